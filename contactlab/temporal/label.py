"""Likelihood labelling of blocks (7.2.2) and the leave-one-out of the thesis
(``contactlab label``).

Each block is labelled with the class of largest log-likelihood (7.4-7.5,
:func:`~contactlab.temporal.likelihood.block_loglik`, summed over channels) --
the thesis's forced choice with equal priors.  Accuracy and the confusion
matrix (rows: true class) are counted over blocks whose true class is one of
the models' classes.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from contactlab.errors import DataError, UsageError
from contactlab.metrics import confusion_matrix
from contactlab.stages import Stage, TrialOutcome, run_stage
from contactlab.temporal import energy
from contactlab.temporal.likelihood import block_loglik, loglik_params
from contactlab.temporal.model import ModelSet, TemporalModel
from contactlab.temporal.train import LabelledBlocks, _opened, collect_blocks, fit_models

__all__ = ["label_archive", "loglik_table", "confusion", "log_energy_means"]

LOO_UNITS = ("trial", "block")


def loglik_table(blocks: LabelledBlocks, models: dict[str, TemporalModel]) -> np.ndarray:
    """(K, J) log-likelihood of every block under every class (J = len(models))."""
    if len(blocks) == 0:
        return np.zeros((0, len(models)))
    return np.column_stack([block_loglik(blocks.features, m) for m in models.values()])


def _loo_block_table(blocks: LabelledBlocks, models: dict[str, TemporalModel]) -> np.ndarray:
    """(K, J) like :func:`loglik_table`, but each training block is scored under its
    own class's model refitted without it (downdated mean, covariance and noise
    variance; the structure does not enter 7.5)."""
    table = loglik_table(blocks, models)
    feats = blocks.features
    for j, (name, m) in enumerate(models.items()):
        idx = np.flatnonzero(blocks.label == name)
        K = m.n_blocks
        if idx.size == 0:
            continue
        if idx.size != K:
            raise UsageError("block leave-one-out needs models trained on these very blocks "
                             f"(class {name!r}: {K} training blocks, {idx.size} here)")
        if K - 1 <= m.n_params:
            raise DataError(f"class {name!r} has {K} blocks; leaving one out leaves too few "
                            f"for a covariance of {m.n_params} parameters", field="--loo")
        x = feats.orthogonal[idx]                                   # (k, C, q)
        d = x - m.theta_mean
        mean = m.theta_mean + (m.theta_mean - x) / (K - 1)
        scatter = m.theta_cov * (K - 1) - (K / (K - 1)) * np.einsum("kci,kcj->kcij", d, d)
        cov = scatter / (K - 2)
        noise = (K * m.noise_var - feats.noise_var[idx]) / (K - 1)
        sub = feats.take(idx)
        table[idx, j] = loglik_params(sub, mean, cov, noise, level_sd=m.level_sd,
                                      level_mean=m.level_mean,
                                      level_cov=m.level_cov).sum(axis=1)
    return table


def confusion(true, predicted, labels) -> dict:
    """``{"labels", "matrix" (counts, rows true class), "rates" (rows sum to 1; NaN for a
    class without blocks)}`` of :func:`contactlab.metrics.confusion_matrix`."""
    index = {name: i for i, name in enumerate(labels)}
    counts, rates = confusion_matrix([index[t] for t in true], [index[p] for p in predicted],
                                     len(labels))
    return {"labels": list(labels), "matrix": counts.tolist(), "rates": rates.tolist()}


def _hf_signal(trial, path):
    """The log-energy y_h of the trial's strains (or, lacking strains, of its wrench),
    averaged over channels, and its times (:func:`contactlab.signals.condition`)."""
    from contactlab.signals import condition, default_signal

    if trial.strain is None and trial.wrench is None:
        raise DataError("trial has neither strain nor wrench", file=path,
                        field=f"/trials/{trial.id}/measurements")
    sig = condition(trial, "hf", path=path, source=default_signal(trial))
    return sig.y.mean(axis=1), sig.times


def log_energy_means(archive, blocks: LabelledBlocks) -> np.ndarray:
    """(K,) mean of ``y_h`` (averaged over channels) over each block's time span."""
    out = np.full(len(blocks), np.nan)
    with _opened(archive) as (arch, path):
        for tid in dict.fromkeys(blocks.trial.tolist()):
            idx = np.flatnonzero(blocks.trial == tid)
            h, t = _hf_signal(arch.trial(tid), str(path))
            cs = np.concatenate([[0.0], np.cumsum(h)])
            lo = np.searchsorted(t, blocks.start_s[idx], side="left")
            hi = np.searchsorted(t, blocks.end_s[idx], side="right")
            n = hi - lo
            with np.errstate(invalid="ignore", divide="ignore"):
                out[idx] = np.where(n > 0, (cs[hi] - cs[lo]) / np.maximum(n, 1), np.nan)
    return out


