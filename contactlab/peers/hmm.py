"""A supervised Gaussian hidden Markov model decoded by Viterbi (hmmlearn): the
recognition peer of the observer (7.3).

:func:`labelled_points` gives each trial's y_h with its truth on the
conditioned time base (:mod:`contactlab.signals`); :func:`fit_hmm` sets a
Gaussian HMM's per-state mean and covariance from the points whose whole input
window has one label, and its transition and start probabilities from label
counts -- no EM, so the peer sees exactly the labels the observer's models are
trained from.
"""

from __future__ import annotations

import numpy as np

from contactlab.signals import trial_signals, truth_codes, window_of

__all__ = ["labelled_points", "fit_hmm", "decode", "state_path", "point_accuracy"]


def labelled_points(archive, states, *, reduce: str = "mean") -> list[dict]:
    """Per trial: ``y`` (n, C) y_h, ``truth`` (n,) state index of the newest input sample
    (-1 unlabelled), ``pure`` (n,) the same only where the whole input window is one label."""
    from contactlab.archive import open_archive

    out = []
    with open_archive(archive) as arc:
        for trial in arc:
            data, index, _ = trial_signals(trial, ["hf"], reduce=reduce)
            out.append({"id": trial.id, "y": data["hf"],
                        "truth": truth_codes(trial, index, states),
                        "pure": truth_codes(trial, index, states, window=window_of("hf", trial.rate_hz))})
    return out


def fit_hmm(train: list[dict], n_states: int, *, pseudo: float = 1.0):
    """A supervised Gaussian HMM: per-state mean/covariance of the pure labelled points,
    transition and start probabilities from label counts (+ ``pseudo`` per allowed cell)."""
    from hmmlearn.hmm import GaussianHMM

    K = int(n_states)
    C = train[0]["y"].shape[1]
    means, covs = np.zeros((K, C)), np.zeros((K, C, C))
    for k in range(K):
        y = np.concatenate([t["y"][t["pure"] == k] for t in train if t["pure"] is not None])
        means[k] = y.mean(axis=0)
        covs[k] = np.atleast_2d(np.cov(y, rowvar=False)) + 1e-9 * np.eye(C)
    trans = np.full((K, K), pseudo)
    start = np.full(K, pseudo)
    for t in train:
        if t["truth"] is None:
            continue                               # a trial without ground truth
        lab = t["truth"][t["truth"] >= 0]          # unlabelled gaps skipped
        if not len(lab):
            continue
        np.add.at(trans, (lab[:-1], lab[1:]), 1.0)
        start[lab[0]] += 1.0
    model = GaussianHMM(n_components=K, covariance_type="full", init_params="", params="")
    model.n_features = C
    model.startprob_ = start / start.sum()
    model.transmat_ = trans / trans.sum(axis=1, keepdims=True)
    model.means_ = means
    model.covars_ = covs
    return model


def decode(model, runs: list[dict], n_states: int) -> tuple[np.ndarray, list[np.ndarray]]:
    """The Viterbi state sequence of each run's ``y`` (:func:`labelled_points`) and the
    point confusion counts pooled over the runs with truth (rows true, columns decoded)."""
    from contactlab.metrics import confusion_matrix

    total = np.zeros((n_states, n_states), np.int64)
    paths = [model.decode(r["y"], algorithm="viterbi")[1] for r in runs]
    for r, s in zip(runs, paths):
        if r["truth"] is not None:
            total += confusion_matrix(r["truth"], s, n_states)[0]
    return total, paths


def state_path(states, names) -> list[tuple[str, int]]:
    """A decoded state sequence as an observer's path, ``[(name, first sample), ...]`` at
    each change (what :func:`contactlab.observer.recognize.detection_delays` scores)."""
    s = np.asarray(states)
    ch = np.r_[0, np.flatnonzero(np.diff(s)) + 1] if len(s) else np.zeros(0, np.int64)
    return [(names[s[c]], int(c)) for c in ch]


def point_accuracy(train_archive, test_archive, states, *, reduce: str = "mean") -> float:
    """Share of the labelled y_h points of ``test_archive`` that the supervised HMM fitted
    on ``train_archive`` marks correctly by Viterbi (labels named like ``states``)."""
    model = fit_hmm(labelled_points(train_archive, states, reduce=reduce), len(states))
    total, _ = decode(model, labelled_points(test_archive, states, reduce=reduce), len(states))
    if total.sum() == 0:
        raise ValueError(f"{test_archive}: no labelled points named {', '.join(states)}")
    return float(np.trace(total) / total.sum())


def main(argv=None) -> int:
    """``python -m contactlab.peers.hmm TRAIN.h5 TEST.h5 [STATES]``: the peer's point
    accuracy (states default to the hf hypotheses H0-H3 of 7.3)."""
    import sys

    args = list(sys.argv[1:] if argv is None else argv)
    if len(args) not in (2, 3):
        print("usage: python -m contactlab.peers.hmm TRAIN.h5 TEST.h5 [H0,H1,H2,H3]",
              file=sys.stderr)
        return 2
    states = (args[2] if len(args) == 3 else "H0,H1,H2,H3").split(",")
    from contactlab.errors import ContactlabError

    try:
        acc = point_accuracy(args[0], args[1], states)
    except (ContactlabError, OSError, ValueError) as exc:
        print(f"contactlab.peers.hmm: error: {exc}", file=sys.stderr)
        return 1
    print(f"supervised Gaussian HMM (hmmlearn, Viterbi) on y_h, trained on {args[0]}: "
          f"{100 * acc:.1f} % of the labelled points of {args[1]} marked correctly")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
