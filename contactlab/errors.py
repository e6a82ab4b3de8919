"""Exceptions that the CLI turns into one-line messages.

A :class:`DataError` names the file and the field (an HDF5 path, a CSV column,
an option) so that the message alone tells the user what to fix.
"""

from __future__ import annotations


class ContactlabError(Exception):
    """Base class of every error contactlab reports to users."""

    exit_code = 1


class DataError(ContactlabError):
    """Input data that does not conform: exit status 1.

    Parameters
    ----------
    file : path of the offending file (or None when there is none)
    field : the field inside it: HDF5 path, column name, option name
    message : what is wrong, in a few words
    """

    exit_code = 1

    def __init__(self, message: str, *, file: str | None = None, field: str | None = None):
        self.file = None if file is None else str(file)
        self.field = field
        self.message = message
        super().__init__(self.one_line())

    def one_line(self) -> str:
        parts = [p for p in (self.file, self.field) if p]
        return ": ".join(parts + [self.message])


class UsageError(ContactlabError):
    """A request that cannot be carried out as asked: exit status 2."""

    exit_code = 2
