"""bench: free space vs contact on real wrist recordings, trained on some, recognised on others.

Recordings of other groups (``../shared/data/real`` or ``$CONTACTLAB_REAL_DATA``; skipped
with one line when absent): the wiping demonstration, one recording, imported as two
trials with ``import --window`` (train on 0-22 s, recognise 22-43 s; its label 4 counted
as contact), and the HIRO snap-fit trials (train on S-02 and S-03, recognise S-04..S-09;
train on the first 14, recognise the other 13; rotation, insertion and mating counted as
contact).  Both are imported with the tool's orientation (the wrench is measured in the
sensor's axes, the position in the base frame).  Ours: ``train --graph free-contact
--label-map ...`` then ``recognize`` with default flags, points of the conditioned time
base (the payload's weight refitted where the tool turns: :func:`contactlab.observer.
recognize.observe_trial`).  Peer: the force threshold ``|F| > k
sigma`` (:class:`contactlab.peers.force_threshold.ForceThreshold`) with ``k`` chosen on
the training trials, on the raw samples; and, on the points and per-sample features of
``bench_real_phases`` (the ``phase`` stream: the wrench in the base frame and the velocity
through the 5 Hz lowpass), its supervised Gaussian HMM and random forest.  Also: how many
recognised trials the misfit check warned about (it should be silent where the models
fit).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.real_data import SKIPPED, real_data_dir

COLUMNS = "time=t;wrench=fx,fy,fz,tx,ty,tz;position=x,y,z;labels=label"
#: the tool's orientation as each recording stores it (the wrench is in the sensor's axes,
#: the position in the base frame: the contact signals rotate the force into the base)
WIPE_COLUMNS = COLUMNS + ";orientation=qw,qx,qy,qz"
HIRO_COLUMNS = COLUMNS + ";rpy=roll,pitch,yaw"
WIPE_MAP = "1=free,2=contact,3=free,4=contact"
HIRO_MAP = "1=free,2=contact,3=contact,4=contact"


def _cli(*args) -> str:
    from click.testing import CliRunner

    from contactlab.cli import main

    r = CliRunner().invoke(main, [str(a) for a in args])
    assert r.exit_code == 0, r.output
    return r.stdout             # warnings go to stderr


def _threshold(archive, train_ids, test_ids, lmap) -> float:
    """Point accuracy of the force threshold fitted on ``train_ids``, on ``test_ids``."""
    from contactlab.archive import open_archive
    from contactlab.peers.force_threshold import ForceThreshold

    cmap = dict(part.split("=") for part in lmap.split(","))

    def points(ids):
        F, C = [], []
        with open_archive(archive) as a:
            for tid in ids:
                tr = a.trial(tid)
                names = [cmap.get(str(n)) for n in tr.label_names]
                lab = np.asarray(tr.labels, np.int64)
                state = np.array([names[k] if k >= 0 else None for k in lab], dtype=object)
                keep = state != None  # noqa: E711 (elementwise)
                F.append(np.asarray(tr.wrench)[keep, :3])
                C.append(state[keep] == "contact")
        return np.concatenate(F), np.concatenate(C)

    peer = ForceThreshold().fit(*points(train_ids))
    f, c = points(test_ids)
    return float(np.mean(peer.predict(f) == c))


def _learned_peers(archive, train_ids, test_ids, lmap) -> tuple[float, float]:
    """Point accuracy of the supervised Gaussian HMM and the random forest of
    ``bench_real_phases`` on the free/contact labels."""
    from benchmarks.bench_real_phases import _features, _peers

    cmap = dict(part.split("=") for part in lmap.split(","))
    nodes = list(dict.fromkeys(cmap.values()))
    hmm, _, forest, _ = _peers(_features(archive, train_ids, cmap, nodes),
                               _features(archive, test_ids, cmap, nodes), len(nodes))
    return hmm, forest


def _ours(archive, train_ids, test_ids, lmap, models) -> tuple[float, int, float]:
    import json

    def trials(ids):
        return [a for t in ids for a in ("--trial", t)]

    t0 = time.perf_counter()
    _cli("train", archive, "--graph", "free-contact", "--label-map", lmap, "--out", models,
         "--force", "-q", *trials(train_ids))
    out = json.loads(_cli("recognize", archive, "--graph", "free-contact", "--models", models,
                          "--label-map", lmap, "--no-write", "-q", "--json",
                          *trials(test_ids)))
    elapsed = time.perf_counter() - t0
    misfits = sum(bool((e.get("fit") or {}).get("misfit")) for e in out["trials"].values())
    return float(out["accuracy"]), misfits, elapsed


def run() -> list[dict]:
    root = real_data_dir("wiping", "hiro_snap")
    if root is None:
        print(SKIPPED)
        return []
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        wipe = d / "wipe.h5"
        _cli("import", *sorted((root / "wiping").glob("*.csv")), "--out", wipe, "-q",
             "--columns", WIPE_COLUMNS, "--window", "0:22", "--window", "22:43")
        hiro = d / "hiro.h5"
        csvs = sorted((root / "hiro_snap").glob("*.csv"))
        _cli("import", *csvs, "--out", hiro, "-q", "--columns", HIRO_COLUMNS)
        from contactlab.archive import open_archive

        with open_archive(wipe) as a:
            w_ids = list(a.trial_ids)
        ids = [c.stem for c in csvs]
        splits = [("wiping, 0-22 s -> 22-43 s", wipe, w_ids[:1], w_ids[1:], WIPE_MAP),
                  ("HIRO, S-02/03 -> S-04..09", hiro, ids[:2], ids[2:8], HIRO_MAP),
                  ("HIRO, first 14 -> other 13", hiro, ids[:14], ids[14:], HIRO_MAP)]
        for name, archive, tr, te, lmap in splits:
            acc, misfits, secs = _ours(archive, tr, te, lmap, d / "m.h5")
            t0 = time.perf_counter()
            peer = _threshold(archive, tr, te, lmap)
            peer_s = time.perf_counter() - t0
            hmm, forest = _learned_peers(archive, tr, te, lmap)
            rows.append({"name": f"free/contact, {name}", "ours_s": secs,
                         "peer": "force threshold (k on train)", "peer_s": peer_s,
                         "ratio": peer_s / secs,
                         "notes": f"points correct: ours {100 * acc:.1f} %, threshold "
                                  f"{100 * peer:.1f} %, HMM {100 * hmm:.1f} %, random forest "
                                  f"{100 * forest:.1f} %; misfit warnings on {misfits} of "
                                  f"{len(te)} recognised trials; default flags"})
        rows.append(run_hour(root, d))
    return rows


def _hiro_trials(root: Path) -> list:
    """The HIRO trials' wrench, pose and labels, one table each."""
    import pandas as pd

    cols = ["fx", "fy", "fz", "tx", "ty", "tz", "x", "y", "z", "roll", "pitch", "yaw", "label"]
    return [pd.read_csv(f)[cols] for f in sorted((root / "hiro_snap").glob("*.csv"))]


