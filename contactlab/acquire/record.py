"""The acquisition loop: a :class:`~contactlab.acquire.base.Source` -> an archive.

Each trial is committed as it completes through the incremental archive writer
(in place behind a rollback journal once the first one is), so an interruption
leaves every finished trial readable and the archive valid: Ctrl-C or SIGTERM
(which :func:`record` turns into the same KeyboardInterrupt while it runs)
drops the trial in progress and says what was kept, a second signal quits at
once keeping the same, and a SIGKILL loses at most the trial in progress (the
next run on the archive plays the journal back). ``append`` copies the existing
trials into a new file first; it replaces the original by an atomic rename when
its first new trial is finished.
"""

from __future__ import annotations

import sys
from pathlib import Path

from contactlab.archive import create_archive
from contactlab.errors import UsageError
from contactlab.interrupt import Terminated, signals_as_interrupt  # noqa: F401 - re-exported
from contactlab.progress import bar


#: SIGTERM is handled like Ctrl-C while :func:`record` runs (kept here for callers).
sigterm_as_interrupt = signals_as_interrupt


def record(source, *, out: str | Path, n_trials: int, seed: int, append: bool = False,
           force: bool = False, title: str = "", quiet: bool = False, log=None) -> dict:
    """Record ``n_trials`` trials of ``source`` into the archive ``out``.

    ``append`` adds to an existing archive (its trials are kept; new ids must
    not clash); otherwise an existing ``out`` is refused unless ``force``.
    ``log(message)`` (default: stderr unless ``quiet``) hears one line per
    finished trial. Returns ``{file, trials_written, trial_ids, seed, source}``.
    """
    out = Path(out)
    if n_trials < 1:
        raise UsageError(f"--trials must be at least 1, not {n_trials}")
    if append and not out.exists():
        raise UsageError(f"--append: {out} does not exist (leave out --append to create it)")
    if append and force:
        raise UsageError("--append and --force exclude each other")
    if append:
        from contactlab.archive.validate import check_archive

        check_archive(out)  # an archive that does not conform is left as it is
    if log is None:
        def log(message: str) -> None:
            if not quiet:
                print(message, file=sys.stderr, flush=True)
    written: list[str] = []
    with sigterm_as_interrupt():
        writer = create_archive(out, force=force or append, title=title, incremental=True)
        with writer:
            if append:
                writer.copy_trials_from(out)
            for stream in source.trials(n_trials=n_trials, seed=seed):
                _record_trial(writer, stream, quiet=quiet)
                written.append(stream.info.trial_id)
                log(f"acquire: trial {stream.info.trial_id} written "
                    f"({len(written)}/{n_trials})")
    return {"file": str(out), "trials_written": len(written), "trial_ids": written,
            "seed": seed, "source": getattr(source, "name", type(source).__name__)}


def finish_trial(trial, stream, *, truth: bool = True) -> None:
    """Write what a source knows once its trial has ended into the trial being written:
    its ground truth (``stream.ground_truth()``: labels and segments, and the simulator's
    per-sample truth; skipped when ``truth`` is False) and its optional extra datasets of
    one row per sample (hardware bookkeeping, ``stream.extra_datasets()``)."""
    gt = stream.ground_truth() if truth else None
    if gt:
        gt = dict(gt)
        extra = gt.pop("truth", None)
        if "labels" in gt:
            trial.set_ground_truth(**gt)
        if extra:
            trial.set_truth(**extra)
    extra = getattr(stream, "extra_datasets", None)  # optional: hardware bookkeeping
    for name, data in (extra() if extra else {}).items():
        if len(data) == trial.n_samples:
            trial.set_extra(name, data)


def _record_trial(writer, stream, *, quiet: bool) -> None:
    info = stream.info
    trial = writer.add_trial(
        info.trial_id, rate_hz=info.rate_hz, controller=info.controller,
        environment=info.environment, seed=info.seed, source=info.source,
        description=info.description, calibration=info.calibration,
        command_columns=info.command_columns, action_names=info.action_names,
        strain_units=info.strain_units, command_units=info.command_units)
    progress = bar(total=None, desc=info.trial_id, quiet=quiet, unit="sample")
    try:
        for chunk in stream.chunks():
            trial.append(**chunk)
            progress.update(len(chunk["time"]))
    finally:
        progress.close()
    finish_trial(trial, stream)
    attrs = {**info.attrs, **(stream.final_attrs() or {})}
    trial.set_attrs(attrs)
    trial.close()
