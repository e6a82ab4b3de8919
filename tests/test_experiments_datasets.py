"""The fact-computing functions of `contactlab reproduce datasets` (thesis outcomes vs the sim)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from contactlab.acquire.sim import simulate_trial
from contactlab.acquire.spec import load_all
from contactlab.experiments import datasets as d


def _specs():
    return {s.name: s for s in load_all()}


# ---------------------------------------------------------------------------
# synthetic inputs
# ---------------------------------------------------------------------------
def test_sliding_phase_position_and_force():
    n = 10
    floor = np.ones(n, bool)
    floor[0] = False
    cmd = np.zeros((n, 3))
    cmd[3:7, 0] = np.arange(1, 5) * 1e-3           # x steps at samples 3..6, then holds
    cmd[7:, 0] = 4e-3
    cmd[:, 2] = -np.linspace(0, 1, n)              # z motion does not count
    phase = d.sliding_phase(cmd, floor, "position")
    assert np.flatnonzero(phase).tolist() == [3, 4, 5, 6]      # steps into samples 3..6

    force = np.zeros((n, 3))
    force[5:] = (0.1, -0.1, -0.2)
    force[:5, 2] = -0.2
    assert np.flatnonzero(d.sliding_phase(force, floor, "force")).tolist() == [5, 6, 7, 8, 9]
    floor[8] = False
    assert np.flatnonzero(d.sliding_phase(force, floor, "force")).tolist() == [5, 6, 7, 9]


def test_stick_episodes_counts_interior_stops_only():
    moving = np.array([0, 0, 1, 1, 0, 1, 1, 0, 0, 0, 1, 1, 0, 0, 0, 1, 0, 0, 0, 0], bool)
    phase = np.zeros(20, bool)
    phase[2:18] = True
    # inside the phase: a 1-sample stop (chatter), a 3-sample stop, a 3-sample stop, and a
    # final stop running to the end of the phase (not a stick-slip: no slip after it)
    assert d.stick_episodes(moving, phase, min_stick=3) == 2
    assert d.stick_episodes(moving, phase, min_stick=1) == 3
    assert d.stick_episodes(moving, phase, min_stick=4) == 0
    # a stop straddling the phase start is not interior
    phase2 = np.zeros(20, bool)
    phase2[8:14] = True                             # starts inside the stop at 7..9
    assert d.stick_episodes(moving, phase2, min_stick=1) == 0
    # two phase segments are counted separately
    phase3 = phase.copy()
    phase3[6] = False                               # split: [2, 6) and [7, 18)
    assert d.stick_episodes(moving, phase3, min_stick=1) == 2
    assert d.stick_episodes(moving, np.zeros(20, bool), min_stick=1) == 0


def test_corner_reached_and_impact_at_contact():
    contact = np.zeros((50, 3), bool)
    contact[20:, 0] = True
    contact[30:, 1] = True
    assert not d.corner_reached(contact)
    contact[-1, 2] = True
    assert d.corner_reached(contact)

    iv = np.array([[5, 9], [23, 40]])
    assert d.impact_at_contact(contact, iv, tolerance=3)       # 23 - 20 = 3
    assert not d.impact_at_contact(contact, iv, tolerance=2)
    assert d.impact_at_contact(contact, np.zeros((0, 2)), tolerance=10) is False
    assert d.impact_at_contact(np.zeros((50, 3), bool), iv, tolerance=10) is None


def test_wall_angle_and_slide_margin():
    from contactlab import sim

    env = sim.ENVIRONMENTS["corner"](angle_y_deg=17.5, angle_x_deg=-4.0)
    assert d.wall_angle_deg(env) == pytest.approx(17.5)
    assert d.wall_angle_deg(env, "wall_x") == pytest.approx(-4.0)

    push = (0.1, 0.1, -0.1)
    # nominal wall: 0.1 N along it against 0.4 x 0.1 (table) + 0.61 x 0.1 (wall) N
    assert d.wall_slide_margin(push, 0.0, 0.4, 0.61) == pytest.approx(0.1 - 0.04 - 0.061)
    # 45 deg: the push lies along the wall, nothing presses into it
    assert d.wall_slide_margin(push, 45.0, 0.4, 0.61) == pytest.approx(math.sqrt(0.02) - 0.04)
    # frictionless: the whole component along the wall
    a = math.radians(20.0)
    assert d.wall_slide_margin(push, 20.0, 0.0, 0.0) == pytest.approx(0.1 * (math.cos(a)
                                                                            + math.sin(a)))


def test_hf_class_means_orders_quiet_and_loud_classes():
    rng = np.random.default_rng(0)
    n = 4000
    moving = np.zeros(n, bool)
    moving[1000:3000] = True
    texture = np.full(n, -1)
    texture[1000:2000] = 0
    texture[2000:3000] = 1
    impact = np.zeros(n, bool)
    impact[990:1010] = True
    scale = np.where(~moving, 0.01, np.where(texture == 0, 1.0, 0.1))
    strain = np.cumsum(rng.normal(size=(n, 8)) * scale[:, None], axis=0)   # diff = noise
    m = d.hf_class_means(strain, 1000.0, moving, impact, texture, n_textures=2)
    assert m["rest"] < m[1] < m[0]
    # log-energy of the differences: the means differ by about log(10) per decade of rms
    assert m[0] - m[1] == pytest.approx(math.log(10.0), abs=0.3)
    assert m[1] - m["rest"] == pytest.approx(math.log(10.0), abs=0.3)
    # a class with no whole block is NaN
    m3 = d.hf_class_means(strain, 1000.0, moving, impact, texture, n_textures=3)
    assert math.isnan(m3[2])


# ---------------------------------------------------------------------------
# short simulated input: the counts match what the truth arrays say
# ---------------------------------------------------------------------------
def test_guarded_move_findings_match_truth():
    specs = _specs()
    facts = d.findings([specs["guarded-move"]], seed=3, trials={"guarded-move": 2})
    assert [f["dataset"] for f in facts] == ["guarded-move", "guarded-move (start of motion)"]
    expected = 0
    for k in range(2):
        _, r = simulate_trial(specs["guarded-move"], k, 3)
        first = int(np.flatnonzero(r.contact.any(axis=1))[0])
        starts = np.asarray(r.impact_intervals).reshape(-1, 2)[:, 0]
        expected += int(np.any(np.abs(starts - first) <= 10))
    assert facts[0]["n"] == 2 and facts[0]["k"] == expected
    assert facts[0]["agrees"] == (expected == 2)
    for f in facts:
        assert {"dataset", "section", "claim", "measured", "agrees", "explanation"} <= set(f)
        assert f["section"] == "9.1.1"


def test_stick_slip_of_a_simulated_position_trial_matches_truth():
    spec = _specs()["guarded-move-multi"]
    _, r = simulate_trial(spec, 0, 1)
    assert r.command_kind == "position"
    phase = d.sliding_phase(r.command, r.contact[:, 0], "position")
    # independent count: runs of "not moving" of >= 10 samples, with moving samples of the
    # same phase run on both sides
    count = 0
    idx = np.flatnonzero(phase)
    segments = np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1)
    for seg in segments:
        mv = r.moving[seg]
        i = 0
        while i < len(mv):
            if not mv[i]:
                j = i
                while j < len(mv) and not mv[j]:
                    j += 1
                if i > 0 and j < len(mv) and j - i >= 10:
                    count += 1
                i = j
            else:
                i += 1
    assert d.stick_episodes(r.moving, phase, min_stick=10) == count
    assert count > 0                                # the position controller stick-slips (9.1.2)


def test_findings_section_renders(tmp_path):
    from contactlab.report.page import ReportPage

    page = ReportPage(title="t", out_dir=tmp_path)
    facts = [d._finding("maze", "9.2", "'claim'", "21 of 21", True, k=21, n=21),
             d._finding("x", "9.1.3", "'c'", "0 of 20", False, "why", k=0, n=20)]
    d._findings_section(page, facts, seed=1, subset={"maze": 5})
    html = page._html()
    assert "What the simulator does beside what the thesis says" in html
    assert "first 5" in html and "why" in html and "NO" in html
