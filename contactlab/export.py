"""Recognition results as CSV tables for a user's own tools (``recognize --csv``).

Two tables, one file each, written atomically and never over an existing file unless
``force``:

- the samples, ``OUT.csv``: one row per sample the observer saw, columns ``trial``,
  ``time_s``, ``node`` (the node of the final MAP path at that sample), ``node_prob``
  (that node's on-line probability there) and ``p_<node>`` for every node of the graph
  (each node's on-line probability, summing to 1 per row);
- the phase boundaries, ``OUT-boundaries.csv`` (:func:`boundaries_path`): one row per
  change of the final MAP path's node, columns ``trial``, ``time_s`` (the first sample
  of the new node), ``from``, ``to``.

With several archives, an ``archive`` column comes first in both.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from contactlab.fileio import atomic_path, check_writable


def boundaries_path(path: str | os.PathLike) -> Path:
    """``recognised.csv`` -> ``recognised-boundaries.csv``: where the boundaries go."""
    path = Path(path)
    return path.with_name(f"{path.stem}-boundaries{path.suffix or '.csv'}")


def check_csv_targets(path: str | os.PathLike, *, force: bool, inputs=()) -> None:
    """Refuse (DataError naming the file) before any work when either table's file
    exists without ``force``, or cannot be written."""
    for target in (Path(path), boundaries_path(path)):
        check_writable(target, force=force, inputs=inputs)


def sample_table(trial_id: str, times, labels, node_prob, node_names: Sequence[str]
                 ) -> pd.DataFrame:
    """One trial's per-sample rows: the final MAP path's node and the on-line node
    probabilities (see the module notes)."""
    labels = np.asarray(labels, dtype=np.int64)
    prob = np.asarray(node_prob, dtype=np.float64)
    names = np.asarray(list(node_names), dtype=object)
    table = pd.DataFrame({"trial": trial_id, "time_s": np.asarray(times, dtype=np.float64),
                          "node": names[labels],
                          "node_prob": prob[np.arange(len(labels)), labels]})
    for k, name in enumerate(node_names):
        table[f"p_{name}"] = prob[:, k]
    return table


def boundary_table(trial_id: str, times, labels, node_names: Sequence[str]) -> pd.DataFrame:
    """One trial's changes of the final MAP path's node: ``trial, time_s, from, to``."""
    labels = np.asarray(labels, dtype=np.int64)
    at = np.flatnonzero(labels[1:] != labels[:-1]) + 1
    names = np.asarray(list(node_names), dtype=object)
    return pd.DataFrame({"trial": trial_id,
                         "time_s": np.asarray(times, dtype=np.float64)[at],
                         "from": names[labels[at - 1]], "to": names[labels[at]]})


def write_tables(path: str | os.PathLike, samples: pd.DataFrame, boundaries: pd.DataFrame,
                 *, force: bool = False) -> tuple[Path, Path]:
    """Write both tables (each atomically); return their paths."""
    out = []
    for target, table in ((Path(path), samples), (boundaries_path(path), boundaries)):
        with atomic_path(target, force=force) as tmp:
            table.to_csv(tmp, index=False, float_format="%.9g")
        out.append(target)
    return out[0], out[1]


def export_recognition(runs_by_archive: dict, node_names: Sequence[str],
                       path: str | os.PathLike, *, force: bool = False) -> tuple[Path, Path]:
    """Write the samples and boundaries of recognised trials: ``runs_by_archive`` maps
    each archive to its :class:`~contactlab.observer.recognize.TrialRecognition`
    objects.  Returns the two files' paths."""
    samples, bounds = [], []
    several = len(runs_by_archive) > 1
    for archive, runs in runs_by_archive.items():
        for rec in runs:
            res = rec.result
            s = sample_table(rec.trial_id, rec.times, res.labels, res.node_prob, node_names)
            b = boundary_table(rec.trial_id, rec.times, res.labels, node_names)
            if several:
                s.insert(0, "archive", str(archive))
                b.insert(0, "archive", str(archive))
            samples.append(s)
            bounds.append(b)
    empty = pd.DataFrame(columns=["trial", "time_s"])
    return write_tables(path, pd.concat(samples, ignore_index=True) if samples else empty,
                        pd.concat(bounds, ignore_index=True) if bounds else empty, force=force)
