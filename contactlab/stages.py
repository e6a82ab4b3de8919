"""One shape for the analysis stages (segment, label, estimate, recognize).

After scikit-learn's estimators and ruptures' ``BaseEstimator``: a stage's
constructor only stores and checks its parameters; :meth:`Stage.run_trial`
is a pure function of one trial (it reads the trial, returns a
:class:`TrialOutcome`, writes nothing), so it runs unchanged in another
process or on another machine; :meth:`Stage.summarize` pools the outcomes of
one archive. :func:`run_stage` drives it::

    select trials -> run_trial for each (serial, local processes, or a Dask
    cluster) -> write every trial's results in one atomic step per archive
    (contactlab.archive.write_stage) -> summarize

A run interrupted before the write leaves every old result as it was; when
trials fail, the other trials' results are written and the run ends with one
DataError line naming the archive and the first failed trial, its reason, and
how many others failed.

Bad input.  Before a trial runs, it is checked where it runs
(:func:`contactlab.archive.validate.trial_problems`): the schema walk over the
trial (layout, dtypes, shapes, attributes), then the value checks of its
measurements (finite values, an increasing time base at the trial's rate,
...) on the arrays the trial caches, which the stage then reads without
decompressing them again.  So the checks are shared among the workers; the
commands check the rest of the archive up front
(``check_archive(values=False, walk_trials=False)``).  A trial that fails
them stops the whole run before anything is written, with the error
``contactlab validate`` would give (file, field and what is wrong).

Parallel work: ``workers=1`` (the default) runs in this process -- a stage
over a few trials is faster without starting processes that each load the
numba kernels again; ``workers=N`` runs trials in a local pool of N
processes; ``scheduler="tcp://host:8786"`` sends them to an existing Dask
distributed cluster, whose workers must see the archives at the same paths
(a shared filesystem). Results are the same whichever runs them.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

from contactlab.archive.results import TrialResults
from contactlab.errors import DataError, UsageError

__all__ = ["Stage", "TrialOutcome", "TrialFailure", "check_workers", "parallel_map", "run_stage"]


@dataclass
class TrialOutcome:
    """What :meth:`Stage.run_trial` returns for one trial.

    ``entry``: the trial's JSON-able summary; ``results``: what to store in
    ``results/<stage>`` (None: nothing); ``extra``: anything
    :meth:`Stage.summarize` pools (confusion counts, metrics, ...).
    """

    entry: dict
    results: TrialResults | None = None
    extra: dict = field(default_factory=dict)


@dataclass
class TrialFailure:
    """A trial whose ``run_trial`` raised: the message names archive and trial."""

    archive: str
    trial: str
    message: str
    field: str = ""
    #: the trial's measurements failed the archive's value checks (Problems)
    problems: list = dataclasses.field(default_factory=list)


class Stage:
    """Base class of stages. Subclasses set ``name`` and define :meth:`run_trial`.

    Every attribute set by the constructor must pickle (it travels to worker
    processes with the stage).
    """

    #: The results group the stage writes (``results/<name>``).
    name: str = ""
    #: False for runs that only report (a threshold sweep, ``--no-write``).
    write: bool = True
    #: True for stages whose unit of work is the archive (a leave-one-trial-out
    #: refits on the other trials): :meth:`run_archive` instead of ``run_trial``.
    per_archive: bool = False

    def select(self, archive, trials: Sequence[str] | None) -> list[str]:
        """The trial ids to run (default: ``archive.select(trials)``)."""
        return archive.select(trials)

    def run_trial(self, trial) -> TrialOutcome:  # pragma: no cover - abstract
        """Analyse one trial; pure: reads ``trial``, returns its outcome."""
        raise NotImplementedError

    def run_archive(self, archive, trial_ids: list[str]) -> TrialOutcome:  # pragma: no cover
        """For ``per_archive`` stages: analyse the trials ``trial_ids`` of the open
        ``archive`` together; ``entry`` is the archive's summary and
        ``extra["results"]`` maps trial ids to :class:`TrialResults`."""
        raise NotImplementedError

    def summarize(self, path: Path, outcomes: dict[str, TrialOutcome]) -> dict:
        """The archive's summary (default ``{"trials": {id: entry}}``)."""
        return {"trials": {tid: o.entry for tid, o in outcomes.items()}}


def check_workers(workers: int, scheduler: str | None) -> None:
    """Refuse worker counts below 1 and asking for both a pool and a cluster."""
    if not isinstance(workers, int) or workers < 1:
        raise UsageError(f"workers must be an integer >= 1; got {workers!r}")
    if scheduler is not None and workers != 1:
        raise UsageError("give --workers or --scheduler, not both")


