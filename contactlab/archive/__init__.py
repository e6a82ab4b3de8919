"""HDF5 trace archives: the format (``datasets_spec/ARCHIVE.md``), writer, reader,
validator, results store and CSV import.

- :mod:`.spec`      the schema, ``archive.schema.json``, as Python data
- :mod:`.writer`    :func:`create_archive` -> :class:`ArchiveWriter` -> :class:`TrialWriter`
- :mod:`.reader`    :func:`open_archive` -> :class:`Archive` -> :class:`Trial`
- :mod:`.validate`  :func:`validate_archive` -> list of :class:`Problem`
- :mod:`.results`   :func:`write_stage` (one stage, many trials, atomic) and :func:`write_results`
- :mod:`.summary`   :func:`summarize` (``contactlab info``)
- :mod:`.importer`  :func:`import_csv` (``contactlab import``)
"""

from contactlab.archive.reader import Archive, Results, Trial, open_archive
from contactlab.archive.results import TrialResults, write_results, write_stage
from contactlab.archive.summary import summarize
from contactlab.archive.validate import Problem, validate_archive
from contactlab.archive.writer import ArchiveWriter, TrialWriter, create_archive

__all__ = [
    "Archive", "ArchiveWriter", "Problem", "Results", "Trial", "TrialWriter", "create_archive",
    "import_csv", "open_archive", "parse_column_map", "summarize", "validate_archive",
    "TrialResults", "write_results", "write_stage",
]


def __getattr__(name: str):
    # the CSV importer needs pandas (0.3 s to import): loaded when first asked for
    if name in ("import_csv", "parse_column_map"):
        from contactlab.archive import importer

        return getattr(importer, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
