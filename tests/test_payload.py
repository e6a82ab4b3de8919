"""A turning tool's payload and sensor offset: the fit of contactlab.payload against
least squares and simulated truth, and recognition that removes the drift they cause."""

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from contactlab.archive.importer import quaternion_matrices
from contactlab.payload import MARGIN_S, Payload, fit_payload, free_mask
from contactlab.synthetic.free_contact import free_contact_recording

from conftest import one_json_object, run_cli

G = 9.81


def _turning(n, degrees, seed=0):
    """(n, 4) quaternions (w x y z): the tool turns smoothly by ``degrees`` about one
    random axis, then by as much about another (about one axis only, the components of
    w and o along it cannot be told apart)."""
    rng = np.random.default_rng(seed)
    h = n // 2
    rots = []
    for m in (h, n - h):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        ang = np.radians(degrees) * 0.5 * (1 - np.cos(np.linspace(0, np.pi, m)))
        rots.append(Rotation.from_rotvec(ang[:, None] * axis))
    whole = Rotation.concatenate([rots[0], rots[1] * rots[0][-1]])
    return whole.as_quat()[:, [3, 0, 1, 2]]


def _sensor_force(q, f_base, weight, offset):
    """What a wrist sensor reads: ``R^T (f_base + weight) + offset``."""
    R = quaternion_matrices(q)
    return np.einsum("nji,nj->ni", R, f_base + weight) + offset


def test_fit_recovers_weight_and_offset_like_least_squares():
    rng = np.random.default_rng(1)
    n, fs = 2000, 200.0
    q = _turning(n, 40.0)
    w, o = np.array([0.5, -1.0, -4.4]), np.array([2.0, -0.7, 1.5])
    f = _sensor_force(q, np.zeros((n, 3)), w, o) + rng.normal(0, 0.05, (n, 3))
    p = fit_payload(q, f, np.ones(n, bool), fs=fs)
    # independent oracle: unweighted least squares on the stacked system [I, R] theta = R f
    R = quaternion_matrices(q)
    A = np.concatenate([np.tile(np.eye(3), (n, 1)), R.reshape(-1, 3)], axis=1)
    b = np.einsum("nij,nj->ni", R, f).ravel()
    theta = np.linalg.lstsq(A, b, rcond=None)[0]
    np.testing.assert_allclose(p.weight_n, theta[:3], atol=0.02)
    np.testing.assert_allclose(p.offset_n, theta[3:], atol=0.02)
    np.testing.assert_allclose(p.weight_n, w, atol=0.05)
    np.testing.assert_allclose(p.offset_n, o, atol=0.05)
    assert 40.0 <= p.turn_deg <= 80.0
    assert p.free_s == pytest.approx(n / fs)
    # the correction takes the drift and the offset out: free space reads zero
    fb = np.einsum("nij,nj->ni", R, f)
    left = fb - p.correction(q)
    assert np.ptp(fb, axis=0).max() > 1.5
    assert np.abs(left).max() < 0.3


def test_without_a_turn_the_fit_is_a_constant_and_bounded():
    """Only w + R o is seen: the correction is the mean force (a tare) and the prior
    keeps w and o near the scale of a payload."""
    rng = np.random.default_rng(2)
    n = 1000
    q = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    f = np.array([0.3, -0.2, 1.0]) + rng.normal(0, 0.05, (n, 3))
    p = fit_payload(q, f, np.ones(n, bool), fs=200.0)
    np.testing.assert_allclose(p.correction(q), np.tile(f.mean(axis=0), (n, 1)), atol=1e-3)
    assert np.linalg.norm(p.weight_n) < 5 and np.linalg.norm(p.offset_n) < 5
    assert p.turn_deg == pytest.approx(0.0, abs=1e-6)


def test_too_little_free_space_is_not_fitted():
    q = _turning(1000, 30.0)
    mask = np.zeros(1000, bool)
    mask[:99] = True                                # 0.495 s at 200 Hz
    assert fit_payload(q, np.zeros((1000, 3)), mask, fs=200.0) is None
    mask[:100] = True
    assert isinstance(fit_payload(q, np.zeros((1000, 3)), mask, fs=200.0), Payload)


def test_free_mask_takes_free_segments_less_the_margin():
    fs_raw = 1000.0
    index = np.arange(3, 4000, 4)                   # conditioned points, 4:1
    path = [("free", 0), ("contact", 250), ("free", 600), ("impact", 700)]
    m = free_mask(path, index, {"free"}, 4000, fs_raw=fs_raw)
    k = int(MARGIN_S * fs_raw)
    first = np.flatnonzero(m[: index[249] + 1])
    assert first[0] == index[0] + k and first[-1] == index[249] - k
    second = np.flatnonzero(m[index[250]:]) + index[250]
    assert second[0] == index[600] + k and second[-1] == index[699] - k
    assert m.sum() == (index[249] - index[0] + 1 - 2 * k) + (index[699] - index[600] + 1 - 2 * k)


