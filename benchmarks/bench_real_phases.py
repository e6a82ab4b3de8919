"""bench: task phases of real robot recordings, a graph learned from labels vs HMM and RF.

Data: the real recordings of ``../shared/data/real`` (``CONTACTLAB_REAL_DATA`` overrides;
the bench prints one line and skips when they are absent): HIRO snap-fit assembly
(200 Hz; labels 1 approach, 2 rotation, 3 insertion, 4 mating -> three phases
approach / engage (2, 3) / mated) and Baxter pick-and-place (100 Hz; skills 1, 2, 5, 3,
4; label 0, outside the task, is left unlabelled).  Each CSV is imported as a user
would, with the tool's orientation (HIRO's roll/pitch/yaw, Baxter's endpoint quaternion;
the wrench is in the sensor's axes) and Baxter's repeated time stamps dropped first, in a
scratch directory.

Ours: ``graph learn`` on the training trials' labels, ``train --graph`` on them,
``recognize`` on the held-out trials, all with default settings.  Peers, on the same
per-sample features (the ``phase`` stream the learned graph's models read: the wrench in
the base frame and the velocity through the 5 Hz causal lowpass) and the same labelled
points: a
supervised Gaussian HMM (hmmlearn ``GaussianHMM``, full covariances; means and
covariances from the labels, start and transition probabilities from label counts,
Viterbi) and a random forest (scikit-learn defaults, ``random_state=0``).  Splits:

* ``hiro S-02..08``: train S-02..S-08, test the other 20 trials (S-09..S-30, ERROR-06..09);
* ``hiro alternate``: the 27 trials sorted by name, train the even positions (0, 2, ..),
  test the odd;
* ``baxter s03->s07`` and ``s07->s03``.

Printed per split: point accuracy of ours / HMM / RF, our phase changes' mean absolute
detection delay (ms; changes found within 0.25 s of the labelled one / all), and the
time each takes (train + recognise).
"""

from __future__ import annotations

from benchmarks.real_data import SKIPPED, real_data_dir

import tempfile
import time
from pathlib import Path

import numpy as np

COLUMNS = "time=t;wrench=fx,fy,fz,tx,ty,tz;position=x,y,z;labels=label"
#: the tool's orientation as each recording stores it
ORIENTATION = {"hiro": ";rpy=roll,pitch,yaw", "baxter": ";orientation=qw,qx,qy,qz"}
HIRO_MAP = {"1": "approach", "2": "engage", "3": "engage", "4": "mated"}
BAXTER_MAP = {"1": "s1", "2": "s2", "5": "s5", "3": "s3", "4": "s4"}


def data_dir() -> Path | None:
    return real_data_dir("hiro_snap", "baxter_pnp")


def _import(csvs, out: Path, scratch: Path) -> Path:
    import pandas as pd
    from click.testing import CliRunner

    from contactlab.cli import main

    files = []
    for f in csvs:
        d = pd.read_csv(f).drop_duplicates("t")
        name = f.stem.replace("hiro_20121127-HIROSA-", "").replace("hiro_20160930-HIRO_", "")
        name = name.replace("baxter_pnp_20170918_", "")
        dst = scratch / f"{name}.csv"
        d.to_csv(dst, index=False)
        files.append(str(dst))
    kind = "hiro" if "hiro" in csvs[0].name else "baxter"
    r = CliRunner().invoke(main, ["import", *files, "--out", str(out), "-q", "--columns",
                                  COLUMNS + ORIENTATION[kind]])
    assert r.exit_code == 0, r.output
    return out


def _features(path, trials, lmap, nodes):
    """Per trial: the phase stream (n, C) and the truth codes into ``nodes`` (-1 unlabelled)."""
    from contactlab.archive import open_archive
    from contactlab.signals import relabel, trial_signals, truth_codes

    out = []
    with open_archive(path) as a:
        for tid in trials:
            t = a.trial(tid)
            d, idx, _ = trial_signals(t, ["phase"])
            out.append((d["phase"], truth_codes(relabel(t, lmap), idx, nodes)))
    return out


