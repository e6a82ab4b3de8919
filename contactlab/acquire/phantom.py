"""The PHANToM's position through the OpenHaptics HD API (ctypes on libHD.so).

The HD API runs a servo loop (1 kHz by default) in its own thread; the
documented way to read device state from another thread is a synchronous
scheduler callback (``hdScheduleSynchronous``), which runs once in the servo
thread and returns. This module polls that way at ``rate_hz``: sample k is
read at the first servo tick after ``k / rate_hz`` and is placed at that time.
A sample slot whose moment has already passed by more than one period (the
process was descheduled) is skipped and counted (``missed_samples``), so the
time base stays uniform and the rows that exist are where they belong.
Positions and velocities come in mm and mm/s in the device frame (x right,
y up, z toward the user) and are stored in m and m/s in that frame.

The library is found through ``CONTACTLAB_LIBHD`` (a path) or
``ctypes.util.find_library("HD")``. Names, signatures and constant values
are those of OpenHaptics' ``HD/hdDefines.h``, ``HD/hdDevice.h`` and
``HD/hdScheduler.h`` (OpenHaptics 3.x; the values are unchanged since 1.0).
This module is tested here against fakes with that interface (a Python object
and a small C library built by the test suite), never against a device.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import math
import os
import time as _time
from collections.abc import Iterator
from datetime import datetime, timezone

import numpy as np

from contactlab.acquire.base import TrialInfo
from contactlab.errors import ContactlabError, DataError, UsageError

ENV_VAR = "CONTACTLAB_LIBHD"
MISSING = ("OpenHaptics HD library (libHD.so) not found: install the OpenHaptics SDK "
           f"or set {ENV_VAR}")

# hdDefines.h
HD_SUCCESS = 0x0000
HD_CURRENT_POSITION = 0x2050     # 3 HDdouble, mm
HD_CURRENT_VELOCITY = 0x2051     # 3 HDdouble, mm/s
HD_FORCE_OUTPUT = 0x4000
HD_INVALID_HANDLE = 0xFFFFFFFF
HD_DEFAULT_DEVICE = None         # NULL: the default device of the configuration
HD_DEFAULT_SCHEDULER_PRIORITY = (0xFFFF + 0) // 2   # (USHRT_MAX + 0) / 2
# hdScheduler.h
HD_CALLBACK_DONE = 0
HD_CALLBACK_CONTINUE = 1

MM = 1e-3
#: Samples per chunk handed to the archive writer (0.1 s at 1 kHz).
CHUNK_SAMPLES = 100


class HDErrorInfo(ctypes.Structure):
    """``HDErrorInfo`` of hdDefines.h (returned by value from hdGetError)."""

    _fields_ = [("errorCode", ctypes.c_uint),         # HDerror
                ("internalErrorCode", ctypes.c_int),
                ("hHD", ctypes.c_uint)]                # HHD


#: ``HDCallbackCode (HDCALLBACK *)(void *pUserData)``; HDCALLBACK is empty on Linux.
HDSchedulerCallback = ctypes.CFUNCTYPE(ctypes.c_uint, ctypes.c_void_p)

_PROTOTYPES = {
    "hdInitDevice": (ctypes.c_uint, [ctypes.c_char_p]),
    "hdDisableDevice": (None, [ctypes.c_uint]),
    "hdEnable": (None, [ctypes.c_uint]),
    "hdStartScheduler": (None, []),
    "hdStopScheduler": (None, []),
    "hdScheduleSynchronous": (None, [HDSchedulerCallback, ctypes.c_void_p, ctypes.c_ushort]),
    "hdBeginFrame": (None, [ctypes.c_uint]),
    "hdEndFrame": (None, [ctypes.c_uint]),
    "hdGetDoublev": (None, [ctypes.c_uint, ctypes.POINTER(ctypes.c_double)]),
    "hdGetError": (HDErrorInfo, []),
    "hdGetErrorString": (ctypes.c_char_p, [ctypes.c_uint]),
}


def load_library(library=None):
    """The HD API: ``library`` itself when given, else libHD loaded with ctypes.

    ``library`` may be any object with the HD function names (tests pass a
    fake). Raises a one-line :class:`ContactlabError` when libHD is missing.
    """
    if library is not None:
        return library
    path = os.environ.get(ENV_VAR) or ctypes.util.find_library("HD")
    if not path:
        raise ContactlabError(MISSING)
    try:
        lib = ctypes.CDLL(path)
    except OSError as err:
        reason = str(err).splitlines()[0] if str(err) else type(err).__name__
        raise ContactlabError(f"OpenHaptics HD library (libHD.so) could not be loaded from "
                              f"{path}: {reason}") from None
    for name, (restype, argtypes) in _PROTOTYPES.items():
        try:
            fn = getattr(lib, name)
        except AttributeError:
            raise ContactlabError(f"{path} is not the OpenHaptics HD library: it has no "
                                  f"{name}") from None
        fn.restype, fn.argtypes = restype, argtypes
    return lib


class PhantomSource:
    """Trials of PHANToM position and velocity read through OpenHaptics.

    Parameters
    ----------
    duration_s : length of each trial, s
    rate_hz : polling rate, Hz (at most the servo rate, 1000 Hz by default;
        faster polling repeats servo ticks)
    library : an object with the HD API's functions instead of libHD (tests)
    trial_prefix : trial ids are ``<prefix>01``, ``<prefix>02``, ...
    """

    name = "phantom"

    def __init__(self, *, duration_s: float, rate_hz: float = 1000.0, library=None,
                 trial_prefix: str = "phantom"):
        for pname, value in (("duration_s", duration_s), ("rate_hz", rate_hz)):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise UsageError(f"{pname} must be a positive number, not {value!r}")
        self.duration_s = float(duration_s)
        self.rate_hz = float(rate_hz)
        self.trial_prefix = trial_prefix
        self.hd = load_library(library)

    def trials(self, *, n_trials: int, seed: int) -> Iterator[PhantomTrial]:
        """``n_trials`` recordings, one after the other (``seed`` is only stored)."""
        for i in range(n_trials):
            yield PhantomTrial(self, f"{self.trial_prefix}{i + 1:02d}", seed=seed)


class PhantomTrial:
    """One recording: iterate :meth:`chunks`, then read :meth:`final_attrs`."""

    def __init__(self, source: PhantomSource, trial_id: str, *, seed: int = -1):
        self.source = source
        self.hd = source.hd
        self.info = TrialInfo(
            trial_id=trial_id, rate_hz=source.rate_hz, seed=seed, source="phantom",
            description="PHANToM position and velocity through the OpenHaptics HD API",
            attrs={"frame": "OpenHaptics device frame: x right, y up, z toward the user"})
        self._missed = 0
        self._started_utc = ""

    def ground_truth(self) -> None:
        """Hardware has no ground truth."""
        return None

    def final_attrs(self) -> dict:
        return {"missed_samples": self._missed, "started_utc": self._started_utc}

    def chunks(self) -> Iterator[dict[str, np.ndarray]]:
        """Open the device, yield ``{"time", "position", "velocity"}`` chunks, close it.

        The scheduler is stopped and the device disabled however the loop
        ends (normally, on an error, on KeyboardInterrupt or generator close).
        """
        hd = self.hd
        handle = hd.hdInitDevice(HD_DEFAULT_DEVICE)
        self._check("hdInitDevice")
        if handle == HD_INVALID_HANDLE:
            raise DataError("hdInitDevice returned an invalid handle", field="phantom")
        scheduler = False
        try:
            hd.hdEnable(HD_FORCE_OUTPUT)
            self._check("hdEnable")
            hd.hdStartScheduler()
            scheduler = True
            self._check("hdStartScheduler")
            self._started_utc = datetime.now(timezone.utc).isoformat(timespec="milliseconds")
            yield from self._poll(handle)
        finally:
            if scheduler:
                hd.hdStopScheduler()
            hd.hdDisableDevice(handle)

    # -- internals -------------------------------------------------------------

    def _error_text(self, code: int) -> str:
        text = self.hd.hdGetErrorString(code)
        if isinstance(text, bytes):
            text = text.decode("utf-8", "replace")
        return f"{text or 'HD error'} (0x{code:04x})"

    def _check(self, call: str) -> None:
        info = self.hd.hdGetError()
        if info.errorCode != HD_SUCCESS:
            raise DataError(f"{call} failed: {self._error_text(info.errorCode)}",
                            field="phantom")

    def _poll(self, handle: int) -> Iterator[dict[str, np.ndarray]]:
        hd = self.hd
        rate = self.source.rate_hz
        n_target = max(1, round(self.source.duration_s * rate))
        position = (ctypes.c_double * 3)()
        velocity = (ctypes.c_double * 3)()
        failure = [HD_SUCCESS]

        def read_state(_user_data):
            # Runs in the servo thread: no Python exceptions may escape.
            try:
                hd.hdBeginFrame(handle)
                hd.hdGetDoublev(HD_CURRENT_POSITION, position)
                hd.hdGetDoublev(HD_CURRENT_VELOCITY, velocity)
                hd.hdEndFrame(handle)
                failure[0] = hd.hdGetError().errorCode
            except BaseException:            # noqa: BLE001 -- reported below
                failure[0] = -1
            return HD_CALLBACK_DONE

        callback = HDSchedulerCallback(read_state)   # kept alive for the whole trial
        times, rows_p, rows_v = [], [], []
        start = _time.monotonic()
        slot = 0
        while slot < n_target:
            wait = start + slot / rate - _time.monotonic()
            if wait > 0:
                _time.sleep(wait)
            elif -wait > 1.0 / rate:             # fell behind: skip the slots already past
                behind = int(-wait * rate)
                if slot + behind >= n_target:
                    self._missed += n_target - slot
                    break
                self._missed += behind
                slot += behind
            hd.hdScheduleSynchronous(callback, None, HD_DEFAULT_SCHEDULER_PRIORITY)
            if failure[0] != HD_SUCCESS:
                what = ("the read callback raised" if failure[0] == -1
                        else self._error_text(failure[0]))
                raise DataError(f"reading the device state failed: {what}", field="phantom")
            times.append(slot / rate)
            rows_p.append(tuple(position))
            rows_v.append(tuple(velocity))
            slot += 1
            if len(times) >= CHUNK_SAMPLES:
                yield self._chunk(times, rows_p, rows_v)
                times, rows_p, rows_v = [], [], []
        if times:
            yield self._chunk(times, rows_p, rows_v)

    @staticmethod
    def _chunk(times, rows_p, rows_v) -> dict[str, np.ndarray]:
        return {"time": np.asarray(times, dtype=np.float64),
                "position": np.asarray(rows_p, dtype=np.float64).reshape(-1, 3) * MM,
                "velocity": np.asarray(rows_v, dtype=np.float64).reshape(-1, 3) * MM}
