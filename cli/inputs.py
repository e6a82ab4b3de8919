"""Up-front input checks shared by the commands that read archives.

:func:`checks_archive` runs :func:`contactlab.archive.validate.check_archive`
(the checks behind ``contactlab validate``, with its words) on the archive a
command reads, limited to the trials it selects, before any work starts; it
also removes temporary files that a killed run left beside the archive.

Commands that run a :class:`contactlab.stages.Stage` and read nothing else
first (segment, estimate) check up front the archive outside its trials and
that the trials asked for exist (``values=False, walk_trials=False``), and
leave each trial's checks to the stage, which runs them where the trial runs
(:func:`contactlab.stages.run_stage`): the checks are shared among the
workers and the measurements are decompressed once.  ``recognize`` reads its
models and graph first: it checks the whole layout up front (``values=False``),
so a malformed archive is named before the models are read, and each trial's
values where the trial runs, so an hour's measurements are read once, not twice;
``train --graph`` checks each trial's values where it reads the trial.  ``label``
and the other commands check everything up front.
"""

from __future__ import annotations

import functools

from contactlab.archive.validate import check_archive
from contactlab.fileio import refuse_while_recorded, remove_stale_temp_files


def check_inputs(archives, trials=None, *, values: bool = True,
                 walk_trials: bool = True) -> None:
    """Check each archive (the trials ``trials`` of it, or all): a DataError naming
    the file and the first offending field, or None when everything conforms.
    ``values=False``: the layout only; ``walk_trials=False``: not the trials'
    contents either (see the module notes)."""
    for path in archives:
        refuse_while_recorded(path)
        remove_stale_temp_files(path)
        check_archive(path, trials=list(trials) if trials else None, values=values,
                      walk_trials=walk_trials)


def checks_archive(command=None, *, values: bool = True, walk_trials: bool = True):
    """Decorate a command callback taking ``archive`` (or ``archives``) and optionally
    ``trials`` so that those are checked before the command runs (``values`` and
    ``walk_trials`` as for :func:`check_inputs`; ``@checks_archive`` or
    ``@checks_archive(values=False, walk_trials=False)``)."""
    if command is None:
        return functools.partial(checks_archive, values=values, walk_trials=walk_trials)

    @functools.wraps(command)
    def wrapper(*args, **kwargs):
        archives = kwargs.get("archives")
        if archives is None:
            archives = [kwargs["archive"]] if kwargs.get("archive") is not None else []
        check_inputs(archives, kwargs.get("trials"), values=values, walk_trials=walk_trials)
        return command(*args, **kwargs)

    return wrapper
