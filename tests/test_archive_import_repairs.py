"""CSV import of real recordings: repeated and out-of-order time stamps, gaps, a sensor
offset, orientation (quaternion or roll/pitch/yaw), a base-frame wrench and time windows."""

from __future__ import annotations

import io
import json

import h5py
import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from contactlab.archive import open_archive, parse_column_map, validate_archive
from contactlab.archive.importer import (import_files, parse_window, quaternion_matrices,
                                         rotate_vectors,
                                         rpy_to_quaternion, window_id)
from contactlab.cli import main
from contactlab.errors import DataError, UsageError

WRENCH = ["fx", "fy", "fz", "tx", "ty", "tz"]
MAP = "time=t;wrench=fx,fy,fz,tx,ty,tz;position=x,y,z;labels=label"


def recording(n=500, rate=100.0, seed=0, offset=(0.5, -0.3, 2.0, 0.01, -0.02, 0.005)):
    """A wrist recording like the real ones: a sensor offset, noise, a press from 2 s to
    3.5 s (label 2; free 1 before and after), a slowly turning tool (quaternion, file order
    qx qy qz qw as the Baxter files write it)."""
    rng = np.random.default_rng(seed)
    t = np.round(np.arange(n) / rate, 5)
    press = (t >= 2.0) & (t < 3.5)
    wrench = rng.normal(0, 0.05, (n, 6)) + np.asarray(offset)
    wrench[press, 2] -= 15.0
    angle = np.linspace(0, 0.6, n)
    frame = pd.DataFrame({"t": t})
    frame[WRENCH] = wrench
    frame[["x", "y", "z"]] = np.column_stack([0.3 + 0.01 * t, 0.1 + 0 * t, 0.2 - 0.001 * t])
    frame["qx"], frame["qy"], frame["qz"], frame["qw"] = (0 * t, 0 * t, np.sin(angle / 2),
                                                          np.cos(angle / 2))
    frame["label"] = np.where(press, 2, 1)
    text = io.StringIO()
    frame.to_csv(text, index=False, float_format="%.9g")
    return pd.read_csv(io.StringIO(text.getvalue()))   # the values as a CSV holds them


def write(frame, path):
    frame.to_csv(path, index=False, float_format="%.9g")
    return path


def test_repeated_stamp_is_an_error_naming_file_column_and_row_and_the_option(tmp_path):
    frame = recording()
    frame.loc[11, "t"] = frame.loc[10, "t"]
    csv = write(frame, tmp_path / "rec.csv")
    with pytest.raises(DataError) as err:
        import_files([csv], out=tmp_path / "o.h5", columns=parse_column_map(MAP), quiet=True)
    assert err.value.file == str(csv) and err.value.field == "t"
    assert "data row 12" in err.value.message and "--repair-time" in err.value.message
    assert not (tmp_path / "o.h5").exists()


def test_repair_sorts_drops_duplicates_averages_shared_stamps_and_records_it(tmp_path):
    frame = recording()
    raw = frame.copy()
    dup = frame.iloc[[40]]                                # an exact duplicate row
    shared = frame.iloc[[70]].copy()                      # a second reading at one stamp
    shared[WRENCH] += 1.0
    shared["label"] = 2                                   # disagreeing label: first kept
    swapped = frame.copy()
    swapped.iloc[[100, 101]] = frame.iloc[[101, 100]].to_numpy()  # out of order
    messy = pd.concat([swapped.iloc[:41], dup, swapped.iloc[41:71], shared,
                       swapped.iloc[71:]], ignore_index=True)
    csv = write(messy, tmp_path / "rec.csv")
    report = import_files([csv], out=tmp_path / "o.h5", columns=parse_column_map(MAP),
                          quiet=True, repair_time=True)
    fix = report.trials["rec"]["time_repair"]
    assert fix == {"rows_reordered": 1, "duplicate_rows_dropped": 1, "stamps_averaged": 1,
                   "rows_merged": 2}
    assert validate_archive(report.path) == []
    with open_archive(report.path) as archive:
        trial = archive.trial("rec")
        assert json.loads(trial.attrs["time_repair"]) == fix
        np.testing.assert_array_equal(trial.time, raw["t"].to_numpy())
        expected = raw[WRENCH].to_numpy().copy()
        expected[70] += 0.5                               # mean of the two readings
        np.testing.assert_allclose(trial.wrench, expected, rtol=0, atol=1e-8)  # 9 digits
        assert trial.labels[70] == trial.label_names.index("1")


