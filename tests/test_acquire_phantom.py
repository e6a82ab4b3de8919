"""The PHANToM source against fake HD libraries: a Python object and a small C library."""

from __future__ import annotations

import ctypes
import ctypes.util
import shutil
import subprocess

import numpy as np
import pytest

from contactlab.acquire import phantom
from contactlab.acquire.phantom import (HD_CALLBACK_DONE, HD_CURRENT_POSITION,
                                        HD_CURRENT_VELOCITY, HD_FORCE_OUTPUT, MISSING,
                                        PhantomSource)
from contactlab.errors import ContactlabError, DataError, UsageError

HANDLE = 7
RATE = 1000.0


class ErrorInfo:
    def __init__(self, code=0):
        self.errorCode = code
        self.internalErrorCode = 0
        self.hHD = HANDLE


class FakeHD:
    """The HD API functions the source uses; logs every call.

    The k-th position read (k = 1, 2, ...) is (k, -k, 0.5 k) mm and the k-th
    velocity read (10 k, 0, -k) mm/s. ``fail`` maps a function name to the HD
    error code hdGetError reports after it.
    """

    def __init__(self, fail=None):
        self.calls = []
        self.fail = dict(fail or {})
        self.reads = {HD_CURRENT_POSITION: 0, HD_CURRENT_VELOCITY: 0}
        self.pending = 0
        self.callback_codes = []

    def _log(self, name, *args):
        self.calls.append((name, *args))
        if name in self.fail:
            self.pending = self.fail[name]

    def hdInitDevice(self, name):
        self._log("hdInitDevice", name)
        return HANDLE

    def hdEnable(self, cap):
        self._log("hdEnable", cap)

    def hdStartScheduler(self):
        self._log("hdStartScheduler")

    def hdStopScheduler(self):
        self._log("hdStopScheduler")

    def hdDisableDevice(self, handle):
        self._log("hdDisableDevice", handle)

    def hdScheduleSynchronous(self, callback, data, priority):
        self._log("hdScheduleSynchronous", priority)
        self.callback_codes.append(callback(data))

    def hdBeginFrame(self, handle):
        self._log("hdBeginFrame", handle)

    def hdEndFrame(self, handle):
        self._log("hdEndFrame", handle)

    def hdGetDoublev(self, pname, out):
        self._log("hdGetDoublev", pname)
        self.reads[pname] += 1
        k = self.reads[pname]
        values = (k, -k, 0.5 * k) if pname == HD_CURRENT_POSITION else (10 * k, 0, -k)
        for i, v in enumerate(values):
            out[i] = v

    def hdGetError(self):
        self.calls.append(("hdGetError",))
        code, self.pending = self.pending, 0
        return ErrorInfo(code)

    def hdGetErrorString(self, code):
        return b"Communication error"

    def names(self):
        return [c[0] for c in self.calls]


def record(source):
    (trial,) = source.trials(n_trials=1, seed=5)
    chunks = list(trial.chunks())
    data = {k: np.concatenate([c[k] for c in chunks]) for k in chunks[0]}
    return trial, chunks, data


@pytest.fixture
def no_libhd(monkeypatch):
    monkeypatch.delenv(phantom.ENV_VAR, raising=False)
    monkeypatch.setattr(ctypes.util, "find_library", lambda name: None)


def test_missing_library_is_one_line(no_libhd):
    with pytest.raises(ContactlabError) as err:
        PhantomSource(duration_s=1.0)
    assert str(err.value) == MISSING
    assert str(err.value) == ("OpenHaptics HD library (libHD.so) not found: install the "
                              "OpenHaptics SDK or set CONTACTLAB_LIBHD")


def test_unloadable_library_names_the_path(monkeypatch, tmp_path):
    monkeypatch.setenv(phantom.ENV_VAR, str(tmp_path / "libHD.so"))
    with pytest.raises(ContactlabError) as err:
        PhantomSource(duration_s=1.0)
    message = str(err.value)
    assert message.startswith(f"OpenHaptics HD library (libHD.so) could not be loaded from "
                              f"{tmp_path / 'libHD.so'}: ")
    assert "\n" not in message


