"""Synthetic trials -> HDF5 trace archives the CLI reads like recordings.

Every trial kind of :mod:`contactlab.synthetic` knows its measurements and
its truth (:meth:`archive_fields`): time, strains and/or wrench and position,
per-sample label codes with their names and a segment table.  The archive's
``source`` attribute is ``synthetic`` and each trial carries its seed.
"""

from __future__ import annotations

import numpy as np

from contactlab.archive import create_archive
from contactlab.archive.writer import label_segments

__all__ = ["write_archive"]


def write_archive(trials, path, *, force: bool = False, title: str = "",
                  prefix: str = "syn") -> list[str]:
    """Write ``trials`` (objects with ``archive_fields()``) to ``path``; returns trial ids.

    ``archive_fields()`` returns ``dict(rate_hz, time, measurements: {name: array},
    labels, names, environment, description)`` (``labels``/``names`` optional).
    """
    ids = []
    with create_archive(path, force=force, title=title or "synthetic benchmark") as out:
        for i, trial in enumerate(trials):
            f = trial.archive_fields()
            tid = f"{prefix}-{i:03d}"
            meas = f["measurements"]
            strain = meas.get("strain")
            tw = out.add_trial(tid, rate_hz=float(f["rate_hz"]), source="synthetic",
                               seed=int(getattr(trial, "seed", -1)),
                               environment=f.get("environment", ""),
                               description=f.get("description", ""),
                               strain_channels=None if strain is None else strain.shape[1])
            tw.append(time=f["time"], **meas)
            if f.get("labels") is not None:
                tw.set_ground_truth(labels=np.asarray(f["labels"], np.int64), names=f["names"],
                                    segments=label_segments(f["labels"], f["time"], f["rate_hz"]))
            if f.get("truth"):
                tw.set_truth(**f["truth"])
            if f.get("attrs"):
                tw.set_attrs(f["attrs"])
            tw.close()
            ids.append(tid)
    return ids