def test_gaps_are_counted_not_filled(tmp_path):
    frame = recording()
    frame = frame.drop(index=list(range(200, 230)) + [400]).reset_index(drop=True)
    csv = write(frame, tmp_path / "rec.csv")
    report = import_files([csv], out=tmp_path / "o.h5", columns=parse_column_map(MAP),
                          quiet=True)
    gaps = report.trials["rec"]["gaps"]
    assert gaps["count"] == 1          # one dropped sample is a step of 2: no gap
    assert gaps["longest_s"] == pytest.approx(0.31)
    assert gaps["longest_at_s"] == pytest.approx(1.99)
    assert gaps["missing_samples"] == 30
    with open_archive(report.path) as archive:
        assert archive.trial("rec").n_samples == len(frame)


def test_zero_offset_subtracts_the_rest_mean_and_records_it(tmp_path):
    frame = recording()
    csv = write(frame, tmp_path / "rec.csv")
    report = import_files([csv], out=tmp_path / "o.h5", columns=parse_column_map(MAP),
                          quiet=True, zero_offset_s=1.0)
    raw = frame[WRENCH].to_numpy()
    with open_archive(report.path) as archive:
        trial = archive.trial("rec")
        offset = np.asarray(trial.attrs["wrench_offset"])
        assert trial.attrs["wrench_offset_s"] == 1.0
        np.testing.assert_allclose(offset, raw[:100].mean(axis=0), rtol=1e-12)
        np.testing.assert_allclose(trial.wrench + offset, raw, rtol=0, atol=1e-12)
        assert np.abs(trial.wrench[:100].mean(axis=0)).max() < 1e-12
        assert trial.wrench[250, 2] == pytest.approx(-15.0, abs=0.3)
    with pytest.raises(DataError, match="needs 10 s of samples") as err:
        import_files([csv], out=tmp_path / "p.h5", columns=parse_column_map(MAP),
                     quiet=True, zero_offset_s=10.0)
    assert err.value.field == "fx"


def test_quaternion_columns_are_stored_wxyz_in_map_order(tmp_path):
    frame = recording()
    csv = write(frame, tmp_path / "rec.csv")
    report = import_files([csv], out=tmp_path / "o.h5", quiet=True,
                          columns=parse_column_map(MAP + ";orientation=qw,qx,qy,qz"))
    assert validate_archive(report.path) == []
    with open_archive(report.path) as archive:
        trial = archive.trial("rec")
        np.testing.assert_allclose(trial.orientation, frame[["qw", "qx", "qy", "qz"]],
                                   atol=1e-8)
        assert trial.dataset_attrs("orientation")["convention"] == "wxyz, tool to base"
        assert trial.wrench_frame == "sensor"
    bad = frame.assign(qw=frame["qw"] * 1.5)
    with pytest.raises(DataError, match="not a unit quaternion") as err:
        import_files([write(bad, tmp_path / "bad.csv")], out=tmp_path / "p.h5", quiet=True,
                     columns=parse_column_map(MAP + ";orientation=qw,qx,qy,qz"))
    assert err.value.field == "qw,qx,qy,qz"


def test_validator_flags_a_non_unit_quaternion(tmp_path):
    csv = write(recording(), tmp_path / "rec.csv")
    out = import_files([csv], out=tmp_path / "o.h5", quiet=True,
                       columns=parse_column_map(MAP + ";orientation=qw,qx,qy,qz")).path
    with h5py.File(out, "r+") as f:
        f["trials/rec/measurements/orientation"][5] = [1.0, 0.1, 0.0, 0.0]
    problems = [str(p) for p in validate_archive(out)]
    assert len(problems) == 1 and "not unit quaternions (first: sample 5" in problems[0]


