"""Shared fixtures: small synthetic archives written with the archive writer."""

from __future__ import annotations

import os
import signal

os.environ.setdefault("MPLBACKEND", "Agg")      # as the CLI does: figures go to files

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from contactlab.archive import create_archive  # noqa: E402

RATE_HZ = 1000.0


@pytest.fixture(autouse=True)
def _signal_handlers_restored():
    """A CLI run that received a signal ignores later ones (it is exiting); in the test
    process the handlers are put back after each test."""
    saved = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    yield
    for s, handler in saved.items():
        signal.signal(s, handler)

LABEL_NAMES = ["free", "contact", "sliding"]


def synthetic_measurements(n: int, *, rate_hz: float = RATE_HZ, seed: int = 0,
                           t0: float = 0.0) -> dict:
    """Plausible per-sample data: 8 strains, their wrench, position, velocity, action, command."""
    rng = np.random.default_rng(seed)
    time = t0 + np.arange(n) / rate_hz
    calibration = rng.normal(size=(6, 8))
    strain = rng.normal(scale=1e-3, size=(n, 8)) + np.sin(time)[:, None]
    position = np.column_stack([0.1 * time, np.zeros(n), -0.01 * np.ones(n)])
    return {
        "time": time,
        "strain": strain,
        "wrench": strain @ calibration.T,
        "position": position,
        "velocity": np.gradient(position, time, axis=0) if n > 1 else np.zeros((n, 3)),
        "action": (time > time[n // 2]).astype(np.int16) if n else np.zeros(0, np.int16),
        "command": position + 0.001,
        "calibration": calibration,
    }


def synthetic_labels(time: np.ndarray) -> tuple[np.ndarray, list]:
    """Three labelled phases and one unlabelled sample; the matching segment rows."""
    n = len(time)
    labels = np.zeros(n, dtype=np.int16)
    labels[n // 3:] = 1
    labels[2 * n // 3:] = 2
    labels[0] = -1
    edges = [time[0], time[n // 3], time[2 * n // 3], time[-1]]
    segments = [(edges[i], edges[i + 1], LABEL_NAMES[i]) for i in range(3)]
    return labels, segments


def write_archive(path, *, trials=("t01", "t02"), n: int = 1500, chunks: int = 3,
                  ground_truth: bool = True, incremental: bool = False, force: bool = False):
    """Write a valid archive with every dataset of the format; returns the data written."""
    written = {}
    with create_archive(path, title="fixture", force=force, incremental=incremental) as archive:
        for i, tid in enumerate(trials):
            data = synthetic_measurements(n, seed=i)
            trial = archive.add_trial(tid, rate_hz=RATE_HZ, controller="position",
                                      environment="plane", seed=i, source="simulator",
                                      description=f"fixture trial {i}",
                                      calibration=data["calibration"],
                                      command_columns=["x", "y", "z"], command_units="m",
                                      action_names=["approach", "press"])
            for rows in np.array_split(np.arange(n), chunks):
                trial.append(**{k: data[k][rows] for k in
                                ("time", "strain", "wrench", "position", "velocity", "action",
                                 "command")})
            if ground_truth:
                labels, segments = synthetic_labels(data["time"])
                trial.set_ground_truth(labels=labels, names=LABEL_NAMES, segments=segments)
                data["labels"], data["segments"] = labels, segments
            trial.close()
            written[tid] = data
    return written


@pytest.fixture
def archive_path(tmp_path):
    """A valid two-trial archive with measurements, ground truth and no results."""
    path = tmp_path / "runs.h5"
    write_archive(path)
    return path


def run_cli(*args):
    """Invoke the contactlab CLI in-process with string arguments."""
    from click.testing import CliRunner

    from contactlab.cli import main
    return CliRunner().invoke(main, [str(a) for a in args])


def one_json_object(stdout: str) -> dict:
    """Assert ``stdout`` is exactly one JSON object on one line and return it."""
    import json

    lines = stdout.strip().splitlines()
    assert len(lines) == 1, stdout
    obj = json.loads(lines[0])
    assert isinstance(obj, dict)
    return obj


def assert_same_observer_results(fast, slow) -> None:
    """Two observers' results (the compiled core's and the general form's) agree: the same
    events, paths and path log-likelihoods to the bit, node probabilities to rounding."""
    assert len(fast.events) == len(slow.events)
    for a, b in zip(fast.events, slow.events):
        assert (a.time, a.path, a.node, a.model, a.change_time) == \
            (b.time, b.path, b.node, b.model, b.change_time)
        assert (a.spawned, a.merged) == (b.spawned, b.merged)
        np.testing.assert_array_equal(a.candidates_loglik, b.candidates_loglik)
        np.testing.assert_array_equal(a.kept, b.kept)
    assert fast.map_path == slow.map_path
    np.testing.assert_array_equal(fast.map_node, slow.map_node)
    np.testing.assert_allclose(fast.node_prob, slow.node_prob, rtol=0, atol=1e-12)
    assert [(p.id, p.node, p.start, p.loglik, p.history) for p in fast.paths] == \
        [(p.id, p.node, p.start, p.loglik, p.history) for p in slow.paths]
