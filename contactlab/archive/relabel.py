"""A copy of an archive whose ground truth keeps only some classes.

:func:`restrict_labels` copies an archive and recodes its per-sample labels
and truth segments to the classes ``keep`` (new codes = positions in
``keep``; every other sample unlabelled, -1).  The measurements are copied
untouched; the source archive is only read.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import h5py
import numpy as np

from contactlab.archive import spec as archive_spec
from contactlab.archive.writer import create_dataset, label_segments
from contactlab.fileio import atomic_path

__all__ = ["restrict_labels"]


def restrict_labels(src, dst, *, keep: list[str]) -> Path:
    """Copy archive ``src`` to ``dst`` with ground-truth labels and segments reduced to
    the classes ``keep`` (written atomically); ValueError when a trial lacks one of them."""
    dst = Path(dst)
    with atomic_path(dst, force=True) as tmp:      # a crash leaves no half-relabelled copy
        shutil.copyfile(src, tmp)
        _restrict(tmp, keep, src)
    return dst


def _restrict(path, keep: list[str], src) -> None:
    with h5py.File(path, "r+") as h5:
        for tid, trial in h5["trials"].items():
            gt = trial[archive_spec.GROUND_TRUTH]
            old = [str(n.decode() if isinstance(n, bytes) else n)
                   for n in gt["labels"].attrs["names"]]
            missing = [k for k in keep if k not in old]
            if missing:
                raise ValueError(f"{src}: trial {tid}: no class {missing} in {old}")
            table = np.full(len(old) + 1, -1, np.int16)      # old code -1 -> index -1 -> -1
            for new, name in enumerate(keep):
                table[old.index(name)] = new
            codes = table[np.asarray(gt["labels"][...], int)]
            time = np.asarray(trial[archive_spec.MEASUREMENTS]["time"][...], float)
            rate = float(trial.attrs["rate_hz"])
            rows = label_segments(codes, time, rate)
            names = archive_spec.string_array(keep)
            for key, data in (("labels", codes), ("segments", rows)):
                if key in gt:
                    del gt[key]
                create_dataset(gt, key, data).attrs["names"] = names