def _peers(train, test, K):
    from hmmlearn.hmm import GaussianHMM
    from sklearn.ensemble import RandomForestClassifier

    X = np.vstack([x for x, _ in train])
    Y = np.concatenate([y for _, y in train])
    t0 = time.perf_counter()
    m = GaussianHMM(K, covariance_type="full", init_params="", params="")
    m.means_ = np.array([X[Y == k].mean(0) for k in range(K)])
    m.covars_ = np.array([np.cov(X[Y == k].T) + 1e-6 * np.eye(X.shape[1]) for k in range(K)])
    T, s = np.full((K, K), 1e-3), np.full(K, 1e-3)
    for _, y in train:
        y = y[y >= 0]
        s[y[0]] += 1
        np.add.at(T, (y[:-1], y[1:]), 1)
    m.transmat_, m.startprob_ = T / T.sum(1, keepdims=True), s / s.sum()
    hmm = [m.predict(x) for x, _ in test]
    t_hmm = time.perf_counter() - t0
    t0 = time.perf_counter()
    rf = RandomForestClassifier(random_state=0, n_jobs=1).fit(X[Y >= 0], Y[Y >= 0])
    forest = [rf.predict(x) for x, _ in test]
    t_rf = time.perf_counter() - t0

    def acc(preds):
        ok = sum(int(np.sum((p == y)[y >= 0])) for p, (_, y) in zip(preds, test))
        return ok / sum(int(np.sum(y >= 0)) for _, y in test)

    return acc(hmm), t_hmm, acc(forest), t_rf


def _ours(path, train, test, lmap, scratch: Path, tag: str):
    from contactlab.observer.graph_learn import learn_from_labels
    from contactlab.observer.graph_toml import write_graph
    from contactlab.observer.recognize import recognize_archive
    from contactlab.observer.training import train_graph

    t0 = time.perf_counter()
    doc, summary = learn_from_labels([path], lmap, trials=train, name=tag)
    gpath = write_graph(doc, scratch / f"{tag}.toml")
    full = dict(e.split("=", 1) for e in summary["label_map"].split(","))
    gm = train_graph(path, gpath, trials=train, label_map=full)
    t_train = time.perf_counter() - t0
    t0 = time.perf_counter()
    s = recognize_archive(path, graph=gpath, models=gm, trials=test, write=False)
    t_rec = time.perf_counter() - t0
    fs = gm.fs
    # the task's labelled points only (an added outside node's points are not scored)
    names, c = s["confusion"]["labels"], np.asarray(s["confusion"]["matrix"])
    task = [names.index(n) for n in dict.fromkeys(lmap.values())]
    accuracy = float(c[task, task].sum() / c[task].sum())
    delays = [d for e in s["trials"].values() if e["delays"] for d in e["delays"]["delays"]]
    found = [d for d in delays if abs(d) <= 0.25 * fs]
    n_tr = s["delays"]["transitions"] if s["delays"] else 0
    delay_ms = float(np.mean(np.abs(found)) / fs * 1e3) if found else float("nan")
    return accuracy, t_train + t_rec, delay_ms, len(found), n_tr


def run() -> list[dict]:
    root = data_dir()
    if root is None:
        print(SKIPPED)
        return []
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        (d / "csv").mkdir()
        hiro = _import(sorted((root / "hiro_snap").glob("*.csv")), d / "hiro.h5", d / "csv")
        bax = _import(sorted((root / "baxter_pnp").glob("*.csv")), d / "baxter.h5", d / "csv")
        from contactlab.archive import open_archive

        with open_archive(hiro) as a:
            hids = sorted(a.select(None))
        with open_archive(bax) as a:
            bids = sorted(a.select(None))
        early = [t for t in hids if t in {f"S-0{i}" for i in range(2, 9)}]
        splits = [("hiro S-02..08", hiro, HIRO_MAP, early, [t for t in hids if t not in early]),
                  ("hiro alternate", hiro, HIRO_MAP, hids[0::2], hids[1::2]),
                  (f"baxter {bids[0]}->{bids[1]}", bax, BAXTER_MAP, bids[:1], bids[1:]),
                  (f"baxter {bids[1]}->{bids[0]}", bax, BAXTER_MAP, bids[1:], bids[:1])]
        for k, (name, path, lmap, train, test) in enumerate(splits):
            nodes = list(dict.fromkeys(lmap.values()))
            ours, t_ours, delay, n_found, n_tr = _ours(path, train, test, lmap, d, f"split{k}")
            a_hmm, t_hmm, a_rf, t_rf = _peers(_features(path, train, lmap, nodes),
                                              _features(path, test, lmap, nodes), len(nodes))
            rows.append({"name": f"{name}: accuracy ours/HMM/RF", "ours_s": t_ours,
                         "peer": "GaussianHMM supervised", "peer_s": t_hmm,
                         "ratio": t_hmm / t_ours,
                         "accuracy": ours, "accuracy_hmm": a_hmm, "accuracy_rf": a_rf,
                         "rf_s": t_rf, "delay_ms": delay,
                         "notes": f"accuracy ours {ours:.4f}, HMM {a_hmm:.4f}, RF {a_rf:.4f} "
                                  f"({len(train)} train / {len(test)} test trials); phase "
                                  f"changes found {n_found}/{n_tr}, mean |delay| "
                                  f"{delay:.0f} ms; RF {t_rf * 1e3:.0f} ms"})
    return rows


if __name__ == "__main__":
    for row in run():
        print(row["name"], row["notes"])
