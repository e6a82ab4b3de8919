"""Simulator speed: one 7-second trial of each typical dataset, x-real-time factor.

The target is a 7-second trial at least 20x faster than real time on one
core (``contactlab.sim.simulate``, 1000 Hz output, the integrator's own internal
rate), plus the full ``contactlab acquire`` path (simulation + ground truth +
writing the HDF5 trial) for the stroking spec. No peer: there is no other
simulator of this apparatus to compare with.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from contactlab.acquire.record import record
from contactlab.acquire.sim import SimSource, simulate_trial
from contactlab.acquire.spec import load_spec
from benchmarks.timing import best_time

DURATION_S = 7.0




def run() -> list[dict]:
    rows = []
    for name in ("stroke-a", "guarded-move", "guarded-move-multi"):
        spec = load_spec(name)
        simulate_trial(spec, 0, 1, duration_s=0.2)  # compile / load the numba kernel
        k = spec.n_trials - 1  # last group: the integral force controller for the multi move
        ours = best_time(lambda: simulate_trial(spec, k, 1, duration_s=DURATION_S))
        rows.append({"name": f"simulate 7 s trial ({name})", "ours_s": ours, "peer": None,
                     "peer_s": None, "ratio": None,
                     "notes": f"{DURATION_S / ours:.0f}x real time (target >= 20x)"})
    spec = load_spec("stroke-a")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "b.h5"

        def acquire():
            record(SimSource(spec), out=out, n_trials=1, seed=1, force=True, quiet=True,
                   log=lambda m: None)

        ours = best_time(acquire)
    rows.append({"name": "acquire 7 s stroke-a trial to HDF5", "ours_s": ours, "peer": None,
                 "peer_s": None, "ratio": None,
                 "notes": f"{DURATION_S / ours:.0f}x real time incl. truth + gzip HDF5"})
    return rows
