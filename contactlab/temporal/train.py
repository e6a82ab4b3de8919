"""Training the class models of 7.2.2 / A.2.3 from an archive (``contactlab train``).

:func:`collect_blocks` cuts every trial's conditioned signal into labelled
blocks (:mod:`.blocks`) and computes their features (:mod:`.features`) once;
:func:`fit_models` fits one :class:`~contactlab.temporal.model.TemporalModel`
per class from any subset of them (the leave-one-out of :mod:`.label` refits
from subsets without recomputing features); :func:`train_temporal` does both
and wraps the result in a :class:`~contactlab.temporal.model.ModelSet` with
its provenance.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import os
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from contactlab import __version__
from contactlab import defaults as D
from contactlab.errors import DataError, UsageError
from contactlab.signals import SIGNALS, resolve_signal
from contactlab.temporal.blocks import TrialSignal, cut_blocks, label_runs, load_signal
from contactlab.temporal.features import BlockFeatures, block_features, min_block
from contactlab.temporal.model import ModelSet, TemporalModel, fit_class
from contactlab.fileio import sha256_file

__all__ = ["LabelledBlocks", "collect_blocks", "fit_models", "train_temporal", "fit_temporal",
           "check_settings"]


@dataclass(frozen=True, eq=False)
class LabelledBlocks:
    """Every block of an archive with its features and where it came from.

    features : (K, C, q) :class:`BlockFeatures`.  label : (K,) class names
    ("" when unlabelled).  trial : (K,) trial ids.  start : (K,) first sample
    in the conditioned signal; start_s, end_s : (K,) times (s) of its first
    and last sample.  signals : the conditioned signals by trial id.
    channels : the signal's channels used.  labelled_trials : trials that had
    ground truth; names : every ground-truth label name (union over trials).
    """

    features: BlockFeatures
    label: np.ndarray
    trial: np.ndarray
    start: np.ndarray
    start_s: np.ndarray
    end_s: np.ndarray
    signals: dict[str, TrialSignal]
    channels: list[int]
    fs: float
    signal: str
    block: int
    labels: str
    labelled_trials: list[str]
    names: list[str]

    def __len__(self) -> int:
        return int(self.label.size)


def check_settings(*, signal: str | None, order, mean, block) -> None:
    """UsageError / DataError for settings no block can satisfy (``signal`` None: the
    trial's default, :func:`contactlab.signals.default_signal`)."""
    if signal is not None and signal not in SIGNALS:
        raise UsageError(f"signal must be one of {', '.join(SIGNALS)}; got {signal!r}")
    if not isinstance(order, (int, np.integer)) or isinstance(order, bool) or order < 1:
        raise UsageError(f"order must be an integer >= 1; got {order!r}")
    if not isinstance(mean, (bool, np.bool_)):
        raise UsageError(f"mean must be True or False; got {mean!r}")
    if not isinstance(block, (int, np.integer)) or isinstance(block, bool):
        raise UsageError(f"block must be an integer; got {block!r}")
    need = min_block(int(order), bool(mean))
    if block < need:
        raise DataError(f"blocks of {block} samples are shorter than AR({order})"
                        f"{' with a mean' if mean else ''} needs ({need}: {order} samples of "
                        f"history and {need - order} rows)", field="--block")


@contextlib.contextmanager
def _opened(archive):
    """Yield ``(Archive, path)`` for a path or an already open Archive."""
    from contactlab.archive import open_archive

    if hasattr(archive, "trial_ids"):
        yield archive, Path(archive.path)
    else:
        with open_archive(archive) as a:
            yield a, Path(archive)


def collect_blocks(archive, *, labels: str = "truth", signal: str | None = None,
                   order: int = D.TRAIN_ORDER,
                   mean: bool = False, block: int = D.BLOCK, trials=None, channels=None,
                   keep_unlabelled: bool = False, quiet: bool = True) -> LabelledBlocks:
    """Blocks of every trial (or ``trials``) of ``archive`` and their features.

    ``labels`` is "truth" or a results stage (see :mod:`.blocks`).  Only
    labelled blocks are kept unless ``keep_unlabelled`` (then a trial without
    ground truth and ``labels="truth"`` is cut into consecutive blocks, label
    "").  ``channels`` selects signal columns (default: the columns that vary
    in every trial).  ``signal`` None: strain when the first trial has strain
    gauges, else wrench (:func:`contactlab.signals.default_signal`).
    """
    from contactlab.progress import progress

    if not isinstance(labels, str) or not labels:
        raise UsageError(f"labels must be 'truth' or a results stage name; got {labels!r}")
    with _opened(archive) as (arch, path):
        try:
            check_settings(signal=signal, order=order, mean=mean, block=block)
        except DataError as err:
            raise DataError(err.message, file=str(path), field=err.field) from None
        ids = arch.select(trials)
        if not ids:
            raise DataError("archive has no trials", file=str(path), field="/trials")
        signal = resolve_signal(arch.trial(ids[0]), signal, path=path)
        sigs: dict[str, TrialSignal] = {}
        runs: dict[str, tuple] = {}
        for tid in progress(ids, desc="blocks", quiet=quiet, unit="trial"):
            trial = arch.trial(tid)
            sig = load_signal(trial, signal, path=path)
            sigs[tid] = sig
            runs[tid] = label_runs(trial, sig, labels, path=path)
    return _blocks(sigs, runs, signal=signal, labels=labels, order=order, mean=mean,
                   block=block, channels=channels, keep_unlabelled=keep_unlabelled,
                   path=str(path))


def _blocks(sigs: dict, runs: dict, *, signal, labels, order, mean, block, channels,
            keep_unlabelled, path) -> LabelledBlocks:
    """The blocks of every recording's conditioned signal ``sigs[id]`` inside its label
    runs ``runs[id] = (rows [start, end, code], names or None)``, and their features
    (``channels`` None: the columns that vary in every recording)."""
    widths = {s.y.shape[1] for s in sigs.values()}
    if len(widths) != 1:
        raise DataError(f"trials have different numbers of {signal} channels {sorted(widths)}",
                        file=path, field=f"measurements/{signal}")
    width = widths.pop()
    if channels is None:
        varies = np.ones(width, dtype=bool)
        for s in sigs.values():
            varies &= np.ptp(s.y, axis=0) > 0
        channels = [int(c) for c in np.flatnonzero(varies)]
        if not channels:
            raise DataError(f"every {signal} channel is constant", file=path,
                            field=f"measurements/{signal}")
    else:
        channels = [int(c) for c in channels]
        if any(not 0 <= c < width for c in channels):
            raise DataError(f"channels {channels} outside the signal's {width}",
                            file=path, field=f"measurements/{signal}")
    parts, lab, tri, st, s0, s1 = [], [], [], [], [], []
    labelled, all_names = [], []
    for tid, sig in sigs.items():
        rows, names = runs[tid]
        if names is not None:
            labelled.append(tid)
            all_names.extend(n for n in names if n not in all_names)
        if keep_unlabelled and names is None and labels == "truth":
            rows = np.array([[0, len(sig.times), -1]], dtype=np.int64)
        starts, codes = cut_blocks(rows, block)
        if not keep_unlabelled:
            starts, codes = starts[codes >= 0], codes[codes >= 0]
        if starts.size == 0:
            continue
        y = sig.y[:, channels]
        parts.append(block_features(y, order=order, mean=mean, block=block, starts=starts))
        lab.append(np.array([names[c] if c >= 0 else "" for c in codes], dtype=object))
        tri.append(np.full(starts.size, tid, dtype=object))
        st.append(starts)
        s0.append(sig.times[starts])
        s1.append(sig.times[starts + block - 1])
    feats = BlockFeatures.concat(parts, order=int(order), mean=bool(mean), block=int(block),
                                 channels=len(channels))
    cat = lambda xs, dt: np.concatenate(xs) if xs else np.zeros(0, dtype=dt)  # noqa: E731
    fs = next(iter(sigs.values())).fs
    return LabelledBlocks(features=feats, label=cat(lab, object), trial=cat(tri, object),
                          start=cat(st, np.int64), start_s=cat(s0, float),
                          end_s=cat(s1, float), signals=sigs, channels=channels, fs=fs,
                          signal=signal, block=int(block), labels=labels,
                          labelled_trials=labelled, names=all_names)


def fit_models(blocks: LabelledBlocks, *, classes=None, mask=None, path=None
               ) -> tuple[dict[str, TemporalModel], dict[str, int]]:
    """One model per class from the blocks in ``mask`` (default all).

    ``classes`` None: every ground-truth label name; one with too few blocks
    for its covariance (none at all included) is skipped and returned in the
    second value (label -> blocks).  Explicit ``classes``: an unknown label,
    an empty class or one with too few blocks is a DataError.
    """
    sel = np.ones(len(blocks), dtype=bool) if mask is None else np.asarray(mask, dtype=bool)
    sel &= blocks.label != ""
    present = list(dict.fromkeys(blocks.label[sel].tolist()))
    src = "ground-truth labels" if blocks.labels == "truth" else \
        f"segments of results/{blocks.labels} (labelled by majority ground truth)"
    if not blocks.labelled_trials:
        raise DataError("no ground-truth labels in any trial (training needs "
                        "ground_truth/labels to name the classes)", file=path,
                        field="/trials/*/ground_truth/labels")
    if not present:
        raise DataError(f"no labelled block of {blocks.block} samples in the {src}",
                        file=path, field="--block")
    explicit = classes is not None
    if explicit:
        classes = [str(c) for c in classes]
        if not classes:
            raise UsageError("classes must name at least one label")
        for c in classes:
            if c not in blocks.names:
                raise DataError(f"unknown label {c!r} (the labels are: "
                                f"{', '.join(blocks.names)})", file=path,
                                field="ground_truth/labels")
    else:
        classes = [c for c in blocks.names if c in present] + \
            [c for c in blocks.names if c not in present] + \
            [c for c in present if c not in blocks.names]
    models: dict[str, TemporalModel] = {}
    skipped: dict[str, int] = {}
    q = blocks.features.n_params
    for c in classes:
        idx = np.flatnonzero(sel & (blocks.label == c))
        if not explicit and idx.size <= q:
            skipped[c] = int(idx.size)
            continue
        if idx.size == 0:
            raise DataError(f"empty class {c!r}: no block of {blocks.block} samples inside "
                            f"one run of it in the {src}", file=path, field="ground_truth/labels")
        try:
            models[c] = fit_class(c, blocks.features.take(idx), block=blocks.block)
        except ValueError as err:
            raise DataError(str(err), file=path, field="ground_truth/labels") from None
    if not models:
        raise DataError("no class has enough blocks for a covariance of "
                        f"{q} parameters (blocks per class: {skipped})", file=path,
                        field="ground_truth/labels")
    return models, skipped



def train_temporal(archive, *, labels: str = "truth", signal: str | None = None,
                   order: int = D.TRAIN_ORDER,
                   mean: bool = False, block: int = D.BLOCK, trials=None, classes=None,
                   quiet: bool = True, command: str | None = None) -> ModelSet:
    """Train one :class:`TemporalModel` per class of ``archive`` (7.2.2, A.2.3).

    Per class and channel: the mean and covariance of the blocks' orthogonal
    parameters (the prior of eq. 7.3's k), the mean driving-noise variance and
    the pooled training structure.

    Parameters
    ----------
    archive : path of an archive (or an open :class:`~contactlab.archive.Archive`).
    labels : ``"truth"`` (per-sample ground truth) or a results stage (e.g.
        ``"segment"``: its boundaries, each segment named by its majority
        ground-truth label; see :mod:`.blocks`).
    signal : conditioned signal, ``"strain"`` | ``"wrench"`` | ``"hf"`` (7.1); default
        strain when the trials have strain gauges, else wrench.
    order, mean : AR(order), with a constant regressor if ``mean``.
    block : samples per block (100 in the thesis); blocks never span a label change.
    trials : trial ids to use (default all).
    classes : labels to train (default every label with more blocks than
        parameters; the others are listed in ``provenance["skipped"]``).
    command : the command line to record in the provenance (default sys.argv).

    Raises DataError (one line, file and field) for: no ground-truth labels,
    an unknown label in ``classes``, an empty class, too few blocks for a
    covariance, blocks shorter than the order needs, a missing results stage.
    """
    with _opened(archive) as (arch, path):
        blocks = collect_blocks(arch, labels=labels, signal=signal, order=order, mean=mean,
                                block=block, trials=trials, quiet=quiet)
        ids = list(trials) if trials else list(arch.trial_ids)
    models, skipped = fit_models(blocks, classes=classes, path=str(path))
    provenance = {
        "archive": str(Path(path).resolve()),
        "archive_sha256": sha256_file(Path(path)),
        "trials": ids,
        "labels": labels,
        "classes": list(models),
        "skipped": skipped,
        "signal": blocks.signal,
        "block": int(block),
        "order": int(order),
        "mean": bool(mean),
        "blocks": {k: m.n_blocks for k, m in models.items()},
        "created": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "contactlab_version": __version__,
        "command": command if command is not None else " ".join(
            [os.path.basename(sys.argv[0])] + sys.argv[1:]),
    }
    return ModelSet(models=models, signal=blocks.signal, fs=blocks.fs, provenance=provenance,
                    channels=blocks.channels)


def fit_temporal(recordings, *, labels, fs: float, signal: str = "strain",
                 order: int = D.TRAIN_ORDER, mean: bool = False, block: int = D.BLOCK,
                 classes=None, channels=None) -> ModelSet:
    """Train one :class:`TemporalModel` per class from arrays (:func:`train_temporal`
    does the same from an archive's trials, through the same blocks and fit).

    Parameters
    ----------
    recordings : a sequence of ``(y, codes)``: a conditioned signal ``y``, ``(n,)`` or
        ``(n, channels)`` at rate ``fs``, and the label of each sample, ``(n,)``
        indices into ``labels`` (-1: unlabelled).
    labels : the class names the codes index.
    fs : the signal's rate, Hz; ``signal``: its name, recorded in the models.
    order, mean, block, classes, channels : as for :func:`train_temporal` and
        :func:`collect_blocks` (``channels`` None: the columns that vary in every
        recording).

    Returns the :class:`ModelSet` (``save`` writes the models file ``train`` writes).
    """
    from contactlab.signals import Signal
    from contactlab.temporal.blocks import runs_from_codes

    check_settings(signal=signal, order=order, mean=mean, block=block)
    names = [str(n) for n in labels]
    sigs, runs = {}, {}
    for i, (y, codes) in enumerate(recordings):
        y = np.asarray(y, np.float64)
        y = y.reshape(len(y), -1)
        n = len(y)
        codes = np.asarray(codes, np.int64)
        if codes.shape != (n,) or codes.max(initial=-1) >= len(names):
            raise ValueError(f"recording {i}: the codes must be one index into labels (or -1) "
                             f"per sample ({n})")
        sigs[str(i)] = Signal(signal, y, np.arange(n), np.arange(n) / float(fs), float(fs),
                              str(i))
        runs[str(i)] = (runs_from_codes(codes), names)
    blocks = _blocks(sigs, runs, signal=signal, labels="truth", order=order, mean=mean,
                     block=block, channels=channels, keep_unlabelled=False, path=None)
    models, skipped = fit_models(blocks, classes=classes)
    provenance = {
        "archive": None, "trials": list(sigs), "labels": "truth", "classes": list(models),
        "skipped": skipped, "signal": signal, "block": int(block), "order": int(order),
        "mean": bool(mean), "blocks": {k: m.n_blocks for k, m in models.items()},
        "created": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "contactlab_version": __version__, "command": "fit_temporal",
    }
    return ModelSet(models=models, signal=signal, fs=float(fs), provenance=provenance,
                    channels=blocks.channels)