def test_a_library_without_the_hd_api_is_refused(monkeypatch):
    libc = ctypes.util.find_library("c")
    if libc is None:
        pytest.skip("no libc found by ctypes")
    monkeypatch.setenv(phantom.ENV_VAR, libc)
    with pytest.raises(ContactlabError, match="is not the OpenHaptics HD library: it has no "
                                              "hdInitDevice"):
        PhantomSource(duration_s=1.0)


def test_polling_gives_metres_on_a_uniform_time_base():
    hd = FakeHD()
    trial, chunks, data = record(PhantomSource(duration_s=0.25, rate_hz=RATE, library=hd))
    n = len(data["time"])
    missed = trial.final_attrs()["missed_samples"]
    assert n + missed == 250 and n > 0
    slots = data["time"] * RATE
    np.testing.assert_allclose(slots, np.round(slots), atol=1e-9)
    assert np.all(np.diff(data["time"]) > 0) and data["time"][0] == 0.0
    k = np.arange(1, n + 1)
    np.testing.assert_allclose(data["position"], np.column_stack([k, -k, 0.5 * k]) * 1e-3)
    np.testing.assert_allclose(data["velocity"], np.column_stack([10 * k, 0 * k, -k]) * 1e-3)
    assert set(chunks[0]) == {"time", "position", "velocity"}
    assert all(len(c["time"]) <= 100 for c in chunks) and len(chunks) >= 2
    assert hd.callback_codes == [HD_CALLBACK_DONE] * n
    assert trial.ground_truth() is None
    assert trial.info.rate_hz == RATE and trial.info.source == "phantom"
    assert trial.info.trial_id == "phantom01" and trial.info.seed == 5


def test_calls_come_in_the_documented_order():
    hd = FakeHD()
    trial, _, data = record(PhantomSource(duration_s=0.003, rate_hz=RATE, library=hd))
    n = len(data["time"])
    assert hd.calls[:6] == [("hdInitDevice", None), ("hdGetError",),
                            ("hdEnable", HD_FORCE_OUTPUT), ("hdGetError",),
                            ("hdStartScheduler",), ("hdGetError",)]
    per_sample = [("hdScheduleSynchronous", 0x7FFF), ("hdBeginFrame", HANDLE),
                  ("hdGetDoublev", HD_CURRENT_POSITION), ("hdGetDoublev", HD_CURRENT_VELOCITY),
                  ("hdEndFrame", HANDLE), ("hdGetError",)]
    assert hd.calls[6:-2] == per_sample * n
    assert hd.calls[-2:] == [("hdStopScheduler",), ("hdDisableDevice", HANDLE)]


def test_init_failure_is_one_line_and_opens_nothing():
    hd = FakeHD(fail={"hdInitDevice": 0x0302})
    (trial,) = PhantomSource(duration_s=0.01, library=hd).trials(n_trials=1, seed=0)
    with pytest.raises(DataError) as err:
        list(trial.chunks())
    assert str(err.value) == "phantom: hdInitDevice failed: Communication error (0x0302)"
    assert "hdStartScheduler" not in hd.names()


def test_error_in_the_servo_read_stops_the_scheduler_and_disables_the_device():
    hd = FakeHD(fail={"hdEndFrame": 0x0302})
    (trial,) = PhantomSource(duration_s=0.01, library=hd).trials(n_trials=1, seed=0)
    with pytest.raises(DataError, match="reading the device state failed: Communication error"):
        list(trial.chunks())
    assert hd.names()[-2:] == ["hdStopScheduler", "hdDisableDevice"]


@pytest.mark.parametrize("how", ["close", "interrupt"])
def test_device_is_released_when_the_consumer_stops_or_is_interrupted(how):
    hd = FakeHD()
    (trial,) = PhantomSource(duration_s=1.0, library=hd).trials(n_trials=1, seed=0)
    chunks = trial.chunks()
    next(chunks)
    if how == "close":
        chunks.close()
    else:
        with pytest.raises(KeyboardInterrupt):
            chunks.throw(KeyboardInterrupt)
    assert hd.names()[-2:] == ["hdStopScheduler", "hdDisableDevice"]


