"""Experiments cartesian-estimation, constraint-degree, constraint-direction (8.1.1.2, 8.2, 8.3)
on reduced settings: short runs, few draws, few blocks."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from contactlab.constraints import FORCE_SD, CartesianConstraint, decide_direction
from contactlab.experiments import cartesian_estimation as ce
from contactlab.experiments import constraint_degree as cd
from contactlab.experiments import constraint_direction as cdir

SHORT = 0.4          # s per run: 100 samples at 250 Hz, 400 per group


@pytest.fixture(scope="module")
def groups():
    return ce.load_groups(seed=3, duration_s=SHORT)


def test_groups_carry_the_simulated_geometry(groups):
    assert [groups[g].degree for g in ce.GROUPS] == [0, 1, 2, 3]
    for g in ce.GROUPS:
        gd = groups[g]
        assert len(gd) == 4 * 100 and gd.position.shape == gd.force.shape == (400, 3)
        N = gd.normals
        np.testing.assert_allclose(N.T @ N, np.eye(N.shape[1]), atol=1e-12)
    # plane normal: the spec's wood block lies 8 deg out of level (8.1.1.2's slope); the line's
    # normals span {y, z}; the corner spans R^3
    tilt = np.degrees(np.arccos(abs(groups["plane"].normals[2, 0])))
    assert tilt == pytest.approx(8.0, abs=1e-9)
    Q = groups["line"].normals
    np.testing.assert_allclose(Q @ Q.T, np.diag([0.0, 1.0, 1.0]), atol=1e-12)
    # tare: the free-space group's mean force is zero; contact groups push along their normals
    np.testing.assert_allclose(groups["free"].force.mean(axis=0), 0.0, atol=1e-12)
    fz = groups["plane"].force.mean(axis=0) @ groups["plane"].normals[:, 0]
    assert abs(fz) > 50 * FORCE_SD


def test_constraint_form_recovers_true_normals_and_is_exact_for_free_and_fixed(groups):
    cfgs = [c for c in ce.CONFIGS if c.key in ("constraint-friction", "stiffness-friction")]
    errs = ce.draw_errors(groups, seed=1, sizes=(25, 100), draws=3, configs=cfgs)
    con = errs["constraint-friction"]
    for g in ("free", "corner"):          # nothing to estimate: the frame is exact (NA)
        assert np.all(con[g]["deviation"] <= 1e-12)
    # the PHANToM's kinematic error and the sensor's calibration error (8.1.1.2) leave degrees
    # of error (thesis table 8.3: 1.2 deg on the plane); exact geometry gave 1e-4 deg
    assert np.all(con["plane"]["angle_deg"] < 3.0)
    # the deviation is 1 - cos of the largest principal angle (independent check)
    a = np.radians(con["plane"]["angle_deg"])
    np.testing.assert_allclose(con["plane"]["deviation"], 1 - np.cos(a), atol=1e-12)
    # the constraint form's own criterion never prefers the truth by more than rounding
    # on the plane (the optimum was found)
    assert np.all(con["plane"]["loglik_true"] <= con["plane"]["loglik"] + 1e-6 *
                  np.abs(con["plane"]["loglik"]))
    assert np.all(np.isfinite(errs["stiffness-friction"]["plane"]["angle_deg"]))


def test_true_projection_matches_joint_projection_oracle(groups):
    fit = CartesianConstraint(degree=1).estimate(groups["plane"].position[:50],
                                             groups["plane"].force[:50])
    P = ce.true_projection(groups["plane"].normals, fit.scaling)
    expect = np.zeros((6, 3))
    expect[:3, 0] = groups["plane"].normals[:, 0]
    assert np.allclose(np.abs(P.T @ expect).max(axis=0)[:1], 1.0)
    np.testing.assert_allclose(P.T @ P, np.eye(3), atol=1e-12)


def test_blocks_are_consecutive_within_one_run_and_random_without_repeats(groups):
    rng = np.random.default_rng(0)
    gd = groups["line"]
    idx = cd.consecutive_blocks(gd, n_blocks=200, block=25, rng=rng)
    assert np.all(np.diff(idx, axis=1) == 1)
    assert np.all(gd.run[idx] == gd.run[idx[:, :1]])
    r = cd.random_blocks(gd, n_blocks=50, block=25, rng=rng)
    assert all(len(set(row)) == 25 for row in r.tolist())


def test_posterior_top_is_the_normalised_maximum():
    ll = np.array([[0.0, math.log(3.0)], [-np.inf, 1.0]])
    np.testing.assert_allclose(cd.posterior_top(ll), [0.75, 1.0])


def test_degree_tests_on_rich_blocks_and_the_noise_warning():
    res = cd.run_tests(seed=5, n_blocks=60, duration_s=SHORT)
    r = res["kinds"]["random"]
    y = r["true"]
    assert np.mean(r["likelihood"]["thesis_rule"] == y) > 0.9     # truth from the simulator
    # on these short runs the alignment test misses the line (degree 2) since the PHANToM's
    # kinematic error skews the position frame against the force frame (8.1.1.2); on the
    # full-length runs of reproduce constraint-degree its random-block diagonal is 1, 1, 1, 1
    # (seed 1); free, plane and corner stay right here
    a = np.asarray(r["alignment"])
    for c in (0, 1, 3):
        assert np.mean(a[y == c] == c) > 0.9
    # consecutive blocks decided with their run so far: never worse than the blocks alone
    c = res["kinds"]["consecutive"]
    seq = c["likelihood"]["sequential"]["gated"]
    assert np.mean(seq == c["true"]) >= np.mean(c["likelihood"]["gated"] == c["true"])
    # pure noise: the exploration gate declares it undetermined, the alignment test does not
    assert np.all(res["noise_likelihood"]["gated"] < 0)
    assert np.median(r["noise_alignment_posterior"]) > 0.9


def test_rotation_is_a_rotation_about_the_axis():
    R = cdir.rotation("x", 30.0)
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-15)
    np.testing.assert_allclose(R @ [0, 1, 0], [0, math.cos(math.pi / 6), math.sin(math.pi / 6)],
                               atol=1e-15)
    np.testing.assert_allclose(R @ [1, 0, 0], [1, 0, 0])
    assert cdir.correct_fraction(np.array([1.0, -1.0, 0.0, 0.0])) == 0.5


def test_direction_cannot_tell_top_from_bottom_but_tells_20_degrees(groups):
    gd = groups["plane"]
    rng = np.random.default_rng(2)
    idx = cd.random_blocks(gd, n_blocks=40, block=25, rng=rng)
    fits = CartesianConstraint(degree=1, friction=True).estimate_blocks(
        gd.position[idx], gd.force[idx], gd.velocity[idx])
    N = gd.normals
    _, s = decide_direction(fits, [N, -N])
    np.testing.assert_array_equal(s[:, 0], s[:, 1])
    choice, _ = decide_direction(fits, [N, cdir.rotation("x", 20.0) @ N])
    assert np.mean(choice == 0) > 0.9


@pytest.mark.parametrize("module,kw", [
    (ce, {"sizes": (8, 25, 100), "draws": 2}),
    (cd, {"n_blocks": 40}),
    (cdir, {"angles": (5.0, 20.0), "n_nominal": 2, "blocks": 5}),
])
def test_run_writes_page_and_summary(tmp_path, module, kw):
    summary = module.run(out_dir=tmp_path, seed=0, quiet=True, duration_s=SHORT, **kw)
    assert (tmp_path / "index.html").exists() and (tmp_path / "report.pdf").exists()
    on_disk = json.loads((tmp_path / "results.json").read_text())
    assert on_disk["experiment"] == summary["experiment"]
    assert "Where ours differ" in (tmp_path / "index.html").read_text()


def test_strided_blocks_stay_in_one_run_at_their_stride(groups):
    from contactlab.acquire.cartesian_groups import consecutive_blocks, strided_blocks
    gd = groups["plane"]
    a = consecutive_blocks(gd, n_blocks=50, block=25, rng=np.random.default_rng(4))
    b = strided_blocks(gd, n_blocks=50, block=25, stride=1, rng=np.random.default_rng(4))
    np.testing.assert_array_equal(a, b)
    idx = strided_blocks(gd, n_blocks=200, block=25, stride=3, rng=np.random.default_rng(5))
    assert np.all(np.diff(idx, axis=1) == 3)
    assert np.all(gd.run[idx] == gd.run[idx[:, :1]])         # never across two runs
    with pytest.raises(ValueError, match="no run"):
        strided_blocks(gd, n_blocks=1, block=25, stride=5, rng=np.random.default_rng(0))


def test_free_exploration_is_the_least_rms_excursion_along_the_free_directions():
    from contactlab.acquire.cartesian_groups import GroupData, free_exploration
    # a plane tilted about x; 25 samples once round an ellipse of half-axes a, b in its free
    # directions: the centred columns are orthogonal with sums of squares 25 a^2 / 2 and
    # 25 b^2 / 2, so the least rms excursion is b / sqrt(2) (closed form)
    t = math.radians(10.0)
    n = np.array([0.0, -math.sin(t), math.cos(t)])
    u, w = np.array([1.0, 0.0, 0.0]), np.cross(n, [1.0, 0.0, 0.0])
    th = 2 * np.pi * np.arange(25) / 25
    a, b, sd = 2e-3, 3e-4, 1e-5
    pos = 0.01 + np.outer(a * np.cos(th), u) + np.outer(b * np.sin(th), w) + 0.2 * n
    gd = GroupData("plane", pos, np.zeros_like(pos), np.zeros_like(pos), n[:, None],
                   np.zeros(25, int), np.ones(25, int))
    got = free_exploration(gd, np.arange(25)[None], position_sd=sd)
    assert got[0] == pytest.approx(b / math.sqrt(2) / sd, rel=1e-9)
    corner = GroupData("corner", pos, pos, pos, np.eye(3), np.zeros(25, int), np.ones(25, int))
    assert np.isnan(free_exploration(corner, np.arange(25)[None], position_sd=sd)).all()


@pytest.fixture(scope="module")
def longer_groups():
    """Test and training groups of 0.8 s runs (200 samples: blocks spread up to 0.77 s)."""
    return ce.load_groups(seed=6, duration_s=0.8), ce.load_groups(seed=7, duration_s=0.8)


def test_the_degree_test_follows_what_a_block_explores(longer_groups):
    # the measured cause of the 0.1 s blocks' confusions: the longer a block's samples are
    # spread over its run, the more it explores and the more blocks are decided right
    sp = cd.span_test(longer_groups[0], seed=6, n_blocks=80, block=25)
    strides = [r["stride"] for r in sp["by_stride"]]
    assert strides == [1, 2, 4, 8]            # 16 does not fit a 200-sample run
    first, last = sp["by_stride"][0], sp["by_stride"][-1]
    for i in (1, 2):                          # plane and line
        assert last["median_exploration_sd"][i] > 10 * first["median_exploration_sd"][i]
        assert last["correct_by_class"][i] >= first["correct_by_class"][i] + 0.2
    rich = [r for r in sp["by_exploration"] if r["from_sd"] >= 30.0 and r["plane"]["blocks"]]
    poor = sp["by_exploration"][0]
    assert rich and all(r["plane"]["correct"] > poor["plane"]["correct"] for r in rich)


def test_the_direction_test_follows_what_a_block_explores(longer_groups):
    sp = cdir.span_curves(*longer_groups, seed=6, n_nominal=4, blocks=25)
    for case in ("one contact", "two contacts"):
        rows = [r for r in sp if r["case"] == case]
        assert [r["stride"] for r in rows] == [1, 2, 4, 8]
        first, last = rows[0], rows[-1]
        assert last["median_exploration_sd"] > 10 * first["median_exploration_sd"]
        # 100 decisions a point: at 5 deg the spread blocks are right at least 0.2 more often
        assert last["correct"][0] >= first["correct"][0] + 0.2
        assert min(last["correct"]) >= 0.95
