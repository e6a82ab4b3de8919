"""A dataset spec's simulated trials recorded straight into an archive.

:func:`record_spec` is exactly ``contactlab acquire --spec NAME --seed SEED``
as a function: the experiments, benchmarks and tests use it to make the
archives they analyse.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["record_spec"]


def record_spec(name: str, path, *, seed: int, n_trials: int | None = None,
                title: str | None = None, spec=None) -> Path:
    """Simulate the trials of dataset spec ``name`` (or of ``spec``, a
    :class:`~contactlab.acquire.spec.DatasetSpec` made from it) into a new archive
    ``path`` (overwritten if present) and return its path."""
    from contactlab.acquire.record import record
    from contactlab.acquire.sim import SimSource
    from contactlab.acquire.spec import load_spec

    spec = load_spec(name) if spec is None else spec
    record(SimSource(spec), out=path, n_trials=n_trials or spec.n_trials, seed=seed,
           force=True, title=title or name, quiet=True, log=lambda m: None)
    return Path(path)
