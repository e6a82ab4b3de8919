"""bench: recognising a user's wrench-and-position recording (free-contact graph).

Data we did not simulate: hand-held-tool recordings (:mod:`contactlab.synthetic.free_contact`;
one surface, tool inertia on the sensor, light touches) written as CSV and imported
as a user would, at 100 Hz and 500 Hz: one recording trains (``train --graph
free-contact --label-map 1=free,2=contact,3=free``), four others (seeds 21-24) are
recognised with the defaults.  Peer: the force threshold ``|F| > k sigma``
(:class:`contactlab.peers.force_threshold.ForceThreshold`, k chosen on the training
recording) on the same conditioned points.  Accuracy is over the labelled points,
contact vs free (our impact node counts as contact).  Speed: the observer over the
test recordings, x real time on one core (goal >= 100x).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

SEEDS = (21, 22, 23, 24)
MAP = {"1": "free", "2": "contact", "3": "free"}
COLUMNS = "time=t;wrench=fx,fy,fz,tx,ty,tz;position=x,y,z;labels=state"


def _import(d: Path, name: str, seed: int, fs: float) -> Path:
    import pandas as pd
    from click.testing import CliRunner

    from contactlab.cli import main
    from contactlab.synthetic.free_contact import free_contact_recording

    csv = d / f"{name}.csv"
    pd.DataFrame(free_contact_recording(seed=seed, fs=fs).csv_columns()).to_csv(csv, index=False)
    out = d / f"{name}.h5"
    r = CliRunner().invoke(main, ["import", str(csv), "--out", str(out), "-q",
                                  "--columns", COLUMNS])
    assert r.exit_code == 0, r.output
    return out


def _points(path):
    from contactlab.archive import open_archive
    from contactlab.signals import relabel, trial_signals, truth_codes

    with open_archive(path) as a:
        t = a.trial(a.select(None)[0])
        d, idx, _ = trial_signals(t, ["contact"])
        truth = truth_codes(relabel(t, MAP), idx, ["free", "contact"])
    return d["contact"][:, 3:], truth


def run() -> list[dict]:
    from contactlab.observer.recognize import recognize_archive
    from contactlab.observer.training import train_graph
    from contactlab.peers.force_threshold import ForceThreshold

    rows = []
    for fs in (100.0, 500.0):
        with tempfile.TemporaryDirectory() as tmp:
            d = Path(tmp)
            train = _import(d, "train", 20, fs)
            gm = train_graph(train, "free-contact", label_map=MAP)
            f, tr = _points(train)
            peer = ForceThreshold().fit(f[tr >= 0], tr[tr >= 0] == 1)
            # the compiled kernels loaded before the timing (as bench_triples does)
            recognize_archive(train, graph="free-contact", models=gm, write=False)
            ours_ok = peer_ok = total = 0
            t_ours = t_peer = dur = 0.0
            for s in SEEDS:
                test = _import(d, f"test{s}", s, fs)
                t0 = time.perf_counter()
                out = recognize_archive(test, graph="free-contact", models=gm, write=False,
                                        keep=True)
                t_ours += time.perf_counter() - t0
                rec = out["_runs"][0]
                dur += len(rec.times) / rec.fs
                f, truth = _points(test)
                lab = rec.result.labels[:len(truth)]
                keep = truth >= 0
                contact_ours = lab != list(rec.result.node_names).index("free")
                t0 = time.perf_counter()
                contact_peer = peer.predict(f)
                t_peer += time.perf_counter() - t0
                ours_ok += int(np.sum(contact_ours[keep] == (truth[keep] == 1)))
                peer_ok += int(np.sum(contact_peer[keep] == (truth[keep] == 1)))
                total += int(keep.sum())
        rows.append({
            "name": f"free-contact recognition, {fs:.0f} Hz CSV ({len(SEEDS)} recordings)",
            "ours_s": t_ours, "peer": f"force threshold (k={peer.k_:g})", "peer_s": t_peer,
            "ratio": t_peer / t_ours,
            "notes": f"points correct (contact vs free): ours {100 * ours_ok / total:.1f} %, "
                     f"peer {100 * peer_ok / total:.1f} %; observer {dur / t_ours:.0f}x real "
                     f"time (goal >= 100x, reading and conditioning included)"})
    return rows


if __name__ == "__main__":
    for row in run():
        print(row)
