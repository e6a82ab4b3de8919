"""The synthetic benchmark suite: every stage beside its standard peer on data we did not
simulate (:mod:`contactlab.synthetic`), accuracy and time in one run.

Each case is written as an archive and run through the CLI with default flags, as
a user would run it (``contactlab segment A --json``, ...); the peers run on the
same data.  Timing rows time the library call behind the verb against the peer's
fit + predict, per trial.

Segmentation.  12 trials of 8-channel piecewise AR(2) at 1000 Hz (6 s, changes
of variance only, coefficients only, or both; seed 1).  ``segment`` conditions
to the 250 Hz lowpassed copy (7.1); the peers run on that same copy: ruptures
``Binseg`` and ``Pelt`` with a per-channel Gaussian AR(2) likelihood cost
(:class:`ARLikelihoodCost`: ``sum_c m log(RSS_c / m)``, the model of our test,
from the same prefix sums, so the time ratios compare algorithms, not cost
code), ``min_size`` 10, ``jump`` 5, each at the penalty ``beta C (p + 2) log n``
whose pooled F1 on the suite is best (the peers get a sweep; we run with
defaults).  A further row runs ruptures' own ``CostAR`` (a residual sum of
squares, per channel, summed) as a user would assemble it: it is blind to
changes of level alone.  F1 within 50 ms, ruptures' metric.
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import numpy as np

from contactlab.segmentation import (boundary_metrics, conditioned_signal, pooled_metrics,
                                     segment_glr, segment_signal)
from contactlab.synthetic import piecewise_ar_trials, write_archive

from benchmarks.timing import best_time, best_time_and_result

SEED = 1
TOLERANCE_S = 0.05
PEER_BETAS = tuple(float(b) for b in np.round(2.0 ** np.arange(-2, 4.5, 0.5), 2))


def _base_cost():
    from ruptures.base import BaseCost
    return BaseCost


class ARLikelihoodCost(_base_cost()):
    """ruptures cost: minus twice the maximised Gaussian AR(p) log-likelihood of a
    segment, per channel with its own coefficients, intercept and variance, summed
    over channels (rows padded at the start like ``CostAR``)."""

    model = "ar-likelihood"

    def __init__(self, order: int = 2):
        self.order = order
        self.min_size = 2 * (order + 2)
        self.signal = None

    def fit(self, signal):
        from contactlab.detection.ar_glr import ARPrefix
        s = np.asarray(signal, float).reshape(len(signal), -1)
        self.signal = s
        self.prefix_ = ARPrefix(np.concatenate([s[:self.order], s]), order=self.order)
        return self

    def error(self, start, end):
        return float(-2.0 * self.prefix_.loglik(start, end))


def cli(*args) -> dict:
    """Run ``contactlab ARGS --json -q`` in-process; the one JSON object it prints."""
    from click.testing import CliRunner

    from contactlab.cli import main
    res = CliRunner().invoke(main, [str(a) for a in args] + ["--json", "-q"])
    if res.exit_code != 0:
        raise RuntimeError(f"contactlab {' '.join(map(str, args))}: {res.output}")
    return json.loads(res.stdout)


def _f1(trials_found, truths, times) -> dict:
    rows = [boundary_metrics(t, f, times=tm, tolerance_s=TOLERANCE_S)
            for t, f, tm in zip(truths, trials_found, times)]
    return pooled_metrics(rows, TOLERANCE_S)


def _kind_recall(trials, found) -> dict:
    out = {}
    for t, f in zip(trials, found):
        f = np.asarray(f)
        for b, k in zip(t.boundaries_s, t.kinds):
            hit = bool(f.size and np.min(np.abs(f - b)) < TOLERANCE_S)
            n, h = out.get(k, (0, 0))
            out[k] = (n + 1, h + hit)
    return {k: h / n for k, (n, h) in out.items()}


def segmentation_rows(tmp: Path) -> list[dict]:
    import ruptures as rpt

    from contactlab.experiments.stroke_segmentation import ChannelARCost, noise_variance

    trials = piecewise_ar_trials(12, seed=SEED)
    path = tmp / "piecewise-ar.h5"
    ids = write_archive(trials, path, title="piecewise AR suite")
    truths = [t.boundaries_s for t in trials]
    ours = cli("segment", path, "--tolerance", TOLERANCE_S)
    thesis = cli("segment", path, "--method", "page-hinkley", "--tolerance", TOLERANCE_S)
    found_ours = [ours["trials"][i]["boundaries_s"] for i in ids]
    found_thesis = [thesis["trials"][i]["boundaries_s"] for i in ids]

    from contactlab.archive import open_archive
    with open_archive(path) as archive:
        signals = [conditioned_signal(archive.trial(i)) for i in ids]
    times = [s[1] for s in signals]

    def penalty(beta, y):
        return beta * y.shape[1] * 4 * np.log(len(y))

    def peer(algo, beta, y, tm):
        det = getattr(rpt, algo)(custom_cost=ARLikelihoodCost(), min_size=10, jump=5).fit(y)
        return np.asarray(tm)[np.asarray(det.predict(pen=penalty(beta, y))[:-1], int)]

    # the peers' best penalty: Binseg over the whole grid (one fit, many predicts)
    binseg_by_beta = {b: [] for b in PEER_BETAS}
    for (y, tm, _fs) in signals:
        det = rpt.Binseg(custom_cost=ARLikelihoodCost(), min_size=10, jump=5).fit(y)
        for b in PEER_BETAS:
            bk = det.predict(pen=penalty(b, y))
            binseg_by_beta[b].append(np.asarray(tm)[np.asarray(bk[:-1], int)])
    f1_binseg = {b: _f1(f, truths, times)["f1"] for b, f in binseg_by_beta.items()}
    beta_b = max(f1_binseg, key=f1_binseg.get)
    # Pelt is slow: the three betas around Binseg's best
    k = PEER_BETAS.index(beta_b)
    pelt_betas = PEER_BETAS[max(k - 1, 0):k + 2]
    pelt_by_beta = {b: [peer("Pelt", b, y, tm) for (y, tm, _fs) in signals] for b in pelt_betas}
    f1_pelt = {b: _f1(f, truths, times)["f1"] for b, f in pelt_by_beta.items()}
    beta_p = max(f1_pelt, key=f1_pelt.get)

    m_ours, m_thesis = _f1(found_ours, truths, times), _f1(found_thesis, truths, times)
    m_b, m_p = _f1(binseg_by_beta[beta_b], truths, times), _f1(pelt_by_beta[beta_p], truths, times)
    rec = _kind_recall(trials, found_ours)
    rec_thesis = _kind_recall(trials, found_thesis)

    # time per trial: the library call behind the verb (on the conditioned signal)
    y0, tm0, fs0 = signals[0]
    segment_glr(y0[:300], fs=fs0)
    segment_signal(y0[:300], fs=fs0)
    t_ours = sum(best_time(lambda y=y, fs=fs: segment_glr(y, fs=fs), repeats=5)
                 for (y, _t, fs) in signals)
    t_thesis = sum(best_time(lambda y=y, fs=fs: segment_signal(y, fs=fs))
                   for (y, _t, fs) in signals)
    t_b = sum(best_time(lambda y=y, tm=tm: peer("Binseg", beta_b, y, tm))
              for (y, tm, _fs) in signals)
    t_p = sum(best_time_and_result(lambda y=y, tm=tm: peer("Pelt", beta_p, y, tm), repeats=1)[0]
              for (y, tm, _fs) in signals)
    # ruptures' own CostAR per channel, as a user would assemble it: its best penalty
    # (beta sigma^2 log n) from a Binseg sweep, then timed on two trials
    costar = {}
    for (y, tm, _fs) in signals:
        det = rpt.Binseg(custom_cost=ChannelARCost(), min_size=10, jump=5).fit(y)
        for b in (1.0, 2.0, 4.0, 8.0, 16.0):
            bk = det.predict(pen=b * noise_variance(y) * np.log(len(y)))
            costar.setdefault(b, []).append(np.asarray(tm)[np.asarray(bk[:-1], int)])
    f1_costar = {b: _f1(f, truths, times)["f1"] for b, f in costar.items()}
    beta_c = max(f1_costar, key=f1_costar.get)
    m_costar = _f1(costar[beta_c], truths, times)
    t_costar = sum(best_time(lambda y=y: rpt.Binseg(custom_cost=ChannelARCost(), min_size=10,
                                                    jump=5).fit(y).predict(
        pen=beta_c * noise_variance(y) * np.log(len(y))), repeats=1)
        for (y, _t, _fs) in signals[:2]) / 2
    n = len(signals)
    n_changes = sum(len(t.boundaries) for t in trials)

    def acc(m):
        return f"F1 {m['f1']:.3f} (P {m['precision']:.2f} R {m['recall']:.2f})"

    kinds = ", ".join(f"{k} {v:.2f}" for k, v in sorted(rec.items()))
    kinds_thesis = ", ".join(f"{k} {v:.2f}" for k, v in sorted(rec_thesis.items()))
    return [
        {"name": "suite: segment, piecewise AR, per trial", "ours_s": t_ours / n,
         "peer": f"ruptures Binseg (beta {beta_b:g})", "peer_s": t_b / n,
         "ratio": t_b / t_ours,
         "notes": f"{n} trials, {n_changes} changes, 50 ms: segment (defaults: glr) "
                  f"{acc(m_ours)}, recall by kind: {kinds}; Binseg {acc(m_b)}"},
        {"name": "suite: segment, piecewise AR, per trial", "ours_s": t_ours / n,
         "peer": f"ruptures Pelt (beta {beta_p:g})", "peer_s": t_p / n,
         "ratio": t_p / t_ours, "notes": f"Pelt {acc(m_p)}"},
        {"name": "suite: segment, piecewise AR, per trial", "ours_s": t_ours / n,
         "peer": "ruptures Binseg, CostAR per channel", "peer_s": t_costar,
         "ratio": t_costar / (t_ours / n),
         "notes": f"ruptures' own CostAR per channel (residual sum of squares), best "
                  f"beta {beta_c:g}: {acc(m_costar)}"},
        {"name": "suite: segment --method page-hinkley", "ours_s": t_thesis / n,
         "peer": f"ruptures Binseg (beta {beta_b:g})", "peer_s": t_b / n,
         "ratio": t_b / t_thesis,
         "notes": f"the thesis's test at T^2 = 200: {acc(m_thesis)}, "
                  f"recall by kind: {kinds_thesis}"},
    ]


def run() -> list[dict]:
    with tempfile.TemporaryDirectory(prefix="contactlab-suite-") as tmp:
        tmp = Path(tmp)
        rows = segmentation_rows(tmp)
    return rows
