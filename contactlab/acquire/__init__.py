"""Acquisition: sources of trials and the loop that records them into an archive.

- :mod:`.base`    the :class:`Source` / :class:`TrialStream` interface
- :mod:`.spec`    dataset specs (``datasets_spec/*.toml``) -> :class:`DatasetSpec`
- :mod:`.sim`     :class:`SimSource`: simulated trials of a spec, label functions
- :mod:`.record`  :func:`record`: source -> archive, incremental, SIGTERM-safe
- :mod:`.netft`, :mod:`.phantom`  hardware sources (imported on demand)

Used by ``contactlab acquire``.
"""

from contactlab.acquire.base import Source, TrialInfo, TrialStream
from contactlab.acquire.record import record
from contactlab.acquire.sim import LABEL_FUNCTIONS, SimSource, simulate_trial, trial_seed
from contactlab.acquire.spec import DatasetSpec, Group, list_specs, load_all, load_spec

__all__ = ["DatasetSpec", "Group", "LABEL_FUNCTIONS", "SimSource", "Source", "TrialInfo",
           "TrialStream", "list_specs", "load_all", "load_spec", "record", "simulate_trial",
           "trial_seed"]
