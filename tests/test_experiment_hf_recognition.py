"""hf-recognition: the supervised Gaussian-HMM peer and the registry entry."""

from __future__ import annotations

import numpy as np
import pytest

from contactlab.experiments import hf_recognition as hr
from contactlab.peers.hmm import fit_hmm


def _runs(seed):
    rng = np.random.default_rng(seed)
    levels = np.array([-6.0, -4.0, -2.0, 0.0])
    out = []
    for plan in ([0, 1, 3, 2], [0, 1, 0], [0, 1, 3, 2, 0]):
        truth = np.concatenate([np.full(rng.integers(40, 80), s) for s in plan])
        y = levels[truth][:, None] + rng.normal(scale=0.3, size=(len(truth), 1))
        truth = truth.astype(np.int64)
        out.append({"id": str(len(out)), "y": y, "truth": truth, "pure": truth})
    return out


def test_hmm_is_the_supervised_fit():
    runs = _runs(0)
    m = fit_hmm(runs, len(hr.STATES), pseudo=1.0)
    y = np.concatenate([r["y"] for r in runs])[:, 0]
    t = np.concatenate([r["truth"] for r in runs])
    for k in range(4):
        assert m.means_[k, 0] == pytest.approx(y[t == k].mean())
        assert m.covars_[k, 0, 0] == pytest.approx(y[t == k].var(ddof=1), rel=1e-6)
    counts = np.ones((4, 4))
    for r in runs:
        for a, b in zip(r["truth"][:-1], r["truth"][1:]):
            counts[a, b] += 1
    assert np.allclose(m.transmat_, counts / counts.sum(axis=1, keepdims=True))
    assert np.allclose(m.startprob_, np.array([4.0, 1, 1, 1]) / 7)


def test_hmm_viterbi_recovers_separated_states():
    m = fit_hmm(_runs(0), len(hr.STATES))
    test = _runs(1)
    conf, secs, states = hr.decode_hmm(m, test)
    assert conf.sum() == sum(len(r["truth"]) for r in test)
    assert np.trace(conf) / conf.sum() > 0.97
    assert secs >= 0 and len(states) == len(test)


def test_registered():
    from contactlab.experiments import get
    e = get("hf-recognition")
    assert e.implemented and e.runner() is hr.run


def test_headline_puts_ours_beside_the_thesis_and_the_hmm():
    import numpy as np

    from contactlab.experiments.hf_recognition import THESIS, _headline

    res = {"test_cf": {"accuracy": 0.40}, "test_ctx": {"accuracy": 0.70}}
    hmm = {"test": (np.array([[30, 10], [10, 50]]),)}     # 80 of 100 points on the diagonal
    line = _headline(res, hmm, {"test_cf_gauss": {"accuracy": 0.65}})
    # make demo's closing summary picks this line out by its start
    assert line.startswith("test runs marked correctly: context free 40 %")
    assert f"thesis {100 * THESIS['test_cf']['accuracy']:.0f} %" in line
    assert "HMM peer 80 %" in line and "with context 70 %" in line
    assert "hf-gaussian 65 %" in line
    assert f"thesis {100 * THESIS['test_ctx']['accuracy']:.0f} %" in line


def test_hindsight_text_counts_the_misses_both_share():
    from contactlab.experiments.hf_recognition import HINDSIGHT_ROW, _hindsight_text

    ours = "Gaussian hypotheses, with context"
    line = _hindsight_text({ours: (25, 28, {("a", 1), ("b", 9), ("c", 4)}),
                            HINDSIGHT_ROW: (21, 28, {("a", 1), ("c", 4), ("d", 2)})})
    assert "Of the 3 transitions" in line and "2 are missed by the hindsight row" in line
    line = _hindsight_text({ours: (27, 28, {("a", 1)}), HINDSIGHT_ROW: (27, 28, {("d", 2)})})
    assert "Of the 1 transition the" in line and "0 are missed" in line
    assert "miss no transition" in _hindsight_text({ours: (28, 28, set()),
                                                    HINDSIGHT_ROW: (27, 28, {("d", 2)})})
    assert _hindsight_text({ours: (28, 28, set())}) == ""