def _repeated_csv(trials: list, out: Path, n: int) -> None:
    """The trials one after another, again and again, to ``n`` rows at 200 Hz (a time
    column counted anew)."""
    import pandas as pd

    reps = -(-n // sum(len(t) for t in trials))
    table = pd.concat(trials * reps, ignore_index=True).iloc[:n]
    table.insert(0, "t", np.arange(n) / 200.0)
    table.to_csv(out, index=False, float_format="%.7g")


def run_hour(root: Path, d: Path) -> dict:
    """``import`` -> ``train --graph free-contact`` -> ``recognize`` of one hour at 200 Hz,
    in one process, with the peak traced memory of ``recognize`` beside its first part
    that holds every trial once (the same content, a fifth of the length)."""
    import tracemalloc

    trials = _hiro_trials(root)
    n, n_once = 3600 * 200, sum(len(t) for t in trials)
    csv, once = d / "hour.csv", d / "once.csv"
    _repeated_csv(trials, csv, n)
    _repeated_csv(trials, once, n_once)
    lmap = HIRO_MAP
    t0 = time.perf_counter()
    _cli("import", csv, "--out", d / "hour.h5", "-q", "--columns", HIRO_COLUMNS)
    t1 = time.perf_counter()
    _cli("train", d / "hour.h5", "--graph", "free-contact", "--label-map", lmap,
         "--out", d / "hour-m.h5", "-q")
    t2 = time.perf_counter()
    _cli("recognize", d / "hour.h5", "--graph", "free-contact", "--models", d / "hour-m.h5",
         "--no-write", "-q")
    t3 = time.perf_counter()
    _cli("import", once, "--out", d / "once.h5", "-q", "--columns", HIRO_COLUMNS)
    peaks = []
    for name in ("once", "hour"):
        tracemalloc.start()
        _cli("recognize", d / f"{name}.h5", "--graph", "free-contact", "--models",
             d / "hour-m.h5", "--no-write", "-q")
        peaks.append(tracemalloc.get_traced_memory()[1] / 2 ** 20)
        tracemalloc.stop()
    total = t3 - t0
    return {"name": "an hour of 200 Hz HIRO wrench and pose: import, train, recognize",
            "ours_s": total, "peer": "real time", "peer_s": n / 200.0,
            "ratio": n / 200.0 / total,
            "notes": f"{n / 200.0 / total:.0f}x real time in one process (import "
                     f"{t1 - t0:.2f} s, train {t2 - t1:.2f} s, recognize {t3 - t2:.2f} s; "
                     f"goal >= 1000x); recognize's peak traced memory {peaks[1]:.0f} MB for "
                     f"the hour, {peaks[0]:.0f} MB for its first {n_once / 200 / 60:.0f} "
                     f"minutes (every trial once)"}