def _csv(tmp_path, name, seed, degrees, *extra):
    """A hand-held tool's recording (contactlab.synthetic.free_contact) read by a wrist
    sensor of 0.1 N noise carrying a 0.45 kg tool, zeroed at the start: first held in
    free space for 3 s while the tool turns ``degrees`` about one axis and as much about
    another (as HIRO's later trials turn theirs on the approach), then the recording."""
    rec = free_contact_recording(seed=seed, fs=200.0, cycles=3, force_sd=0.1)
    k = 600
    rng = np.random.default_rng(seed)
    hold = {"position": np.repeat(rec.position[:1], k, axis=0) + rng.normal(0, 0.05e-3, (k, 3)),
            "force": rng.normal(0, 0.1, (k, 3)), "labels": np.ones(k, np.int64)}
    pos = np.concatenate([hold["position"], rec.position])
    base = np.concatenate([hold["force"], rec.force])
    labels = np.concatenate([hold["labels"], rec.labels])
    n = len(pos)
    q = _turning(k, degrees, seed)
    q = np.concatenate([q, np.repeat(q[-1:], n - k, axis=0)])
    w = np.array([0.0, 0.0, -0.45 * G])
    o = -quaternion_matrices(q[:1])[0].T @ w        # zeroed with the tool held still
    f = _sensor_force(q, base, w, o)
    cols = pd.DataFrame({"t": np.arange(n) / 200.0, "fx": f[:, 0], "fy": f[:, 1],
                         "fz": f[:, 2], "tx": 0.0, "ty": 0.0, "tz": 0.0, "x": pos[:, 0],
                         "y": pos[:, 1], "z": pos[:, 2], "state": labels,
                         "qw": q[:, 0], "qx": q[:, 1], "qy": q[:, 2], "qz": q[:, 3]})
    path = tmp_path / f"{name}.csv"
    cols.to_csv(path, index=False)
    out = tmp_path / f"{name}.h5"
    r = run_cli("import", path, "--out", out, "-q", "--columns",
                "time=t;wrench=fx,fy,fz,tx,ty,tz;position=x,y,z;labels=state;"
                "orientation=qw,qx,qy,qz", *extra)
    assert r.exit_code == 0, r.output
    return out, rec


def _trained(tmp_path, test_degrees, *extra):
    """(test archive, models file): free-contact trained on a tool that does not turn;
    ``extra``: the test recording's import options."""
    train, _ = _csv(tmp_path, "still", 11, 0.0)
    test, _ = _csv(tmp_path, "test", 12, test_degrees, *extra)
    models = tmp_path / "m.h5"
    r = run_cli("train", train, "--graph", "free-contact", "--label-map", "1=free,2=contact,3=free",
                "--out", models, "-q")
    assert r.exit_code == 0, r.output
    return test, models


def test_recognition_removes_a_turning_payloads_drift(tmp_path):
    """Trained where the tool does not turn; recognised where it turns 16 deg in free
    space with a 4.4 N tool (the free force drifts by 1.2 N, 12 sd of the sensor's
    noise): the first pass reads the drift as contact, the later ones, on the corrected
    force, follow the labels, and the weight is reported."""
    from contactlab.archive import open_archive
    from contactlab.observer import observe_trial
    from contactlab.observer.recognize import bind_models

    test, models = _trained(tmp_path, 10.0)
    r = run_cli("recognize", test, "--graph", "free-contact", "--models", models, "--json",
                "-q", "--no-write")
    assert r.exit_code == 0, r.output
    (tid, trial), = one_json_object(r.stdout)["trials"].items()
    assert trial["accuracy"] > 0.95 and trial["payload_status"] == "applied"
    check = trial["payload_check"]
    assert check["passes"] >= 2 and check["gain_nats"] > check["bic_nats"] > 0
    weight = np.array(trial["payload"]["weight_base_n"])
    np.testing.assert_allclose(weight, [0.0, 0.0, -0.45 * G], atol=0.6)
    assert trial["payload"]["turn_deg"] > 12
    assert max(trial["payload"]["weight_sd_n"]) < 0.6
    # the text output says what was fitted; --no-payload recognises once, as recorded
    r = run_cli("recognize", test, "--graph", "free-contact", "--models", models, "-q",
                "--no-write")
    assert r.exit_code == 0 and "  payload: constant base-frame force [" in r.stdout
    assert "tell them apart" not in r.stdout                 # a 16 deg turn separates them
    r = run_cli("recognize", test, "--graph", "free-contact", "--models", models, "--json",
                "-q", "--no-write", "--no-payload")
    (_, alone), = one_json_object(r.stdout)["trials"].items()
    assert alone["payload"] is None and alone["payload_status"].startswith("disabled")
    assert alone["accuracy"] < trial["accuracy"] - 0.05

    graph, _, built = bind_models("free-contact", models)
    with open_archive(test) as a:
        tr = a.trial(tid)
        free = np.asarray(tr.labels) != list(tr.label_names).index("2")
        once = observe_trial(tr, graph, built, payload=False)
        twice = observe_trial(tr, graph, built)
    node = graph.node_names.index("free")
    assert once.payload is None and twice.payload is not None
    read_once = once.result.labels[free[once.index]] == node
    read_twice = twice.result.labels[free[twice.index]] == node
    assert read_twice.mean() > 0.95
    assert read_once.mean() < read_twice.mean() - 0.1     # the drift read as contact


