"""Scores of decisions against ground truth: the one confusion matrix.

Every stage and experiment that compares chosen classes with true ones
(``label``, ``recognize``, the degree decisions of chapter 8, the labelling
experiments) counts them with :func:`confusion_matrix`, so they share one
convention:

* rows are the true class, columns the chosen class (scikit-learn's
  ``confusion_matrix`` convention; counted here with ``numpy.bincount``, which gives the
  same counts without importing scikit-learn, a second of a command's start);
* a sample whose true class is negative (unlabelled) is left out;
* a negative choice (undetermined, no decision) counts in its row's total but
  in no column, so a row of ``rates`` sums to the fraction decided;
* a class with no samples has a row of NaN rates: no data, not 0 %.
"""

from __future__ import annotations

import numpy as np

__all__ = ["confusion_matrix"]


def confusion_matrix(true, chosen, n_classes: int) -> tuple[np.ndarray, np.ndarray]:
    """``(counts, rates)`` over classes ``0 .. n_classes - 1`` (see the module notes).

    Returns
    -------
    counts : (n, n) int64, ``counts[i, j]`` samples of true class i chosen as j.
    rates : (n, n) float, counts divided by the number of samples of true class i
        (undetermined choices included); NaN rows for classes without samples.
    """
    true = np.asarray(true, dtype=np.int64).reshape(-1)
    chosen = np.asarray(chosen, dtype=np.int64).reshape(-1)
    if true.shape != chosen.shape:
        raise ValueError(f"true and chosen differ in length ({true.size} vs {chosen.size})")
    n = int(n_classes)
    keep = (true >= 0) & (true < n)
    pair = keep & (chosen >= 0) & (chosen < n)
    counts = np.bincount(true[pair] * n + chosen[pair], minlength=n * n)[:n * n].reshape(n, n)
    counts = counts.astype(np.int64)
    totals = np.bincount(true[keep], minlength=n)[:n, None]
    with np.errstate(invalid="ignore", divide="ignore"):
        rates = np.where(totals > 0, counts / np.maximum(totals, 1), np.nan)
    return counts, rates