def _log_energy_summary(values, true, classes) -> dict | None:
    """Normal fit per class to block-mean log-energies, its predicted (Bayes,
    equal priors) confusion and error, and the measured error of that rule."""
    keep = np.isin(true, classes) & np.isfinite(values)
    present = [c for c in classes if np.count_nonzero(true[keep] == c) >= 2]
    if len(present) < 2:
        return None
    keep &= np.isin(true, present)
    mu, sd = energy.normal_fit(values[keep], true[keep], present)
    if not (sd > 0).all():
        return None
    conf = energy.normal_confusion_1d(mu, sd)
    pred = np.asarray(present, dtype=object)[energy.classify_1d(values[keep], mu, sd)]
    measured = confusion(true[keep], pred, present)
    rates = np.asarray(measured["rates"])
    return {"labels": present, "mean": mu.tolist(), "std": sd.tolist(),
            "predicted_error": energy.normal_error_1d(mu, sd),
            "predicted_confusion": conf.tolist(),
            "measured_error": float(np.mean(1.0 - np.diagonal(rates))),
            "measured_confusion": measured}


def label_archive(archive, *, models, block: int | None = None, loo=False, trials=None,
                  labels: str | None = None, write: bool = False, quiet: bool = True,
                  workers: int = 1, scheduler: str | None = None) -> dict:
    """Label the blocks of ``archive`` with ``models`` by likelihood (7.2.2).

    Parameters
    ----------
    archive : archive path (or open Archive).  models : a :class:`ModelSet` or
        the path of a models file.  block : block length (default: the models'
        training block).  trials : trial ids (default all).  labels : where the
        blocks and their true classes come from (default the models' training
        source, "truth" or a results stage; see :mod:`.blocks`).  Trials
        without ground truth are cut into consecutive blocks, labelled, and
        left out of the accuracy.
    loo : leave-one-out (7.2.2).  False: the models as given.  True or
        ``"trial"``: the unit left out is a **trial** -- for each trial, the
        classes are retrained (same signal, order, mean, block, label source
        and classes as ``models``) on the blocks of all the other trials of
        this archive, then its blocks are labelled; this is the thesis's
        "one example is left out", an example being a trial's segment.
        ``"block"``: the unit is a **block** -- each block is scored under
        its own class refitted without it ("the mean and covariance of k was
        estimated from the examples with the test block removed"), models
        refitted from this archive's blocks.
    write : store each trial's result in ``results/label``, all trials in one
        atomic step (:func:`contactlab.stages.run_stage`; ``workers`` /
        ``scheduler`` as there, the unit of work being the archive).

    Returns ``{"accuracy", "confusion": {"labels", "matrix", "rates"},
    "predicted_error", "log_energy", "n_blocks", "trials": {id: {...}}, ...}``;
    ``accuracy`` is None when no block has a known true class.
    """
    stage = LabelStage(models=models, block=block, loo=loo, labels=labels, write=write,
                       quiet=quiet)
    if hasattr(archive, "trial_ids"):                  # an open Archive: in this process
        out = stage.run_archive(archive, archive.select(trials))
        if write:
            from contactlab.archive import write_stage
            write_stage(Path(archive.path), stage.name, out.extra["results"])
        return out.entry
    return run_stage(stage, [archive], trials=trials, workers=workers, scheduler=scheduler,
                     quiet=quiet)[Path(archive)]


class LabelStage(Stage):
    """``contactlab label`` as a stage: the parameters of :func:`label_archive`.

    Its unit of work is the archive (``per_archive``): the channels used are
    those that vary in every trial, and a leave-one-trial-out refits the
    classes on the other trials.
    """

    name = "label"
    per_archive = True

    def __init__(self, *, models, block: int | None = None, loo=False,
                 labels: str | None = None, write: bool = True, quiet: bool = True):
        if not isinstance(models, ModelSet):
            models = ModelSet.load(models)
        if loo is True:
            loo = "trial"
        if loo not in (False, None) + LOO_UNITS:
            raise UsageError(f"loo must be False, True, 'trial' or 'block'; got {loo!r}")
        self.models, self.loo = models, loo or None
        self.block = models.block if block is None else int(block)
        self.labels, self.write, self.quiet = labels, write, quiet

    def run_archive(self, archive, trial_ids) -> TrialOutcome:
        """Label the blocks of ``trial_ids``; the summary and every trial's results."""
        summary, collected, table, pred = _label(archive, self.models, self.block, self.loo,
                                                 trial_ids, self.labels, self.quiet)
        results = _results(collected, table, pred, self.models.labels, summary)
        return TrialOutcome(summary, None, {"results": results})