def run_stage(stage: Stage, paths: Iterable[str | os.PathLike], *,
              trials: Sequence[str] | None = None, workers: int = 1,
              scheduler: str | None = None, quiet: bool = True,
              check_trials: bool = True) -> dict[Path, dict]:
    """Run ``stage`` over the archives ``paths``; return ``{path: summary}``.

    ``trials``: ids to run in every archive (default all). Results of each
    archive are written in one atomic step once all its trials have run; a
    failed trial is left out of the write and reported in the DataError
    raised at the end.  ``check_trials``: check each trial (layout and
    measurement values) where it runs (see the module notes; False when the
    caller checked the whole archive).
    """
    from contactlab.archive import open_archive
    from contactlab.archive.results import check_archive_writable, write_stage
    from contactlab.archive.validate import raise_problems

    check_workers(workers, scheduler)
    paths = list(dict.fromkeys(Path(p) for p in paths))
    if not paths:
        raise UsageError("no archive given")
    tasks: list[tuple[Path, str]] = []
    for path in paths:
        if stage.write and stage.name:
            check_archive_writable(path)      # also: no such file
        with open_archive(path) as archive:
            ids = stage.select(archive, trials)
        tasks += [(path, tuple(ids))] if stage.per_archive else [(path, tid) for tid in ids]
    done = _map(stage, tasks, workers=workers, scheduler=scheduler, quiet=quiet,
                check_trials=check_trials)
    for path in paths:                        # bad input: nothing is written
        raise_problems(path, [p for task, got in done.items() if task[0] == path and
                              isinstance(got, TrialFailure) for p in got.problems])
    failures: list[TrialFailure] = []
    summaries: dict[Path, dict] = {}
    written = 0
    for path in paths:
        outcomes: dict[str, TrialOutcome] = {}
        for p, tid in tasks:
            if p != path:
                continue
            got = done[(p, tid)]
            if isinstance(got, TrialFailure):
                failures.append(got)
            else:
                outcomes[tid] = got
        if stage.per_archive:
            if not outcomes:
                continue
            whole = next(iter(outcomes.values()))
            results, summaries[path] = whole.extra["results"], whole.entry
        else:
            results = {tid: o.results for tid, o in outcomes.items() if o.results is not None}
            summaries[path] = stage.summarize(path, outcomes)
        if stage.write and stage.name and results:
            write_stage(path, stage.name, results)
            written += 1
    if failures:
        first = failures[0]
        notes = []
        if len(failures) > 1:
            names = [f"{f.archive}:{f.trial}" if f.archive != first.archive else f.trial
                     for f in failures[1:]]
            more = ", ".join(names[:5]) + (", ..." if len(names) > 5 else "")
            notes.append(f"{len(failures)} failed; also {more}")
        if written:
            notes.append("the other results were written")
        field = first.field or (f"/trials/{first.trial}" if first.trial != "*" else None)
        raise DataError(first.message + (f" ({'; '.join(notes)})" if notes else ""),
                        file=first.archive, field=field)
    return summaries


def _run_one(stage: Stage, path: Path, tid, archive,
             check_trials: bool = True) -> TrialOutcome | TrialFailure:
    """Run one trial (``tid`` a tuple of ids: a per-archive stage's trials) of the open
    ``archive`` at ``path``; errors come back as values."""
    try:
        if isinstance(tid, tuple):
            problems = _trial_problems([archive.trial(t) for t in tid], check_trials)
            if problems:
                return TrialFailure(str(path), "*", problems[0].message, problems[0].path,
                                    problems)
            return stage.run_archive(archive, list(tid))
        trial = archive.trial(tid)
        problems = _trial_problems([trial], check_trials)
        if problems:
            return TrialFailure(str(path), tid, problems[0].message, problems[0].path, problems)
        return stage.run_trial(trial)         # the arrays checked are cached on ``trial``
    except DataError as err:
        if isinstance(tid, tuple):
            return TrialFailure(str(path), "*", err.message, err.field or "")
        where = f"/trials/{tid}"
        if err.field and err.field.startswith(where):
            where = err.field
        elif err.field:
            where = f"{where}: {err.field}"
        return TrialFailure(str(path), tid, err.message, where)
    except (ArithmeticError, ValueError, IndexError, KeyError, TypeError, RuntimeError,
            OSError) as err:
        return TrialFailure(str(path), "*" if isinstance(tid, tuple) else tid,
                            f"failed: {type(err).__name__}: {err}")


def _trial_problems(trials: list, check_trials: bool) -> list:
    if not check_trials:
        return []
    from contactlab.archive.validate import trial_problems

    return [p for trial in trials for p in trial_problems(trial)]


