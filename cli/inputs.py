"""Up-front input checks shared by the commands that read archives.

:func:`checks_archive` runs :func:`contactlab.archive.validate.check_archive`
(the checks behind ``contactlab validate``, with its words) on the archive a
command reads, limited to the trials it selects, before any work starts; it
also removes temporary files that a killed run left beside the archive.
"""

from __future__ import annotations

import functools

from contactlab.archive.validate import check_archive
from contactlab.fileio import remove_stale_temp_files


def check_inputs(archives, trials=None) -> None:
    """Check each archive (the trials ``trials`` of it, or all): a DataError naming
    the file and the first offending field, or None when everything conforms."""
    for path in archives:
        remove_stale_temp_files(path)
        check_archive(path, trials=list(trials) if trials else None)


def checks_archive(command):
    """Decorate a command callback taking ``archive`` (or ``archives``) and optionally
    ``trials`` so that those are checked before the command runs."""

    @functools.wraps(command)
    def wrapper(*args, **kwargs):
        archives = kwargs.get("archives")
        if archives is None:
            archives = [kwargs["archive"]] if kwargs.get("archive") is not None else []
        check_inputs(archives, kwargs.get("trials"))
        return command(*args, **kwargs)

    return wrapper