def test_bad_parameters_are_usage_errors():
    with pytest.raises(UsageError, match="duration_s"):
        PhantomSource(duration_s=0, library=FakeHD())
    with pytest.raises(UsageError, match="rate_hz"):
        PhantomSource(duration_s=1, rate_hz=float("nan"), library=FakeHD())


FAKE_LIBHD_C = r"""
/* A stand-in for libHD.so with the OpenHaptics ABI (hdDefines.h, hdDevice.h, hdScheduler.h). */
#include <stdio.h>
#include <string.h>
typedef unsigned int HHD;
typedef unsigned int HDenum;
typedef unsigned int HDerror;
typedef unsigned int HDCallbackCode;
typedef unsigned short HDushort;
typedef struct { HDerror errorCode; int internalErrorCode; HHD hHD; } HDErrorInfo;
typedef HDCallbackCode (*HDSchedulerCallback)(void *);

static char log_[65536];
static int reads = 0;
static void note(const char *s) {
    if (strlen(log_) + strlen(s) + 2 < sizeof log_) { strcat(log_, s); strcat(log_, " "); }
}
const char *fake_log(void) { return log_; }

HHD hdInitDevice(const char *name) { note(name ? "init:named" : "init:default"); return 42; }
void hdDisableDevice(HHD h) { note(h == 42 ? "disable:42" : "disable:?"); }
void hdEnable(HDenum cap) { note(cap == 0x4000 ? "enable:force" : "enable:?"); }
void hdStartScheduler(void) { note("start"); }
void hdStopScheduler(void) { note("stop"); }
void hdBeginFrame(HHD h) { (void)h; }
void hdEndFrame(HHD h) { (void)h; }
void hdGetDoublev(HDenum p, double *v) {
    if (p == 0x2050) { ++reads; v[0] = reads; v[1] = 2.0 * reads; v[2] = -1.0; }
    else if (p == 0x2051) { v[0] = 0.0; v[1] = 0.0; v[2] = 1000.0; }
}
HDErrorInfo hdGetError(void) { HDErrorInfo e = {0, 0, 42}; return e; }
const char *hdGetErrorString(HDerror code) { (void)code; return "no error"; }
void hdScheduleSynchronous(HDSchedulerCallback cb, void *data, HDushort priority) {
    char s[32];
    snprintf(s, sizeof s, "sync:%u", (unsigned)priority);
    if (reads == 0) note(s);
    if (cb(data) != 0) note("callback:continue");
}
"""


@pytest.fixture
def fake_libhd(tmp_path, monkeypatch):
    compiler = shutil.which("cc") or shutil.which("gcc")
    if compiler is None:
        pytest.skip("no C compiler to build the fake libHD")
    src, lib = tmp_path / "fake_hd.c", tmp_path / "libHD.so"
    src.write_text(FAKE_LIBHD_C)
    subprocess.run([compiler, "-shared", "-fPIC", "-O1", "-o", str(lib), str(src)], check=True)
    monkeypatch.setenv(phantom.ENV_VAR, str(lib))
    return lib


def test_ctypes_bindings_against_a_c_library(fake_libhd):
    source = PhantomSource(duration_s=0.02, rate_hz=RATE)
    assert isinstance(source.hd, ctypes.CDLL)
    trial, _, data = record(source)
    n = len(data["time"])
    assert n + trial.final_attrs()["missed_samples"] == 20
    k = np.arange(1, n + 1)
    np.testing.assert_allclose(data["position"], np.column_stack([k, 2 * k, -np.ones(n)]) / 1000)
    np.testing.assert_allclose(data["velocity"], np.tile([0.0, 0.0, 1.0], (n, 1)))
    log = source.hd.fake_log
    log.restype = ctypes.c_char_p
    assert log().decode().split() == ["init:default", "enable:force", "start", "sync:32767",
                                      "stop", "disable:42"]
