"""Building blocks of the chapter-7 labelling experiments (texture-labelling, hf-models).

- :func:`record_spec` / :func:`restrict_labels`: a dataset spec's simulated
  trials as an archive (the ``contactlab acquire`` path), and a copy whose
  ground truth keeps only some classes (the rest unlabelled, -1);
- :func:`conditioned_codes`: per-sample truth labels (input rate) -> one code
  per conditioned (250 Hz) sample, -1 where its input window is not one class;
- :func:`cut_blocks`: consecutive blocks of ``block`` samples inside runs of one
  code (a block never spans a label change; a run's remainder is dropped);
- :func:`block_features`: per block and channel the square-root RLS fit of an
  AR model (7.1) -> orthogonal (LPC) parameters ``k`` of eq. 7.3 and the
  driving-noise variance (the 7.2.2 / 7.3 feature vectors);
- :func:`normal_fit`, :func:`normal_confusion`, :func:`two_normal_errors`: the
  "normal fit" predictions the thesis quotes (7.2.2, 7.3): a normal per class,
  and the confusion of the equal-prior maximum-likelihood rule under those
  normals (Monte Carlo in d dimensions; closed form for two 1-D normals);
- :func:`confusion_matrix`: counts -> row-normalised rates (rows true class).
"""

from __future__ import annotations

import shutil
from pathlib import Path

import h5py
import numpy as np

from contactlab.archive import spec as archive_spec
from contactlab.archive.writer import SEGMENT_DTYPE, create_dataset

__all__ = ["record_spec", "restrict_labels", "conditioned_codes", "cut_blocks",
           "block_features", "normal_fit", "normal_confusion", "two_normal_errors",
           "confusion_matrix", "half_lsb", "conditioned", "trial_blocks", "WINDOW"]


# ---------------------------------------------------------------------------
# archives
# ---------------------------------------------------------------------------
def record_spec(name: str, path: Path, *, seed: int, n_trials: int | None = None) -> Path:
    """Simulate the trials of dataset spec ``name`` into a new archive ``path``
    (exactly what ``contactlab acquire --spec NAME --seed SEED`` records)."""
    from contactlab.acquire import SimSource, load_spec, record

    spec = load_spec(name)
    record(SimSource(spec), out=path, n_trials=n_trials or spec.n_trials, seed=seed,
           force=True, title=f"{name} (labelling experiment)", quiet=True, log=lambda m: None)
    return Path(path)


def restrict_labels(src: Path, dst: Path, *, keep: list[str]) -> Path:
    """Copy archive ``src`` to ``dst`` with ground-truth labels and segments reduced to
    the classes ``keep`` (new codes = positions in ``keep``; all else -1)."""
    dst = Path(dst)
    shutil.copyfile(src, dst)
    with h5py.File(dst, "r+") as h5:
        for tid, trial in h5["trials"].items():
            gt = trial[archive_spec.GROUND_TRUTH]
            old = [str(n.decode() if isinstance(n, bytes) else n)
                   for n in gt["labels"].attrs["names"]]
            missing = [k for k in keep if k not in old]
            if missing:
                raise ValueError(f"trial {tid}: no class {missing} in {old}")
            table = np.full(len(old) + 1, -1, np.int16)      # old code -1 -> index -1 -> -1
            for new, name in enumerate(keep):
                table[old.index(name)] = new
            codes = table[np.asarray(gt["labels"][...], int)]
            time = np.asarray(trial[archive_spec.MEASUREMENTS]["time"][...], float)
            rate = float(trial.attrs["rate_hz"])
            segs = [s for s in _segments(codes, time, rate) if s[2] >= 0]
            rows = np.array(segs, dtype=SEGMENT_DTYPE) if segs else np.zeros(0, SEGMENT_DTYPE)
            names = archive_spec.string_array(keep)
            for key, data in (("labels", codes), ("segments", rows)):
                if key in gt:
                    del gt[key]
                create_dataset(gt, key, data).attrs["names"] = names
    return dst


