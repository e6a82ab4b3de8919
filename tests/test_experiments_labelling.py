"""Building blocks of the texture-labelling and hf-models experiments (7.2.2, 7.3).

Oracles: brute-force loops over label arrays, numpy least squares, closed-form
normal error rates and plain Monte Carlo, and the simulator's own ground truth.
The full experiments run from ``contactlab reproduce``, not here.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from contactlab.archive import open_archive, validate_archive
from contactlab.experiments import get
from contactlab.experiments.hf_models import impact_fits, predicted_confusion, stationary_features
from contactlab.acquire.simulated import record_spec
from contactlab.archive.relabel import restrict_labels
from contactlab.metrics import confusion_matrix
from contactlab.signals import codes_at
from contactlab.temporal import block_features as _block_features
from contactlab.temporal.blocks import code_blocks as cut_blocks
from contactlab.temporal.blocks import truth_blocks
from contactlab.temporal.energy import normal_confusion_1d, normal_confusion_mc


def block_features(y, starts, *, block, order, mean):
    f = _block_features(y, order=order, mean=mean, block=block, starts=np.asarray(starts))
    return {"k": f.orthogonal, "coef": f.coef, "noise_var": f.ml_noise_var}


def two_normal_errors(m1, s1, m2, s2):
    conf = normal_confusion_1d([m1, m2], [s1, s2])
    return float(conf[0, 1]), float(conf[1, 0])


def normal_confusion(means, covs, *, n_draws, seed):
    return normal_confusion_mc(np.asarray(means, float), np.asarray(covs, float), n=n_draws,
                               seed=seed)
from contactlab.experiments.texture_labelling import log_energy_prediction, sample_features
from conftest import LABEL_NAMES, write_archive


def _random_codes(rng, n=3000, classes=4):
    """Runs of random lengths (1..250) and codes (-1..classes-1)."""
    codes = []
    while len(codes) < n:
        codes += [int(rng.integers(-1, classes))] * int(rng.integers(1, 250))
    return np.asarray(codes[:n])


# ---------------------------------------------------------------------------
# blocks
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cut_blocks_never_cross_a_label_change(seed):
    rng = np.random.default_rng(seed)
    codes = _random_codes(rng)
    block = int(rng.integers(5, 60))
    starts, labels = cut_blocks(codes, block=block)
    # brute force: every run of a labelled code gives len // block blocks from its start
    expect = []
    i = 0
    while i < len(codes):
        j = i
        while j < len(codes) and codes[j] == codes[i]:
            j += 1
        if codes[i] >= 0:
            expect += [(i + m * block, codes[i]) for m in range((j - i) // block)]
        i = j
    assert [(int(s), int(c)) for s, c in zip(starts, labels)] == expect
    for s, c in zip(starts, labels):
        assert np.all(codes[s:s + block] == c)
    assert np.all(np.diff(starts) >= block)                      # no overlap


def test_cut_blocks_class_filter_and_edges():
    codes = np.array([0] * 10 + [1] * 25 + [-1] * 30 + [2] * 20)
    starts, labels = cut_blocks(codes, block=10, classes=[1, 2])
    assert starts.tolist() == [10, 20, 65, 75]
    assert labels.tolist() == [1, 1, 2, 2]
    assert cut_blocks(np.zeros(0, int), block=5)[0].size == 0
    with pytest.raises(ValueError):
        cut_blocks(codes, block=0)


def test_conditioned_codes_brute_force():
    rng = np.random.default_rng(3)
    codes = _random_codes(rng, n=2000)
    for window in (4, 8):
        index = np.arange(0, 2000, 4)
        got = codes_at(codes, index, window=window)
        for k, i in enumerate(index):
            w = codes[max(i - window + 1, 0):i + 1]
            assert got[k] == (w[0] if np.all(w == w[0]) else -1)


# ---------------------------------------------------------------------------
# block features
# ---------------------------------------------------------------------------
def test_block_features_match_least_squares():
    rng = np.random.default_rng(4)
    n, C, block = 900, 3, 100
    y = np.empty((n, C))
    y[0] = 0.0
    for t in range(1, n):                                        # AR(1) with a mean
        y[t] = 0.4 + 0.6 * y[t - 1] + rng.normal(0, 0.1, C)
    starts = np.array([0, 150, 400, 777])
    f = block_features(y, starts, block=block, order=1, mean=True)
    assert f["k"].shape == (4, C, 2) and f["noise_var"].shape == (4, C)
    for b, s in enumerate(starts):
        for c in range(C):
            x = y[s:s + block, c]
            A = np.column_stack([np.ones(block - 1), x[:-1]])
            coef, *_ = np.linalg.lstsq(A, x[1:], rcond=None)
            resid = x[1:] - A @ coef
            np.testing.assert_allclose(f["coef"][b, c], coef, rtol=1e-8, atol=1e-10)
            # with a constant regressor the residuals sum to zero, so the orthogonal
            # parameter of the constant is the mean of the predicted samples (A.42)
            np.testing.assert_allclose(f["k"][b, c, 0], x[1:].mean(), rtol=1e-10)
            np.testing.assert_allclose(f["k"][b, c, 1], coef[1], rtol=1e-8)
            np.testing.assert_allclose(f["noise_var"][b, c], resid @ resid / (block - 1),
                                       rtol=1e-8)


def test_block_features_recover_ar2_coefficients():
    rng = np.random.default_rng(5)
    a1, a2, n = 1.2, -0.5, 20_000
    e = rng.normal(size=n)
    y = np.zeros(n)
    for t in range(2, n):
        y[t] = a1 * y[t - 1] + a2 * y[t - 2] + e[t]
    f = block_features(y, np.arange(0, n - 1000 + 1, 1000), block=1000, order=2, mean=False)
    coef = f["coef"][:, 0]
    se = coef.std(axis=0, ddof=1) / np.sqrt(len(coef))
    assert np.all(np.abs(coef.mean(axis=0) - [a1, a2]) < 4 * se + 1e-3)
    assert abs(f["noise_var"].mean() - 1.0) < 0.05


# ---------------------------------------------------------------------------
# normal fits and confusions
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("m1,s1,m2,s2", [(0.0, 1.0, 1.5, 1.0), (0.0, 1.0, 1.0, 2.5),
                                         (-5.4, 0.03, -5.25, 0.16)])
def test_two_normal_errors_against_monte_carlo(m1, s1, m2, s2):
    p12, p21 = two_normal_errors(m1, s1, m2, s2)
    rng = np.random.default_rng(6)
    n = 400_000
    for (m, s), want, other in (((m1, s1), p12, 1), ((m2, s2), p21, 0)):
        x = rng.normal(m, s, n)
        ll = np.column_stack([stats.norm.logpdf(x, m1, s1), stats.norm.logpdf(x, m2, s2)])
        rate = np.mean(np.argmax(ll, axis=1) == other)
        assert abs(rate - want) < 5 * np.sqrt(want * (1 - want) / n) + 1e-4
    if s1 == s2:                                          # equal variances: Phi(-d / 2 s)
        want = stats.norm.cdf(-abs(m2 - m1) / (2 * s1))
        assert p12 == pytest.approx(want, rel=1e-9) and p21 == pytest.approx(want, rel=1e-9)


def test_normal_confusion_rows_sum_to_one_and_match_closed_form():
    means = [np.array([0.0, 0.0]), np.array([2.0, 0.0]), np.array([0.0, 3.0])]
    covs = [np.eye(2)] * 3
    conf = normal_confusion(means, covs, n_draws=100_000, seed=1)
    np.testing.assert_allclose(conf.sum(axis=1), 1.0)
    # classes 0 and 1 alone would be split at x = 1; with a third class far away in y the
    # 0 -> 1 rate stays below the two-class closed form and close to it
    p01 = two_normal_errors(0.0, 1.0, 2.0, 1.0)[0]
    assert conf[0, 1] <= p01 + 0.005 and conf[0, 1] > p01 - 0.03
    assert np.all(np.diag(conf) > 0.6)


def test_confusion_matrix_counts_and_rates():
    true = np.array([0, 0, 0, 1, 1, 2])
    chosen = np.array([0, 1, 0, 1, 1, 0])
    counts, rates = confusion_matrix(true, chosen, 4)
    assert counts.tolist()[:3] == [[2, 1, 0, 0], [0, 2, 0, 0], [1, 0, 0, 0]]
    np.testing.assert_allclose(rates[:3].sum(axis=1), [1, 1, 1])
    assert np.isnan(rates[3]).all()                     # a class without blocks: no rate
    # undetermined choices (-1) count in their row, in no column; unlabelled truth is left out
    counts, rates = confusion_matrix([0, 0, -1, 1], [0, -1, 1, 1], 2)
    assert counts.tolist() == [[1, 0], [0, 1]]
    np.testing.assert_allclose(rates, [[0.5, 0.0], [0.0, 1.0]])


def test_log_energy_prediction_closed_form_and_loo():
    rng = np.random.default_rng(7)
    a, b = rng.normal(-5.4, 0.03, 40), rng.normal(-5.3, 0.05, 40)
    res = log_energy_prediction(np.r_[a, b], np.r_[np.zeros(40, int), np.ones(40, int)])
    p = two_normal_errors(a.mean(), a.std(ddof=1), b.mean(), b.std(ddof=1))
    assert res["predicted_sum"] == pytest.approx(sum(p))
    assert res["predicted_avg"] == pytest.approx(sum(p) / 2)
    assert 0 <= res["loo_sum"] <= 2
    far = log_energy_prediction(np.r_[a, b + 10], np.r_[np.zeros(40, int), np.ones(40, int)])
    assert far["loo_sum"] == 0.0 and far["predicted_sum"] < 1e-12


def test_predicted_confusion_separated_classes():
    rng = np.random.default_rng(8)
    k = np.concatenate([rng.normal(c * 10.0, 1.0, (30, 2)) for c in range(3)])
    labels = np.repeat(np.arange(3), 30)
    pc = predicted_confusion(k, labels, seed=0)
    pred = np.asarray(pc["predicted"])
    np.testing.assert_allclose(pred.sum(axis=1), 1.0)
    assert np.all(np.diag(pred) > 0.999)
    assert np.asarray(pc["resubstitution_counts"]).sum() == 90


# ---------------------------------------------------------------------------
# archives
# ---------------------------------------------------------------------------
def test_restrict_labels(tmp_path):
    src = tmp_path / "src.h5"
    written = write_archive(src)
    dst = restrict_labels(src, tmp_path / "dst.h5", keep=["sliding", "free"])
    assert validate_archive(dst) == []
    with open_archive(dst) as arc:
        for trial in arc:
            old = written[trial.id]["labels"]
            want = np.select([old == LABEL_NAMES.index("sliding"),
                              old == LABEL_NAMES.index("free")], [0, 1], -1)
            assert trial.label_names == ["sliding", "free"]
            np.testing.assert_array_equal(trial.labels, want)
            assert set(trial.segments["label"]) <= {"sliding", "free"}
    with pytest.raises(ValueError):
        restrict_labels(src, tmp_path / "bad.h5", keep=["nope"])


@pytest.fixture(scope="module")
def hf_archive(tmp_path_factory):
    """Two simulated hf-train runs (diagonal move ending in an impact against a block)."""
    return record_spec("hf-train", tmp_path_factory.mktemp("hf") / "hf.h5", seed=3, n_trials=2)


def test_hf_units_lie_inside_one_truth_class(hf_archive):
    from contactlab.experiments.hf_models import BLOCK

    feats = stationary_features(hf_archive)
    assert len(feats["labels"]) > 0 and set(feats["labels"]) <= {0, 1, 2}
    with open_archive(hf_archive) as arc:
        trials = list(arc)
        for i, trial in enumerate(trials):
            b = truth_blocks(trial, signal="hf", block=BLOCK, classes=[0, 1, 2])
            assert np.sum(feats["trial"] == i) == len(b["starts"])
            # y_h[k] uses the inputs 4k .. 4k + 8 (7.1: blocks of 8 differences, step 4)
            for s, c in zip(b["starts"], b["labels"]):
                lo, hi = 4 * s, 4 * (s + BLOCK - 1) + 8 + 1
                assert np.all(trial.labels[lo:hi] == c)        # simulator truth, 1000 Hz


def test_hf_impacts_decay(hf_archive):
    rows = impact_fits(hf_archive)
    with open_archive(hf_archive) as arc:
        n_impacts = sum(len(t.truth("impact_intervals")) for t in arc)
    assert len(rows) == n_impacts >= 2
    assert all(r["slope"] < 0 for r in rows)                  # the falling edge (7.1, fig 7.3)


def test_texture_blocks_on_one_stroke(tmp_path):
    raw = record_spec("stroke-a", tmp_path / "a.h5", seed=2, n_trials=1)
    with open_archive(raw) as arc:
        names = next(iter(arc)).label_names
    arc = restrict_labels(raw, tmp_path / "a-tex.h5", keep=names[3:5])
    f = sample_features(arc, signal="strain")
    assert f["k"].shape[1:] == (8, 2) and f["noise_var"].shape[1] == 8
    assert set(np.unique(f["labels"])) == {0, 1} and set(np.unique(f["yh_labels"])) == {0, 1}
    assert np.all(f["noise_var"] > 0)


def test_experiments_registered():
    for name, module in (("texture-labelling", "contactlab.experiments.texture_labelling"),
                         ("hf-models", "contactlab.experiments.hf_models")):
        exp = get(name)
        assert exp.implemented and exp.module == module and callable(exp.runner())