def _map(stage: Stage, tasks: list[tuple[Path, str]], *, workers: int,
         scheduler: str | None, quiet: bool, check_trials: bool = True) -> dict:
    """Run every task; ``{(path, tid): outcome or TrialFailure}``.

    In parallel, tasks go out in chunks of consecutive trials of one archive
    (about four per worker), each chunk opening its archive once.
    """
    if scheduler is None and (workers == 1 or len(tasks) < 2):
        chunks = [tasks]
    else:
        n = max(1, -(-len(tasks) // (4 * (workers if scheduler is None else 8))))
        chunks = []
        for path in dict.fromkeys(p for p, _ in tasks):
            mine = [task for task in tasks if task[0] == path]
            chunks += [mine[i:i + n] for i in range(0, len(mine), n)]
    if len(chunks) == 1:
        return dict(zip(tasks, _run_chunk(stage, tasks, check_trials, quiet=quiet)))
    got = parallel_map(_run_chunk, [(stage, chunk, check_trials) for chunk in chunks],
                       workers=workers,
                       scheduler=scheduler, quiet=quiet, desc=stage.name or "stage")
    done: dict = {}
    for chunk, outcomes in zip(chunks, got):
        for (p, t), r in zip(chunk, outcomes if isinstance(outcomes, list) else
                             [outcomes] * len(chunk)):
            done[(p, t)] = r if not isinstance(r, Exception) else TrialFailure(
                str(p), "*" if isinstance(t, tuple) else t,
                f"failed in a worker: {type(r).__name__}: {r}")
    return done


def _run_chunk(stage: Stage, tasks: list[tuple[Path, str]], check_trials: bool = True, *,
               quiet: bool = True) -> list:
    """Run ``tasks`` in order, each archive opened once; outcomes or TrialFailures."""
    from contactlab.archive import open_archive
    from contactlab.progress import bar

    done: dict = {}
    progress = bar(total=len(tasks), desc=stage.name or "stage", quiet=quiet, unit="trial")
    try:
        for path in dict.fromkeys(p for p, _ in tasks):
            with open_archive(path) as archive:
                for p, t in tasks:
                    if p == path:
                        done[(p, t)] = _run_one(stage, p, t, archive, check_trials)
                        progress.update(1)
    finally:
        progress.close()
    return [done[task] for task in tasks]


def parallel_map(fn, calls: list[tuple], *, workers: int = 1, scheduler: str | None = None,
                 quiet: bool = True, desc: str = "") -> list:
    """``[fn(*args) for args in calls]`` in a pool of ``workers`` local processes or on
    the Dask cluster at ``scheduler``, in order. ``fn`` and its arguments must pickle.

    An exception raised by one call (or a worker lost under it) is returned in
    that call's place, so the others still finish; an interrupt stops them all.
    """
    from contactlab.progress import bar

    check_workers(workers, scheduler)
    out: list = [None] * len(calls)
    progress = bar(total=len(calls), desc=desc, quiet=quiet, unit="task")
    try:
        if scheduler is not None:
            from distributed import Client, as_completed

            _check_scheduler(scheduler)
            try:
                client = Client(scheduler, set_as_default=False, timeout="20s")
            except (OSError, TimeoutError, ValueError) as err:
                reason = str(err).splitlines()[0] if str(err) else type(err).__name__
                raise DataError(f"cannot reach the Dask scheduler at {scheduler!r} ({reason})",
                                field="--scheduler") from None
            with client:
                futures = {client.submit(fn, *args, pure=False): i
                           for i, args in enumerate(calls)}
                for fut in as_completed(list(futures), loop=client.loop):
                    out[futures[fut]] = _result(fut)
                    progress.update(1)
        elif workers > 1 and len(calls) > 1:
            import multiprocessing
            from concurrent.futures import ProcessPoolExecutor, as_completed

            ctx = multiprocessing.get_context("fork")  # workers inherit loaded kernels
            with ProcessPoolExecutor(max_workers=min(workers, len(calls)),
                                     mp_context=ctx) as pool:
                futures = {pool.submit(fn, *args): i for i, args in enumerate(calls)}
                try:
                    for fut in as_completed(futures):
                        out[futures[fut]] = _result(fut)
                        progress.update(1)
                except BaseException:
                    pool.shutdown(wait=False, cancel_futures=True)
                    raise
        else:
            for i, args in enumerate(calls):
                try:
                    out[i] = fn(*args)
                except Exception as err:  # noqa: BLE001 - returned like a worker's
                    out[i] = err
                progress.update(1)
    finally:
        progress.close()
    return out


def _check_scheduler(address: str) -> None:
    """A one-line error for an address no Dask transport can reach (before a Client
    is made: a half-made one hangs on its way out)."""
    from distributed.comm import parse_address
    from distributed.comm.registry import backends

    try:
        scheme, rest = parse_address(address)
    except ValueError as err:
        raise DataError(f"not a Dask scheduler address {address!r} ({err})",
                        field="--scheduler") from None
    if scheme not in backends or not rest:
        raise DataError(f"not a Dask scheduler address {address!r} (transports: "
                        f"{', '.join(sorted(backends))})", field="--scheduler")


def _result(future):
    """A future's value, or the exception its call raised (a lost worker, ...)."""
    try:
        return future.result()
    except Exception as err:  # noqa: BLE001 - reported by the caller, per call
        return err
