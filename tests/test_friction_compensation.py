"""The friction-compensated contact signal (8.29) and the stick-slip guarded-move graph."""

from types import SimpleNamespace

import numpy as np
import pytest

from contactlab.errors import DataError
from contactlab.observer.graph import parse_graph
from contactlab.signals import compensate_friction, trial_signals


def test_compensation_removes_the_force_along_a_moving_velocity_only():
    rng = np.random.default_rng(0)
    n, sd = 2000, 1e-4
    v = sd * rng.standard_normal((n, 3))
    u = np.array([0.6, 0.8, 0.0])
    v[n // 2:] += 0.004 * u                           # sliding at 4 mm/s along u
    f = rng.normal(size=(n, 3))
    out = compensate_friction(f, v)
    slide = slice(n // 2, None)
    # 8.29 where the finger moves: no component along the velocity, the rest kept
    along = np.einsum("ij,ij->i", out[slide], v[slide])
    assert np.allclose(along, 0.0, atol=1e-12)
    vh = v[slide] / np.linalg.norm(v[slide], axis=1, keepdims=True)
    perp = f[slide] - np.einsum("ij,ij->i", f[slide], vh)[:, None] * vh
    assert np.allclose(out[slide], perp)
    # still: the velocity is its noise; samples under three times its level pass unchanged
    speed = np.linalg.norm(v[:n // 2], axis=1)
    slow = speed <= 3 * sd * 0.95
    assert slow.mean() > 0.9
    assert np.array_equal(out[:n // 2][slow], f[:n // 2][slow])


def _sliding_trial(n=2000, fs=1000.0):
    """A finger sliding along x at 5 mm/s on a plane, friction -0.1 N along x, 0.02 N across."""
    rng = np.random.default_rng(1)
    t = np.arange(n) / fs
    pos = np.zeros((n, 3))
    pos[:, 0] = 0.005 * t
    vel = np.zeros((n, 3))
    vel[:, 0] = 0.005
    vel += 1e-5 * rng.standard_normal((n, 3))
    wrench = np.zeros((n, 6))
    wrench[:, :3] = [-0.1, 0.02, 0.5]
    return SimpleNamespace(id="t", rate_hz=fs, time=t, strain=None, wrench=wrench,
                           position=pos, velocity=vel, labels=None, label_names=None)


def test_the_compensated_contact_signal_drops_the_sliding_friction():
    data, index, fs = trial_signals(_sliding_trial(), ["contact", "contact-compensated"])
    assert fs == 250.0
    raw, comp = data["contact"][100:], data["contact-compensated"][100:]   # past the lowpass's start
    assert np.array_equal(raw[:, :3], comp[:, :3])            # positions untouched
    assert np.allclose(raw[:, 3:], [-0.1, 0.02, 0.5], atol=1e-6)
    # the friction along x removed, the rest kept (the velocity's 1e-5 m/s noise tilts its
    # direction by ~0.2 %, which moves that share of the 0.5 N normal force)
    assert np.abs(comp[:, 3]).max() < 5e-3 and np.abs(raw[:, 3]).min() > 0.09
    assert np.allclose(comp[:, 4:], [0.02, 0.5], atol=5e-3)


def _graph(signal: str, model_signal: str | None = None) -> dict:
    m = {"kind": "constraint", "constraint": "Z", "trained": "floor"}
    if model_signal is not None:
        m["signal"] = model_signal
    return {"name": "g", "edges": ["a -> b", "b -> a"],
            "models": {"C": {**m, "signal": signal},
                       "F": {"kind": "velocity-fixed", "sigma": 0.001}},
            "nodes": [{"name": "a", "models": {"c": "C", "v": "F"}, "initial": 1.0},
                      {"name": "b", "models": {"v": "F"}}]}


def test_a_constraint_model_reads_a_contact_signal():
    assert parse_graph(_graph("contact-compensated")).models["C"].signal == "contact-compensated"
    with pytest.raises(DataError) as err:
        parse_graph(_graph("wrench"))
    assert err.value.field == "models.C.signal" and "\n" not in str(err.value)


def test_models_fitted_on_one_contact_stream_are_refused_by_a_graph_reading_the_other():
    from contactlab.observer.kinematics import fit_kinematic_models
    from contactlab.observer.models.composite import build_models

    rng = np.random.default_rng(2)
    seg = np.concatenate([1e-5 * rng.standard_normal((300, 3)),
                          0.01 * rng.standard_normal((300, 3))], axis=1)
    g_comp = parse_graph(_graph("contact-compensated"))
    fitted = fit_kinematic_models(g_comp, {("contact-compensated", "floor"): [seg]})
    assert fitted["constraint"]["floor"].signal == "contact-compensated"
    build_models(g_comp, fitted["constraint"])                    # its own graph binds it
    with pytest.raises(DataError) as err:
        build_models(parse_graph(_graph("contact")), fitted["constraint"])
    assert err.value.field == "models.C.signal" and "contact-compensated" in str(err.value)


def test_stick_slip_graph_tracks_simulated_guarded_moves(tmp_path):
    """9.1.1's task with 9.1.2's stick-slip transitions and 8.29: simulated runs (labels from
    the simulator, not from the observer) are read 0 1 2 1 3 with stuck nodes as their
    surface, and the stuck intervals are found."""
    from contactlab.acquire.simulated import record_spec
    from contactlab.experiments.guarded_move import STUCK, recognize_stick_slip

    train = record_spec("guarded-move", tmp_path / "train.h5", seed=1)
    test = record_spec("guarded-move", tmp_path / "test.h5", seed=2, n_trials=3)
    res, gm = recognize_stick_slip(train, test)
    assert gm.kinematic["constraint"]["floor-fixed"].degree == 3    # stuck: fully constrained
    for tid, e in res["trials"].items():
        assert e["score"]["correct"], (tid, e["merged_path"])
        assert any(n in STUCK for n, _ in e["merged_path"]), tid
    assert res["accuracy"] > 0.8


def test_constraint_models_trained_on_one_label_read_one_signal():
    doc = _graph("contact-compensated")
    doc["models"]["C2"] = {"kind": "constraint", "constraint": "Z", "trained": "floor",
                           "signal": "contact"}
    doc["nodes"][1]["models"] = {"c": "C2", "v": "F"}
    with pytest.raises(DataError) as err:
        parse_graph(doc)
    assert err.value.field == "models.C2.signal" and "models.C" in str(err.value)
    doc["models"]["C2"]["trained"] = "wall"             # another label: its own model
    assert parse_graph(doc).models["C2"].signal == "contact"
    # a misspelt signal is named with the nearest one a constraint model may read
    with pytest.raises(DataError, match="did you mean 'contact-compensated'"):
        parse_graph(_graph("contact-compensate"))


def test_label_names_a_graph_models_file_for_what_it_is(tmp_path):
    """A models file from ``train --graph`` holding constraint and velocity models only is
    refused by ``label``'s loader with what it holds, not a count of groups."""
    import h5py

    from contactlab.temporal.model import FORMAT, FORMAT_VERSION, ModelSet

    path = tmp_path / "m.h5"
    with h5py.File(path, "w") as h5:
        h5.attrs.update(format=FORMAT, format_version=FORMAT_VERSION, signal="wrench",
                        fs=250.0, labels=np.array([], dtype="S1"), provenance="{}",
                        channels="[]")
        h5.create_group("models")
        h5.create_group("constraints")
    with pytest.raises(DataError) as err:
        ModelSet.load(path)
    assert err.value.field == "/models" and "--graph" in str(err.value)
    assert "\n" not in str(err.value)


def test_graph_show_names_each_models_stream_and_training_label():
    from click.testing import CliRunner

    from contactlab.cli import main

    res = CliRunner().invoke(main, ["graph", "show", "guarded-move-stick-slip"])
    assert res.exit_code == 0, res.output
    lines = res.output.splitlines()
    assert "  model CZ: constraint on contact-compensated, trained on floor-moving" in lines
    assert "  model C3: constraint on contact-compensated, trained on floor-fixed" in lines
    assert "  model S: temporal on hf, trained on free-moving" in lines