def test_a_payload_that_explains_nothing_is_not_kept(tmp_path):
    """A zeroed sensor on a tool that does not turn: the fit is a tare of a few mN, the
    second pass's path is no likelier by BIC's 3 log n, and the first pass is kept,
    streams and all."""
    from contactlab.archive import open_archive
    from contactlab.observer import observe_trial
    from contactlab.observer.recognize import bind_models

    test, models = _trained(tmp_path, 0.0)
    graph, _, built = bind_models("free-contact", models)
    with open_archive(test) as a:
        tr = a.trial(a.trial_ids[0])
        once = observe_trial(tr, graph, built, payload=False)
        kept = observe_trial(tr, graph, built)
    assert kept.payload is None
    np.testing.assert_array_equal(kept.result.labels, once.result.labels)
    assert kept.observer is not None
    for s in once.data:
        np.testing.assert_array_equal(kept.data[s], once.data[s])


def test_a_base_frame_wrench_is_corrected_too(tmp_path):
    """The README's import with --wrench-frame base stores the wrench rotated, the
    sensor's kept aside: the fit reads the force back in the sensor's axes and gives
    what the sensor-frame import gives."""
    test, models = _trained(tmp_path, 10.0, "--wrench-frame", "base")
    r = run_cli("recognize", test, "--graph", "free-contact", "--models", models, "--json",
                "-q", "--no-write")
    assert r.exit_code == 0, r.output
    (_, trial), = one_json_object(r.stdout)["trials"].items()
    assert trial["payload_status"] == "applied" and trial["accuracy"] > 0.95
    np.testing.assert_allclose(trial["payload"]["weight_base_n"], [0.0, 0.0, -0.45 * G],
                               atol=0.6)


def test_why_a_payload_is_not_corrected_is_said(tmp_path):
    """Too little free space before the first pass leaves it (a window starting on the
    surface), and a recording without an orientation: the status says which."""
    from contactlab.archive import open_archive
    from contactlab.observer import observe_trial
    from contactlab.observer.recognize import bind_models, payload_line

    test, models = _trained(tmp_path, 10.0)
    graph, _, built = bind_models("free-contact", models)
    with open_archive(test) as a:
        tr = a.trial(a.trial_ids[0])
        first = np.flatnonzero(np.asarray(tr.labels) == list(tr.label_names).index("2"))[0]
    short = tmp_path / "short.h5"
    r = run_cli("import", tmp_path / "test.csv", "--out", short, "-q", "--window",
                f"{(first - 60) / 200.0}:", "--columns",
                "time=t;wrench=fx,fy,fz,tx,ty,tz;position=x,y,z;labels=state;"
                "orientation=qw,qx,qy,qz")
    assert r.exit_code == 0, r.output
    with open_archive(short) as a:
        run = observe_trial(a.trial(a.trial_ids[0]), graph, built)
    assert run.payload is None and run.payload_status.startswith("free space too short")
    assert payload_line(None, run.payload_status).startswith("payload not corrected: free")
    assert payload_line(None, "disabled (--no-payload)") is None
    # a recording without an orientation, on a graph that reads force in free space: said
    plain = tmp_path / "plain.h5"
    r = run_cli("import", tmp_path / "test.csv", "--out", plain, "-q", "--columns",
                "time=t;wrench=fx,fy,fz,tx,ty,tz;position=x,y,z;labels=state")
    assert r.exit_code == 0, r.output
    with open_archive(plain) as a:
        run = observe_trial(a.trial(a.trial_ids[0]), graph, built)
    assert run.payload is None and run.payload_status.startswith("no orientation")


def test_a_fit_survives_its_json_form():
    q = _turning(1000, 30.0)
    f = _sensor_force(q, np.zeros((1000, 3)), np.array([0.0, 0.0, -4.0]), np.zeros(3))
    p = fit_payload(q, f, np.ones(1000, bool), fs=200.0)
    back = Payload.from_dict(p.to_dict())
    np.testing.assert_array_equal(back.correction(q), p.correction(q))
    assert back.text() == p.text()
