"""How long a Dask worker running ``segment`` holds the GIL at a stretch.

A worker's event loop (heartbeats to the scheduler, data transfers) needs the GIL; a
task that keeps it for seconds makes distributed log "Event loop was unresponsive in
Worker". Measured with a side thread in the worker that sleeps 10 ms at a time and
records the longest gap between its wake-ups beyond the 10 ms: the longest stretch
another thread kept the GIL (plus any wait for a core on a loaded machine).

Rows: ``segment`` (the defaults: strain, the AR GLR) over an archive of 2 trials of
``SECONDS`` s of 8 AR(2) strains at 1000 Hz (noise level stepping every 2.5 s) on a
``LocalCluster`` of one single-threaded worker process, warmed on a short archive;
the peer is distributed's limit for that warning (``distributed.admin.tick.limit``).
Then the 7.1 lowpass of one such trial alone in this process: the longest hold
against the call's own duration (the compiled filter releases the GIL while it runs).
"""

from __future__ import annotations

import os
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
from scipy.signal import lfilter

SECONDS = 600.0
FS = 1000.0
CHANNELS = 8

_beat: dict = {}


def _write(path: Path, seconds: float, trials: int = 2) -> Path:
    from contactlab.archive import create_archive

    rng = np.random.default_rng(7)
    m = int(seconds * FS)
    t = np.arange(m) / FS
    level = 1.0 + 3.0 * ((t // 2.5) % 2)
    with create_archive(path, force=True) as archive:
        for k in range(trials):
            e = rng.standard_normal((m, CHANNELS)) * level[:, None]
            y = lfilter([1.0], [1.0, -1.2, 0.5], e, axis=0)
            trial = archive.add_trial(f"t{k}", rate_hz=FS, source="simulator")
            for rows in np.array_split(np.arange(m), max(1, m // 60000)):
                trial.append(time=t[rows], strain=y[rows])
            trial.close()
    return path


def _beat_start() -> None:
    """Start the heartbeat thread (in whichever process runs this)."""
    _beat.update(running=True, longest=0.0, frame="")

    def loop():
        me = threading.get_ident()
        last = time.perf_counter()
        while _beat["running"]:
            time.sleep(0.01)
            now = time.perf_counter()
            if now - last - 0.01 > _beat["longest"]:
                _beat["longest"] = now - last - 0.01
                _beat["frame"] = _where(me)
            last = now

    threading.Thread(target=loop, daemon=True, name="gil-heartbeat").start()


def _where(me: int) -> str:
    """The innermost contactlab frame of another thread (where a hold just ended)."""
    import sys
    import traceback

    for tid, frame in sys._current_frames().items():
        if tid == me:
            continue
        mine = [f"{Path(f.filename).name}:{f.lineno} {f.name}"
                for f in traceback.extract_stack(frame) if "contactlab" in f.filename]
        if mine:
            return mine[-1]
    return ""


def _beat_stop() -> tuple[float, str]:
    _beat["running"] = False
    return _beat["longest"], _beat["frame"]


def _beat_reset() -> None:
    _beat.update(longest=0.0, frame="")


def _on_worker(seconds: float) -> tuple[float, float, str]:
    """Wall time of ``segment`` on a 1-worker cluster, its longest GIL hold and where."""
    import logging

    from distributed import Client, LocalCluster

    from contactlab.segmentation import run_archive

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        warm, big = _write(tmp / "warm.h5", 5.0), _write(tmp / "long.h5", seconds)
        with LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                          dashboard_address=None, silence_logs=logging.ERROR) as cluster, \
                Client(cluster) as client:
            address = cluster.scheduler_address
            client.run(_beat_start)
            run_archive(warm, scheduler=address)          # the worker loads the kernels
            client.run(_beat_reset)
            t0 = time.perf_counter()
            run_archive(big, scheduler=address)
            wall = time.perf_counter() - t0
            (hold, frame), = client.run(_beat_stop).values()
    return wall, hold, frame


def _lowpass_alone(seconds: float) -> tuple[float, float]:
    """Duration of the 7.1 lowpass of one trial and the longest GIL hold during it."""
    from contactlab.conditioning import lowpass_decimate

    y = np.random.default_rng(1).standard_normal((int(seconds * FS), CHANNELS))
    lowpass_decimate(y[:1000])
    _beat_start()
    time.sleep(0.05)
    _beat_reset()
    t0 = time.perf_counter()
    lowpass_decimate(y)
    took = time.perf_counter() - t0
    time.sleep(0.03)
    hold, _ = _beat_stop()
    return took, hold


def run() -> list[dict]:
    import dask
    import distributed  # noqa: F401 - its configuration
    from dask.utils import parse_timedelta

    limit = parse_timedelta(dask.config.get("distributed.admin.tick.limit"))
    wall, hold, frame = _on_worker(SECONDS)
    took, lp_hold = _lowpass_alone(SECONDS)
    load = os.getloadavg()[0]
    return [
        {"name": f"segment 2 x {SECONDS:.0f} s trials on a Dask worker: longest GIL hold",
         "ours_s": hold, "peer": "distributed's unresponsive-loop limit", "peer_s": limit,
         "ratio": limit / hold,
         "notes": f"the stage {wall:.2f} s wall; the longest hold ended at {frame or '-'}; "
                  f"includes waits for a core (load average {load:.1f})"},
        {"name": f"7.1 lowpass of one {SECONDS:.0f} s 8-strain trial: longest GIL hold",
         "ours_s": lp_hold, "peer": "the call's duration", "peer_s": took,
         "ratio": took / max(lp_hold, 1e-6),
         "notes": "the compiled filter runs without the GIL (nogil): the side thread "
                  "keeps waking every 10 ms while it runs"},
    ]
