"""bench: ``segment`` with default flags on real wrist recordings made by other groups.

Recordings (``../shared/data/real`` or ``$CONTACTLAB_REAL_DATA``; skipped with one line
when absent; never copied into the project): the wiping demonstration (contact made and
broken; its label 4, a lighter press inside the third wipe, counted as contact) and the
27 HIRO snap-fit trials (first contact and the start of mating; rotation and insertion
taken together).  Each CSV is imported as a user would and segmented by
``contactlab segment --tolerance 0.25 --label-map ...`` with no other flag (``auto``:
the level test on a wrench).  Boundaries found where the recording is unlabelled
(wiping after 43 s) are not scored.

Peer: ruptures' Pelt (l2 cost) on the wrench standardised per channel, at its *best*
penalty for each data set from a grid (an oracle's choice; ours has one default for all).
F1 within 0.25 s, boundaries pooled over the trials of a data set (ruptures' metric).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.real_data import SKIPPED, real_data_dir

COLUMNS = "time=t;wrench=fx,fy,fz,tx,ty,tz;position=x,y,z;labels=label"
SETS = {
    "wiping": ("wiping/*.csv", {"1": "free", "2": "contact", "3": "free", "4": "contact"}),
    "hiro": ("hiro_snap/*.csv", {"1": "approach", "2": "engage", "3": "engage",
                                 "4": "mated"}),
}
PENALTIES = (10.0, 30.0, 100.0, 300.0, 1000.0, 3000.0)
TOLERANCE_S = 0.25


def _pelt_f1(trials, lmap, penalty) -> tuple[int, int, int]:
    import ruptures as rpt

    from contactlab.segmentation import labelled_only, truth_boundaries_s

    tp = n_found = n_true = 0
    for trial in trials:
        w = np.asarray(trial.wrench, dtype=np.float64)
        z = (w - w.mean(0)) / np.where(w.std(0) > 0, w.std(0), 1.0)
        bk = rpt.Pelt(model="l2", min_size=10, jump=10).fit(z).predict(pen=penalty)[:-1]
        t = np.asarray(trial.time)
        found = labelled_only(trial, t[np.asarray(bk, int)], lmap)
        truth = truth_boundaries_s(trial, lmap)
        a, b, c = _matches(truth, found)
        tp, n_found, n_true = tp + a, n_found + b, n_true + c
    return tp, n_found, n_true


def _matches(truth, found) -> tuple[int, int, int]:
    """(true positives, found, true): each true boundary matched by at most one found one
    strictly within the tolerance (ruptures' precision_recall)."""
    used, tp = set(), 0
    for f in np.asarray(found, float):
        d = np.abs(np.asarray(truth, float) - f)
        for i in np.argsort(d):
            if d[i] < TOLERANCE_S and i not in used:
                used.add(i)
                tp += 1
                break
    return tp, len(found), len(truth)


def _f1(tp, n_found, n_true) -> float:
    p = tp / n_found if n_found else 0.0
    r = tp / n_true if n_true else 0.0
    return 2 * p * r / (p + r) if p + r else 0.0


def run() -> list[dict]:
    root = real_data_dir()
    if root is None:
        print(SKIPPED)
        return []
    from click.testing import CliRunner

    from contactlab.archive import open_archive
    from contactlab.cli import main
    from contactlab.segmentation import labelled_only, run_archive, truth_boundaries_s

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, (pattern, lmap) in SETS.items():
            csvs = sorted(root.glob(pattern))
            if not csvs:
                continue
            h5 = Path(tmp) / f"{name}.h5"
            r = CliRunner().invoke(main, ["import", *map(str, csvs), "--out", str(h5), "-q",
                                          "--columns", COLUMNS])
            assert r.exit_code == 0, r.output
            t0 = time.perf_counter()
            summary = run_archive(h5, tolerance_s=TOLERANCE_S, write=False, quiet=True)
            ours_s = time.perf_counter() - t0
            tp = n_found = n_true = 0
            with open_archive(h5) as archive:
                trials = [archive.trial(tid) for tid in archive.trial_ids]
                duration = sum(float(tr.time[-1] - tr.time[0]) for tr in trials)
                for tr in trials:
                    found = labelled_only(tr, summary["trials"][tr.id]["boundaries_s"], lmap)
                    a, b, c = _matches(truth_boundaries_s(tr, lmap), found)
                    tp, n_found, n_true = tp + a, n_found + b, n_true + c
                ours = _f1(tp, n_found, n_true)
                t0 = time.perf_counter()
                scores = {pen: _f1(*_pelt_f1(trials, lmap, pen)) for pen in PENALTIES}
                peer_s = (time.perf_counter() - t0) / len(PENALTIES)
            best = max(scores, key=scores.get)
            rows.append({
                "name": f"segment, {name} ({len(csvs)} recordings, {duration:.0f} s)",
                "ours_s": ours_s, "peer": f"ruptures Pelt pen={best:g}", "peer_s": peer_s,
                "ratio": peer_s / ours_s,
                "notes": f"boundary F1 within {TOLERANCE_S} s: ours {ours:.2f} "
                         f"({tp} of {n_true} found, {n_found - tp} extra), ruptures at its "
                         f"best penalty {scores[best]:.2f}; default flags"})
    return rows