def _segments(codes, time, rate_hz):
    from contactlab.acquire.sim import segments_from_labels

    return segments_from_labels(codes, time, rate_hz)


# ---------------------------------------------------------------------------
# labels at the conditioned rate, blocks
# ---------------------------------------------------------------------------
def conditioned_codes(codes, index, *, window: int) -> np.ndarray:
    """One label per conditioned sample: ``codes[index[k] - window + 1 .. index[k]]``
    (input-rate codes, clipped to the record) if all equal, else -1.

    ``index`` are the conditioned samples' newest input samples (``low_index``,
    ``hf_index``); ``window`` is the input span a sample depends on
    (:data:`WINDOW`).
    """
    codes = np.asarray(codes, np.int64)
    index = np.clip(np.asarray(index, np.int64), 0, len(codes) - 1)
    lo = np.clip(index - window + 1, 0, None)
    # runs: a window is pure iff it holds no change point
    change = np.r_[0, np.cumsum(np.diff(codes) != 0)]       # run id of each input sample
    pure = change[lo] == change[index]
    return np.where(pure, codes[index], -1)


def cut_blocks(codes, *, block: int, classes=None) -> tuple[np.ndarray, np.ndarray]:
    """Blocks of ``block`` consecutive samples, each inside one run of equal code.

    Each run of code ``c >= 0`` (and in ``classes`` if given) of length ``L``
    gives ``L // block`` blocks from its start; the remainder is dropped.
    Returns ``(starts, block_codes)`` (int arrays, in time order).
    """
    codes = np.asarray(codes, np.int64)
    if block < 1:
        raise ValueError(f"block must be >= 1; got {block}")
    if codes.size == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    edges = np.flatnonzero(np.diff(codes)) + 1
    run_start = np.r_[0, edges]
    run_len = np.diff(np.r_[run_start, codes.size])
    run_code = codes[run_start]
    ok = run_code >= 0
    if classes is not None:
        ok &= np.isin(run_code, np.asarray(list(classes), np.int64))
    n = np.where(ok, run_len // block, 0)
    owner = np.repeat(np.arange(len(n)), n)
    within = np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)
    return run_start[owner] + within * block, run_code[owner]


def block_features(y, starts, *, block: int, order: int, mean: bool) -> dict:
    """AR(``order``) (with a mean if ``mean``) fit to every block and channel of ``y``
    (:func:`contactlab.temporal.block_features`, one batched square-root RLS).

    ``y`` (N, C) conditioned signal; blocks ``y[s:s + block]``.  Returns ``k``
    (nb, C, q): the orthogonal (LPC) parameters of eq. 7.3, ``theta~_j = k~_j /
    L_jj``, in the order ``{mu, a_1, ...}``; ``coef`` (nb, C, q) natural
    parameters; ``noise_var`` (nb, C) ML driving-noise variance (residual energy
    over the block's regression rows; the trained models use rows - q).
    """
    from contactlab.temporal import block_features as features

    f = features(y, order=order, mean=mean, block=block, starts=np.asarray(starts, np.int64))
    return {"k": f.orthogonal, "coef": f.coef, "noise_var": f.residual_energy / f.rows}


# ---------------------------------------------------------------------------
# normal fits and their predicted confusions
# ---------------------------------------------------------------------------
def normal_fit(samples) -> tuple[np.ndarray, np.ndarray]:
    """Mean (d,) and covariance (d, d) (ddof = 1) of ``samples`` (n, d) or (n,)."""
    x = np.asarray(samples, float)
    x = x[:, None] if x.ndim == 1 else x
    if len(x) < 2:
        raise ValueError(f"a normal fit needs at least 2 samples; got {len(x)}")
    return x.mean(axis=0), np.atleast_2d(np.cov(x, rowvar=False, ddof=1))


def normal_confusion(means, covs, *, n_draws: int = 200_000, seed: int = 0) -> np.ndarray:
    """Confusion of the equal-prior maximum-likelihood rule when class ``i`` really is
    ``N(means[i], covs[i])``: row i = P(choose j | i), by ``n_draws`` Monte Carlo draws
    per class (:func:`contactlab.temporal.energy.normal_confusion_mc`)."""
    from contactlab.temporal.energy import normal_confusion_mc

    mu = np.asarray([np.atleast_1d(m) for m in means], float)
    cov = np.asarray([np.atleast_2d(c) for c in covs], float)
    return normal_confusion_mc(mu, cov, n=n_draws, seed=seed)