def test_rpy_and_a_base_frame_wrench(tmp_path):
    rpy = np.array([[0.0, 0.0, np.pi / 2], [np.pi / 2, 0, 0], [0.3, -0.4, 1.1]])
    q = rpy_to_quaternion(rpy)
    np.testing.assert_allclose(q[0], [np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)], atol=1e-12)
    rz = lambda a: np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    ry = lambda a: np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])
    rx = lambda a: np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    np.testing.assert_allclose(quaternion_matrices(q)[2], rz(1.1) @ ry(-0.4) @ rx(0.3),
                               atol=1e-12)
    frame = recording(n=300)
    frame["roll"], frame["pitch"], frame["yaw"] = 0.0, 0.0, np.pi / 2   # tool x = base y
    csv = write(frame, tmp_path / "arm.csv")
    report = import_files([csv], out=tmp_path / "o.h5", quiet=True, wrench_frame="base",
                          columns=parse_column_map(MAP + ";rpy=roll,pitch,yaw"))
    assert report.trials["arm"]["wrench_frame"] == "base"
    assert validate_archive(report.path) == []
    raw = frame[WRENCH].to_numpy()
    with open_archive(report.path) as archive:
        trial = archive.trial("arm")
        assert trial.wrench_frame == "base"
        np.testing.assert_allclose(trial.wrench[:, [1, 4]], raw[:, [0, 3]], atol=1e-9)
        np.testing.assert_allclose(trial.wrench[:, [0, 3]], -raw[:, [1, 4]], atol=1e-9)
        np.testing.assert_allclose(trial.wrench[:, [2, 5]], raw[:, [2, 5]], atol=1e-9)
        sensor = trial.h5_group["measurements/wrench_sensor"]
        np.testing.assert_array_equal(sensor[()], raw)      # as measured, kept
        assert sensor.attrs["frame"] == "sensor"
    with pytest.raises(UsageError, match="needs wrench and orientation"):
        import_files([csv], out=tmp_path / "p.h5", quiet=True, wrench_frame="base",
                     columns=parse_column_map(MAP))
    with pytest.raises(UsageError, match="not both"):
        parse_column_map(MAP + ";rpy=roll,pitch,yaw;orientation=qw,qx,qy,qz")


def test_windows_give_one_trial_each(tmp_path):
    frame = recording()
    csv = write(frame, tmp_path / "wipe.csv")
    report = import_files([csv], out=tmp_path / "o.h5", columns=parse_column_map(MAP),
                          quiet=True, windows=[(0, 2.5), (2.5, None)])
    assert list(report.trials) == ["wipe@0-2.5", "wipe@2.5-end"]
    assert validate_archive(report.path) == []
    with open_archive(report.path) as archive:
        first, second = archive.trial("wipe@0-2.5"), archive.trial("wipe@2.5-end")
        assert first.n_samples + second.n_samples == len(frame)
        assert first.time[-1] < 2.5 <= second.time[0]
        np.testing.assert_array_equal(second.time, frame["t"][250:])   # times kept
        assert (first.attrs["window"], second.attrs["window"]) == ("0:2.5", "2.5:")
        assert list(second.segments["label"]) == ["2", "1"]
        assert second.segments["start_s"].iloc[0] == pytest.approx(2.5)
    assert window_id("run", (None, 20.0)) == "run@0-20"
    assert parse_window(" 20: ") == (20.0, None)
    for text in ("20", "a:b", ":", "5:3", "-1:2"):
        with pytest.raises(UsageError):
            parse_window(text)
    with pytest.raises(DataError, match="holds 0 samples") as err:
        import_files([csv], out=tmp_path / "p.h5", columns=parse_column_map(MAP), quiet=True,
                     windows=[(60, 70)])
    assert err.value.field == "--window"


def test_cli_prints_and_reports_repairs(tmp_path):
    frame = recording()
    frame.loc[11, "t"] = frame.loc[10, "t"]
    frame = frame.drop(index=range(300, 320))
    csv = write(frame, tmp_path / "rec.csv")
    args = ["import", str(csv), "--out", str(tmp_path / "o.h5"), "--columns", MAP]
    res = CliRunner().invoke(main, args)
    assert res.exit_code == 1 and "rec.csv: t: time is not strictly increasing" in res.output
    assert "Traceback" not in res.output
    res = CliRunner().invoke(main, args + ["--repair-time", "--zero-offset", "1"])
    assert res.exit_code == 0, res.output
    assert "rec: time repaired: 1 repeated stamp averaged (1 row fewer)" in res.output
    assert "rec: 1 gap in the time base, not filled (longest 0.21 s" in res.output
    assert "rec: wrench offset subtracted: mean of the first 1 s" in res.output
    res = CliRunner().invoke(main, args + ["--repair-time", "--force", "--json",
                                           "--window", "0:2", "--window", "2:"])
    out = json.loads(res.output)
    assert out["trials"] == ["rec@0-2", "rec@2-end"]
    assert out["repairs"]["rec@0-2"]["time_repair"]["stamps_averaged"] == 1
    assert out["repairs"]["rec@2-end"]["gaps"]["count"] == 1
    res = CliRunner().invoke(main, args + ["--window", "oops"])
    assert res.exit_code == 2 and "START:END" in res.output