def _label(archive, models, block, loo, trials, labels, quiet):
    """The labelling of :func:`label_archive` over an open archive: the summary, the
    blocks, their log-likelihood table and predicted classes."""
    from contactlab.progress import progress

    source = labels or models.provenance.get("labels", "truth")
    classes = models.labels
    with _opened(archive) as (arch, path):
        collected = collect_blocks(arch, labels=source, signal=models.signal,
                                   order=models.order, mean=models.mean, block=block,
                                   trials=trials, channels=models.channels,
                                   keep_unlabelled=loo is None, quiet=quiet)
        true = collected.label
        if loo is None:
            use = models.models
            if len(models.channels or range(collected.features.channels)) != \
                    next(iter(use.values())).channels:
                raise DataError("models and archive differ in channels", file=str(path),
                                field=f"measurements/{models.signal}")
            table = loglik_table(collected, use)
        elif loo == "block":
            use, _ = fit_models(collected, classes=classes, path=str(path))
            table = _loo_block_table(collected, use)
        else:
            table = np.full((len(collected), len(classes)), np.nan)
            tids = list(dict.fromkeys(collected.trial.tolist()))
            if len(tids) < 2:
                raise DataError("leave-one-trial-out needs blocks from at least 2 trials",
                                file=str(path), field="--loo")
            for tid in progress(tids, desc="leave-one-out", quiet=quiet, unit="trial"):
                out = collected.trial == tid
                fitted, _ = fit_models(collected, classes=classes, mask=~out, path=str(path))
                table[out] = loglik_table(collected, fitted)[out]
        pred = np.asarray(classes, dtype=object)[np.argmax(table, axis=1)] if len(table) \
            else np.zeros(0, dtype=object)
        scored = np.isin(true, classes)
        energy_values = log_energy_means(arch, collected) if scored.any() else None

    summary: dict = {
        "accuracy": float(np.mean(pred[scored] == true[scored])) if scored.any() else None,
        "confusion": confusion(true[scored], pred[scored], classes),
        "predicted_error": None,
        "n_blocks": int(scored.sum()),
        "n_unscored": int((~scored).sum()),
        "loo": loo,
        "signal": models.signal, "block": block, "order": models.order, "mean": models.mean,
        "labels_source": source,
    }
    if energy_values is not None:
        le = _log_energy_summary(energy_values[scored], true[scored], classes)
        summary["log_energy"] = le
        summary["predicted_error"] = None if le is None else le["predicted_error"]
    per_trial: dict = {}
    for tid in collected.signals:
        idx = np.flatnonzero(collected.trial == tid)
        sc = scored[idx]
        per_trial[tid] = {
            "start_s": collected.start_s[idx].tolist(),
            "end_s": collected.end_s[idx].tolist(),
            "true": [t if t else None for t in true[idx].tolist()],
            "predicted": pred[idx].tolist(),
            "accuracy": float(np.mean(pred[idx][sc] == true[idx][sc])) if sc.any() else None,
        }
    summary["trials"] = per_trial
    return summary, collected, table, pred


def _results(blocks: LabelledBlocks, table, pred, classes, summary) -> dict:
    """Every trial's ``results/label``."""
    from contactlab.archive import TrialResults

    code = {c: i for i, c in enumerate(classes)}
    results = {}
    for tid in blocks.signals:
        idx = np.flatnonzero(blocks.trial == tid)
        results[tid] = TrialResults(
            datasets={"start_s": blocks.start_s[idx], "end_s": blocks.end_s[idx],
                      "predicted": np.array([code[p] for p in pred[idx]], dtype=np.int16),
                      "true": np.array([code.get(t, -1) for t in blocks.label[idx]],
                                       dtype=np.int16),
                      "loglik": table[idx]},
            attrs={"label_names": list(classes), "signal": blocks.signal,
                   "codes": "predicted/true index label_names; true -1: not a model class "
                            "or unlabelled"},
            parameters={"block": blocks.block, "loo": summary["loo"],
                        "labels_source": summary["labels_source"],
                        "order": summary["order"], "mean": summary["mean"],
                        "channels": blocks.channels})
    return results
