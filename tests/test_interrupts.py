"""Nothing finished is lost, whatever signals come: one, two or three SIGINT/SIGTERM,
or a SIGKILL, at random moments of acquire, import and the verbs that write.

After each: the archive validates, every trial the run said it finished is there
with its measurements byte for byte (the same seed gives the same trials), stage
results that were there before are intact, and no temporary file is left (a
SIGKILL's is played back or removed by the next run on the archive).

``make test`` runs a sample; ``make stress`` (CONTACTLAB_STRESS=1) hundreds.
"""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import threading
import time

import h5py
import pytest
from conftest import write_archive
from test_acquire_cli import QUICK
from test_stages import measurement_bytes

from contactlab.archive import validate_archive
from contactlab.interrupt import signal_line

STRESS = bool(os.environ.get("CONTACTLAB_STRESS"))
INT, TERM, KILL = signal.SIGINT, signal.SIGTERM, signal.SIGKILL
PLANS = [(INT,), (INT, INT), (INT, INT, INT), (TERM,), (TERM, TERM), (TERM, INT, TERM),
         (KILL,)]
GRAPH = "datasets_spec/graphs/hf-context-free.toml"
N_TRIALS = 8


def _temps(folder):
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".tmp"))


class _Run:
    """A contactlab child process whose stderr lines are collected as they come."""

    def __init__(self, *args):
        self.proc = subprocess.Popen([sys.executable, "-m", "contactlab", *map(str, args)],
                                     stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                     text=True, env=dict(os.environ, PYTHONUNBUFFERED="1"))
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self):
        for line in self.proc.stderr:
            self.lines.append(line.rstrip("\n"))

    def wait_for(self, text, timeout=120.0) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if any(text in line for line in self.lines):
                return True
            if self.proc.poll() is not None:
                self._reader.join(10)
                return any(text in line for line in self.lines)
            time.sleep(0.002)
        return False

    def signal(self, plan, rng) -> int:
        for k, sig in enumerate(plan):
            if self.proc.poll() is not None:
                break
            self.proc.send_signal(sig)
            if k + 1 < len(plan):
                time.sleep(rng.choice([0.0, 0.001, 0.01, 0.05, rng.uniform(0, 0.2)]))
        code = self.proc.wait(timeout=120)
        self._reader.join(10)
        return code


def _check_exit(run, code, plan):
    """No traceback; exit 0 (the work was done first) or 128 + one of the signals, with
    the line that says so last. (Signals that arrive together are handled in the order
    of their numbers, so the first sent need not be the first seen.)"""
    err = "\n".join(run.lines)
    assert "Traceback" not in err and "internal error" not in err, err
    assert "Exception ignored" not in err, err
    if plan[0] == KILL:
        assert code in (0, -KILL), err
        return
    assert code in {0} | {128 + s for s in plan}, (code, err)
    if code:
        assert run.lines[-1] == f"contactlab: {signal_line(code - 128)}", err


def _interrupt(run, plan, rng, path, folder, *, archive=True):
    """Send ``plan``'s signals, check the exit, let the next run on ``path`` (an archive,
    or another output) clean up after a SIGKILL, and check that no temporary file is
    left; the exit status."""
    code = run.signal(plan, rng)
    _check_exit(run, code, plan)
    if plan[0] == KILL:
        _next_run_cleans_up(path, folder, archive=archive)
    assert _temps(folder) == []
    return code


def _next_run_cleans_up(path, folder, *, archive=True):
    """The next run on the archive plays back or removes what a SIGKILL left."""
    if archive and path.exists():
        res = subprocess.run([sys.executable, "-m", "contactlab", "validate", str(path)],
                             capture_output=True, text=True, timeout=120)
        assert res.returncode == 0, res.stderr + res.stdout
    else:  # no archive in place: what the next write of it removes first
        from contactlab.fileio import remove_stale_temp_files

        remove_stale_temp_files(path, notify=None)
    assert _temps(folder) == []


# -- acquire ------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def spec(tmp_path_factory):
    path = tmp_path_factory.mktemp("spec") / "quick.toml"
    path.write_text(QUICK.format(duration=4.0, trials=N_TRIALS))
    return path