def turning_imports(tmp_path):
    """A recording whose tool turns (roll 0 -> 0.8 rad), imported three ways: with its
    roll/pitch/yaw and the wrench as measured, the same rotated at import
    (--wrench-frame base), and without the orientation: (frame, sensor, base, plain)."""
    frame = recording(n=400)
    frame["roll"] = np.linspace(0.0, 0.8, len(frame))
    frame["pitch"], frame["yaw"] = -0.3, np.pi / 2
    csv = write(frame, tmp_path / "arm.csv")
    cols = parse_column_map(MAP + ";rpy=roll,pitch,yaw")
    sensor = import_files([csv], out=tmp_path / "s.h5", quiet=True, columns=cols).path
    base = import_files([csv], out=tmp_path / "b.h5", quiet=True, columns=cols,
                        wrench_frame="base").path
    plain = import_files([csv], out=tmp_path / "p.h5", quiet=True,
                         columns=parse_column_map(MAP)).path
    return frame, sensor, base, plain


def test_contact_signals_pair_the_base_frame_position_with_a_base_frame_force(tmp_path):
    """8.10's reciprocity needs the motion and the force in one frame: a trial with its
    orientation and a wrench as measured gives the constraint models the same force as
    one imported with --wrench-frame base (and through a label map too)."""
    from contactlab.signals import relabel, trial_signals

    frame, sensor, base, plain = turning_imports(tmp_path)
    R = quaternion_matrices(rpy_to_quaternion(frame[["roll", "pitch", "yaw"]].to_numpy()))
    expected = np.einsum("nij,nj->ni", R, frame[WRENCH].to_numpy()[:, :3])
    signals = ["contact", "contact-compensated", "velocity"]
    with open_archive(sensor) as s, open_archive(base) as b, open_archive(plain) as p:
        got, _, _ = trial_signals(s.trial("arm"), signals)
        ref, _, _ = trial_signals(b.trial("arm"), signals)
        raw, _, _ = trial_signals(p.trial("arm"), signals)
        mapped, _, _ = trial_signals(relabel(s.trial("arm"), {"1": "a", "2": "b"}), signals)
    for name in ("contact", "contact-compensated"):
        np.testing.assert_allclose(got[name], ref[name], atol=1e-7)
        np.testing.assert_allclose(mapped[name], ref[name], atol=1e-7)
        np.testing.assert_array_equal(raw[name][:, :3], got[name][:, :3])   # position as is
    np.testing.assert_allclose(got["contact"][:, 3:], expected[: len(got["contact"])],
                               atol=1e-7)      # 100 Hz: the 7.1 lowpass passes it unchanged
    assert np.abs(raw["contact"][:, 3:] - got["contact"][:, 3:]).max() > 1.0


def test_phase_stream_reads_the_wrench_in_the_base_frame(tmp_path):
    """The task-phase stream of a trial with its orientation and a wrench as measured is
    the phase stream of the same recording imported with --wrench-frame base: force and
    torque rotated by scipy's rotation of the roll/pitch/yaw, then the 5 Hz lowpass."""
    from scipy.signal import lfilter, lfilter_zi
    from scipy.spatial.transform import Rotation

    from contactlab.signals import phase_filter, trial_signals

    frame, sensor, base, plain = turning_imports(tmp_path)
    with open_archive(sensor) as s, open_archive(base) as b, open_archive(plain) as p:
        got = trial_signals(s.trial("arm"), ["phase"])[0]["phase"]
        ref = trial_signals(b.trial("arm"), ["phase"])[0]["phase"]
        raw = trial_signals(p.trial("arm"), ["phase"])[0]["phase"]
    np.testing.assert_allclose(got, ref, atol=1e-9)
    # the oracle: scipy's rotation (roll, pitch, yaw about fixed x, y, z) of force and torque
    R = Rotation.from_euler("xyz", frame[["roll", "pitch", "yaw"]].to_numpy())
    w = frame[WRENCH].to_numpy()
    x = np.concatenate([R.apply(w[:, :3]), R.apply(w[:, 3:]), raw[:, 6:]], axis=1)
    b_, a_ = phase_filter(100.0)
    oracle = lfilter(b_, a_, x[:, :6], axis=0, zi=lfilter_zi(b_, a_)[:, None] * x[:1, :6])[0]
    np.testing.assert_allclose(got[:, :6], oracle, atol=1e-7)
    np.testing.assert_array_equal(got[:, 6:], raw[:, 6:])        # the velocity as it was
    assert np.abs(got[:, :3] - raw[:, :3]).max() > 1.0


def test_rotate_vectors_agrees_with_scipy_rotation():
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(5)
    q = rng.normal(size=(200, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    v = rng.normal(size=(200, 3))
    oracle = Rotation.from_quat(q[:, [1, 2, 3, 0]]).apply(v)      # scipy: x y z w
    np.testing.assert_allclose(rotate_vectors(q, v), oracle, atol=1e-12)
    np.testing.assert_allclose(rotate_vectors(q, v),
                               np.einsum("nij,nj->ni", quaternion_matrices(q), v), atol=1e-12)