def two_normal_errors(m1: float, s1: float, m2: float, s2: float) -> tuple[float, float]:
    """``(P(choose 2 | 1), P(choose 1 | 2))`` of the equal-prior rule between
    ``N(m1, s1^2)`` and ``N(m2, s2^2)``, in closed form
    (:func:`contactlab.temporal.energy.normal_confusion_1d`)."""
    from contactlab.temporal.energy import normal_confusion_1d

    conf = normal_confusion_1d([m1, m2], [s1, s2])
    return float(conf[0, 1]), float(conf[1, 0])


def confusion_matrix(true, chosen, n_classes: int) -> tuple[np.ndarray, np.ndarray]:
    """``(counts, rates)``: counts[i, j] of blocks of true class i labelled j, and the
    rows normalised to sum to 1 (a row without blocks stays 0)."""
    true = np.asarray(true, np.int64)
    chosen = np.asarray(chosen, np.int64)
    counts = np.zeros((n_classes, n_classes), np.int64)
    np.add.at(counts, (true, chosen), 1)
    tot = counts.sum(axis=1, keepdims=True)
    return counts, np.divide(counts, tot, out=np.zeros(counts.shape), where=tot > 0)


# ---------------------------------------------------------------------------
# conditioned signals of an archive trial, with their input-sample indices
# ---------------------------------------------------------------------------
#: input samples each conditioned sample depends on: the decimation step (4) for y_l; for
#: y_h[k] the 8 differences y(n) - y(n-1), n = 4k+1 .. 4k+8, i.e. inputs 4k .. 4k+8 (7.1)
WINDOW = {"strain": 4, "wrench": 4, "hf": 9}


def half_lsb(y) -> float:
    """Half the quantisation step of ``y``: :func:`contactlab.conditioning.quantisation_floor`."""
    from contactlab.conditioning import quantisation_floor
    return quantisation_floor(y)


def conditioned(trial, signal: str) -> tuple[np.ndarray, np.ndarray]:
    """``(y, index)``: the 7.1-conditioned ``signal`` of ``trial`` at 250 Hz (for a 1000 Hz
    trial) and each sample's newest input sample. ``strain``: y_l, the strains lowpassed
    at fs/8 and decimated 4:1; ``wrench``: the wrench through the same filter; ``hf``:
    y_h, the block-averaged log|y_d| of every strain with the log floor at half an LSB."""
    from contactlab.conditioning import condition_strains, lowpass_decimate

    fs = float(trial.rate_hz)
    if signal == "wrench":
        y = lowpass_decimate(trial.wrench, fs=fs, cutoff_hz=fs / 8.0, factor=4)
        return y, 4 * np.arange(len(y))
    strain = trial.strain
    floor = half_lsb(strain) if signal == "hf" else 1e-12
    cond = condition_strains(strain, fs=fs, cutoff_hz=fs / 8.0, log_floor=floor)
    if signal == "strain":
        return cond.low, cond.low_index
    if signal == "hf":
        return cond.hf, cond.hf_index
    raise ValueError(f"signal must be strain, wrench or hf; got {signal!r}")


def trial_blocks(trial, *, signal: str, block: int, classes=None) -> dict:
    """The conditioned ``signal`` of ``trial`` and its truth blocks: ``y`` (K, C),
    ``codes`` (K,) per conditioned sample (:func:`conditioned_codes`), ``starts`` and
    ``labels`` of the blocks (:func:`cut_blocks`)."""
    y, index = conditioned(trial, signal)
    codes = conditioned_codes(trial.labels, index, window=WINDOW[signal])
    starts, labels = cut_blocks(codes, block=block, classes=classes)
    return {"y": y, "codes": codes, "starts": starts, "labels": labels}