@pytest.fixture(scope="module")
def reference(spec, tmp_path_factory):
    """Every trial of an uninterrupted run with the same seed."""
    out = tmp_path_factory.mktemp("ref") / "ref.h5"
    res = subprocess.run([sys.executable, "-m", "contactlab", "acquire", "--spec", spec,
                          "--out", out, "--seed", "3", "-q"], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    return measurement_bytes(out)


def _check_trials(path, reference, finished):
    """The archive holds a prefix of the reference's trials, byte for byte, at least
    every trial the run said it finished."""
    if not path.exists():
        assert finished == [], finished
        return []
    assert validate_archive(path) == []
    kept = measurement_bytes(path)
    ids = list(kept)
    assert ids == list(reference)[:len(ids)]
    assert set(finished) <= set(ids), (finished, ids)
    for tid in ids:
        assert kept[tid] == reference[tid], tid
    with h5py.File(path, "r") as f:
        assert all(f["trials"][tid].attrs["complete"] for tid in ids)
    return ids


@pytest.mark.parametrize("plan", PLANS, ids=["-".join(signal.Signals(s).name[3:] for s in p)
                                             for p in PLANS])
def test_acquire_keeps_every_finished_trial_whatever_the_signals(spec, reference, tmp_path,
                                                                 plan):
    rng = random.Random(hash(plan) % 1000)
    for attempt in range(20 if STRESS else 1):
        folder = tmp_path / f"a{attempt}"
        folder.mkdir()
        out = folder / "x.h5"
        run = _Run("acquire", "--spec", spec, "--out", out, "--seed", 3)
        assert run.wait_for(f"written ({rng.randint(1, 3)}/{N_TRIALS})"), run.lines
        time.sleep(rng.uniform(0.0, 0.4))
        code = _interrupt(run, plan, rng, out, folder)
        finished = [line.split()[2] for line in run.lines if " written (" in line]
        ids = _check_trials(out, reference, finished)
        if plan[0] != KILL and code and len(finished) < N_TRIALS:
            kept = run.lines[-2]  # the run said what it kept, the line before the last
            assert kept.startswith(f"contactlab: {out}: {len(ids)} finished trial") \
                or (not ids and "no trial was finished" in kept), run.lines


def test_a_second_signal_quits_at_once_and_rolls_the_trial_in_progress_back(tmp_path):
    """Both signals land while a trial is half written (the writer's deferred section):
    the second quits from the handler, returning the file to its last finished trial."""
    script = f"""
import os, signal, sys
sys.path.insert(0, {os.path.dirname(__file__)!r})
from conftest import synthetic_measurements
from contactlab.archive import create_archive
from contactlab.interrupt import signals_as_interrupt
data = synthetic_measurements(3000)
fields = ("time", "strain", "wrench", "position")
with signals_as_interrupt():
    with create_archive(sys.argv[1], incremental=True) as archive:
        with archive.add_trial("t1", rate_hz=1000.0) as trial:
            trial.append(**{{k: data[k] for k in fields}})
        open(sys.argv[2], "wb").write(open(sys.argv[1], "rb").read())
        trial = archive.add_trial("t2", rate_hz=1000.0)
        trial.append(**{{k: data[k][:1500] for k in fields}})
        archive.flush()
        os.kill(os.getpid(), signal.SIGTERM)   # deferred: raised at the next safe point
        os.kill(os.getpid(), signal.SIGINT)    # the second: quit now
        print("not reached", flush=True)
"""
    out, snapshot = tmp_path / "x.h5", tmp_path / "snapshot.h5"
    res = subprocess.run([sys.executable, "-c", script, str(out), str(snapshot)],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 128 + TERM, res.stderr
    assert "not reached" not in res.stdout
    assert res.stderr.splitlines() == [
        f"contactlab: {out}: 1 finished trial kept (t1); the unfinished trial t2 is dropped",
        "contactlab: terminated (SIGTERM)"]
    assert out.read_bytes() == snapshot.read_bytes()
    assert _temps(tmp_path) == []


def test_an_archive_being_recorded_is_neither_read_nor_replaced(tmp_path):
    from conftest import write_archive as write

    from contactlab.journal import SUFFIX

    path = tmp_path / "x.h5"
    write(path, n=200)
    before = path.read_bytes()
    sleeper = subprocess.Popen(["sleep", "30"])  # the recording process, alive
    journal = tmp_path / f".x.h5.{sleeper.pid}-abcd1234{SUFFIX}"
    journal.write_bytes(b"")
    try:
        for args in (("info", path), ("validate", path), ("segment", path, "-q"),
                     ("acquire", "--spec", "stroke-a", "--out", path, "--force", "-q")):
            res = subprocess.run([sys.executable, "-m", "contactlab", *map(str, args)],
                                 capture_output=True, text=True, timeout=120)
            assert res.returncode == 1, (args, res.stderr)
            assert res.stderr.splitlines() == [
                f"contactlab: error: {path}: is being recorded by a running process "
                f"(pid {sleeper.pid}); wait for it to end"], res.stderr
    finally:
        sleeper.kill()
        sleeper.wait()
    assert path.read_bytes() == before
    res = subprocess.run([sys.executable, "-m", "contactlab", "info", str(path)],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0 and not journal.exists(), res.stderr  # its run is gone


# -- import -------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def csv_files(tmp_path_factory):
    import numpy as np

    folder = tmp_path_factory.mktemp("csv")
    rng = np.random.default_rng(0)
    header = "t," + ",".join(f"s{i}" for i in range(8)) + ",fx,fy,fz,tx,ty,tz"
    paths = []
    for k in range(N_TRIALS):
        data = np.column_stack([np.arange(20000) / 1000.0, rng.normal(size=(20000, 14))])
        path = folder / f"run{k}.csv"
        np.savetxt(path, data, delimiter=",", header=header, comments="", fmt="%.6g")
        paths.append(path)
    return paths


IMPORT_COLUMNS = "time=t;strain=s*;wrench=fx,fy,fz,tx,ty,tz"


@pytest.fixture(scope="module")
def imported(csv_files, tmp_path_factory):
    out = tmp_path_factory.mktemp("imp") / "ref.h5"
    res = subprocess.run([sys.executable, "-m", "contactlab", "import", *csv_files, "--out",
                          out, "--columns", IMPORT_COLUMNS, "-q"], capture_output=True,
                         text=True)
    assert res.returncode == 0, res.stderr
    return measurement_bytes(out)


@pytest.mark.parametrize("plan", PLANS if STRESS else [(INT, INT), (KILL,)],
                         ids=lambda p: "-".join(signal.Signals(s).name[3:] for s in p))
def test_import_keeps_every_finished_trial_whatever_the_signals(csv_files, imported,
                                                                tmp_path, plan):
    rng = random.Random(7 + len(plan))
    for attempt in range(6 if STRESS else 2):
        folder = tmp_path / f"i{attempt}"
        folder.mkdir()
        out = folder / "x.h5"
        run = _Run("import", *csv_files, "--out", out, "--columns", IMPORT_COLUMNS, "-q")
        deadline = time.monotonic() + 120
        while not _temps(folder) and run.proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.002)  # the writing has started
        time.sleep(rng.uniform(0.0, 0.3))
        code = _interrupt(run, plan, rng, out, folder)
        ids = _check_trials(out, imported, [])
        assert code != 0 or len(ids) == N_TRIALS


# -- the verbs that write into an archive -------------------------------------------------

@pytest.fixture(scope="module")
def analysed(tmp_path_factory):
    """An archive with segment and label results, and its models file."""
    folder = tmp_path_factory.mktemp("verbs")
    path, models = folder / "base.h5", folder / "m.h5"
    write_archive(path, trials=[f"t{i:02d}" for i in range(4)], n=6000)
    for args in (("train", path, "--out", models, "--block", 20, "--order", 1, "-q"),
                 ("segment", path, "-q"), ("label", path, "--models", models, "-q")):
        res = subprocess.run([sys.executable, "-m", "contactlab", *map(str, args)],
                             capture_output=True, text=True)
        assert res.returncode == 0, res.stderr
    return path, models


def _results(path):
    """Every trial's results, stage by stage: {stage: {trial: {dataset: bytes}}}."""
    out: dict = {}
    with h5py.File(path, "r") as f:
        for tid, trial in f["trials"].items():
            for stage, group in trial.get("results", {}).items():
                found = {}
                group.visititems(lambda name, obj: found.__setitem__(name, obj[()].tobytes())
                                 if isinstance(obj, h5py.Dataset) else None)
                found["parameters"] = group.attrs.get("parameters")
                out.setdefault(stage, {})[tid] = found
    return out


@pytest.fixture(scope="module")
def recognisable(tmp_path_factory):
    """A test archive with segment results, its feature graph and trained models."""
    from test_recognize import recognition_files

    files = recognition_files(tmp_path_factory.mktemp("recog"))
    res = subprocess.run([sys.executable, "-m", "contactlab", "segment", files["test"], "-q"],
                         capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    return files["test"], files["graph"], files["models"]


VERBS = {
    "segment": lambda a, r: (a[0], ["--threshold", "300", "-q"]),
    "label": lambda a, r: (a[0], ["--models", a[1], "-q"]),
    "estimate": lambda a, r: (a[0], ["-q"]),
    "recognize": lambda a, r: (r[0], ["--graph", r[1], "--models", r[2], "-q"]),
}


_REFERENCE: dict = {}


def _uninterrupted(verb, base, extra, tmp_path):
    """The verb's results on a copy of ``base`` left to finish (computed once)."""
    if verb not in _REFERENCE:
        path = tmp_path / "reference.h5"
        path.write_bytes(base.read_bytes())
        res = subprocess.run([sys.executable, "-m", "contactlab", verb, str(path),
                              *map(str, extra)], capture_output=True, text=True)
        assert res.returncode == 0, res.stderr
        _REFERENCE[verb] = _results(path)[verb]
    return _REFERENCE[verb]


@pytest.mark.parametrize("verb", sorted(VERBS))
def test_a_verb_interrupted_keeps_the_results_that_were_there(analysed, recognisable,
                                                              tmp_path, verb):
    base, extra = VERBS[verb](analysed, recognisable)
    rng = random.Random(sum(map(ord, verb)))
    for attempt, plan in enumerate(PLANS * 2 if STRESS else [rng.choice(PLANS)]):
        folder = tmp_path / f"v{attempt}"
        folder.mkdir()
        path = folder / "a.h5"
        path.write_bytes(base.read_bytes())
        before, results = measurement_bytes(path), _results(path)
        run = _Run(verb, path, *extra)
        time.sleep(rng.uniform(1.0, 4.0))
        code = _interrupt(run, plan, rng, path, folder)
        assert validate_archive(path) == [] and measurement_bytes(path) == before
        after = _results(path)
        for stage, trials in results.items():
            if stage != verb:
                assert after.get(stage) == trials, stage       # other stages untouched
        now = after.get(verb, {})
        if now != results.get(verb, {}):     # else the old results, whole: the new, whole
            assert now == _uninterrupted(verb, base, extra, tmp_path), verb


def test_train_interrupted_leaves_no_models_file_or_a_whole_one(analysed, tmp_path):
    base, _ = analysed
    rng = random.Random(11)
    for attempt, plan in enumerate(PLANS * 2 if STRESS else [(INT, INT)]):
        out = tmp_path / f"m{attempt}.h5"
        run = _Run("train", base, "--out", out, "--block", 20, "--order", 1, "-q")
        time.sleep(rng.uniform(1.0, 3.0))
        code = _interrupt(run, plan, rng, out, tmp_path, archive=False)
        if out.exists():
            with h5py.File(out, "r") as f:
                assert len(f.attrs) > 0


def test_report_interrupted_leaves_no_report_or_a_whole_one(analysed, tmp_path):
    base, _ = analysed
    rng = random.Random(17)
    for attempt, plan in enumerate(PLANS * 2 if STRESS else [rng.choice(PLANS)]):
        out = tmp_path / f"rep{attempt}"
        run = _Run("report", base, "--out", out, "-q")
        time.sleep(rng.uniform(1.0, 4.0))
        code = _interrupt(run, plan, rng, out, tmp_path, archive=False)
        if out.exists():
            names = sorted(p.name for p in out.iterdir())
            assert "index.html" in names and "report.pdf" in names, names
            assert len([n for n in names if n.endswith(".png")]) == 4 + 4 * 2, names
        else:
            assert code != 0
