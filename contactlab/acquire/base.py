"""The interface every acquisition source implements.

A source yields trials; each trial yields chunks of rows that go straight to
:meth:`contactlab.archive.TrialWriter.append` as they arrive, so an interrupted
acquisition keeps every finished trial (the writer runs in incremental mode).

    class MySource:
        name = "mysource"
        def trials(self, *, n_trials, seed): ...   # -> Iterator[TrialStream]
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np


@dataclass
class TrialInfo:
    """What :meth:`ArchiveWriter.add_trial` needs to open a trial."""

    trial_id: str
    rate_hz: float
    controller: str = ""
    environment: str = ""
    seed: int = -1
    source: str = ""
    description: str = ""
    calibration: np.ndarray | None = None   # (6, c): wrench = calibration @ strain
    strain_units: str | None = None
    command_columns: list[str] | None = None
    command_units: str | None = None
    action_names: list[str] | None = None
    attrs: dict = field(default_factory=dict)  # extra trial attributes (e.g. dropped_packets)


class TrialStream(Protocol):
    """One trial being recorded."""

    info: TrialInfo

    def chunks(self) -> Iterator[dict[str, np.ndarray]]:
        """Rows as they arrive: dicts of TrialWriter.append keyword arrays."""

    def ground_truth(self) -> dict | None:
        """After the chunks are exhausted: ``set_ground_truth`` keywords plus any
        extra per-sample truth datasets, or None (hardware has no truth)."""

    def final_attrs(self) -> dict:
        """After the chunks are exhausted: attributes known only at the end
        (e.g. dropped packet counts)."""


class Source(Protocol):
    """A producer of trials: the simulator, a Net F/T sensor, a PHANToM."""

    name: str

    def trials(self, *, n_trials: int, seed: int) -> Iterator[TrialStream]:
        """Yield ``n_trials`` trials; ``seed`` makes simulated ones reproducible."""
