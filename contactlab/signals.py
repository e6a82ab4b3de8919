"""Trial -> conditioned signals, and ground truth on the conditioned time base (7.1).

This module is the one place where a recorded trial (an archive
:class:`~contactlab.archive.reader.Trial`, or anything with the same
attributes: ``rate_hz``, ``time``, ``strain``, ``wrench``, ``position``,
``velocity``, ``labels``, ``label_names``) becomes the signals the stages and
experiments analyse.  It owns the conditioning constants of 7.1:

* the ``4:1`` decimation of 1000 Hz to 250 Hz (:data:`FACTOR`) and the
  lowpass cutoff at ``fs / 8`` (:data:`CUTOFF_DIVISOR`; 125 Hz, the output's
  Nyquist rate), the filter itself being
  :func:`contactlab.conditioning.lowpass_decimate`.  A recording at another
  rate is decimated to the rate nearest 250 Hz it can reach by an integer
  factor (:func:`factor_for`: 500 Hz by 2, 250 Hz and below not at all), with
  the cutoff at the output's Nyquist rate (:func:`cutoff_for`; none when the
  factor is 1).  The thesis conditions 1000 Hz data only; keeping its 4:1 at
  every rate would leave a 250 Hz wrist-sensor recording at 62.5 Hz,
  lowpassed at 31 Hz, and hide most of its contact events;
* the log floor of ``y_h``: half the strain converter step
  (:func:`contactlab.conditioning.quantisation_floor`), so exact zeros of the
  difference of quantised strains enter as ``log(lsb / 2)``, not ``log(1e-12)``;
* the input window each conditioned sample depends on (:func:`window_of`), used
  to give a conditioned sample a truth label only when its whole window has it.

Signals (:data:`SIGNALS`): ``strain`` (``y_l``: strains lowpassed and
decimated), ``wrench`` (the wrench through the same filter and decimation),
``hf`` (``y_h``: block-averaged ``log|y_d|`` of the strains), and
:data:`STREAMS` adds ``position`` and ``velocity`` (through the same filter
and decimation).  The constraint models read ``contact`` (position then force,
both lowpassed; the force in the position's base axes when the trial carries its
orientation, :func:`trial_signals`) or ``contact-compensated``, whose force has the friction along the
velocity removed as 8.29 does before every constraint estimate of chapter 8
(:func:`compensate_friction`).  Every conditioned sample carries the index of the newest
input sample it uses (``index``) and that sample's time (``times``).

A trial recorded with a wrist sensor often has no strain gauges: the default
signal (:func:`default_signal`) is ``strain`` when the trial has strains and
``wrench`` otherwise, and asking for a signal the trial lacks raises a
one-line :class:`~contactlab.errors.DataError` that names the signal it has.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from contactlab.conditioning import difference, log_energy, lowpass_decimate, quantisation_floor
from contactlab.errors import DataError, UsageError

__all__ = ["SIGNALS", "STREAMS", "FACTOR", "CUTOFF_DIVISOR", "TARGET_RATE_HZ",
           "factor_for", "cutoff_for", "hf_block_for", "window_of", "Signal",
           "source_of", "default_signal", "resolve_signal", "lowpass", "condition", "condition_array",
           "conditioned_signal", "trial_signals", "derived_velocity", "codes_at", "truth_codes",
           "relabel", "REDUCE", "loudest_channel", "CONTACT_SIGNALS", "COMPENSATED",
           "compensate_friction", "velocity_noise_level", "phase_stream", "PHASE",
           "PHASE_CUTOFF_HZ", "phase_cutoff", "phase_filter", "phase_sample_weight", "sample_weight",
           "HF_SAMPLE_WEIGHT"]

#: conditioned signals of a trial's force sensor (7.1)
SIGNALS = ("strain", "wrench", "hf")
#: every stream :func:`trial_signals` gives: the conditioned signals and the kinematics
STREAMS = SIGNALS + ("velocity", "position")
#: the constraint models' streams: position then force, both through the 7.1 lowpass;
#: ``contact-compensated`` has the friction along the velocity removed from the force
#: (8.29, :func:`compensate_friction`)
COMPENSATED = "contact-compensated"
CONTACT_SIGNALS = ("contact", COMPENSATED)
#: decimation factor of 7.1 at the thesis's 1000 Hz (1000 Hz -> 250 Hz)
FACTOR = 4
#: the conditioned rate 7.1 decimates to (1000 Hz / 4)
TARGET_RATE_HZ = 250.0
#: the lowpass cutoff is ``fs / CUTOFF_DIVISOR`` at 1000 Hz (7.1: 125 Hz, second order)
CUTOFF_DIVISOR = 2.0 * FACTOR
#: differences averaged into one y_h sample (7.1: blocks of 8, every 4th sample)
HF_BLOCK = 2 * FACTOR
#: the task-phase stream (:func:`phase_stream`: lowpassed wrench and velocity) and its cutoff
PHASE = "phase"
PHASE_CUTOFF_HZ = 5.0
#: the phase stream's wrench offset between recordings, standard deviation per force axis
#: (N) and per torque axis (N m): a wrist sensor not zeroed again between recordings, a
#: grasp that holds the tool or the object a little differently.  A phase model trained on
#: one recording knows its force levels to the noise within it; the same phase in another
#: recording sits ~1-2 N away (Baxter's carried object: 1.5-2 N per axis between its two
#: recordings; HIRO's later trials: their payload turned with the tool).  Chosen on the
#: held-out splits of bench_real_phases (HIRO S-02..08 / alternate, Baxter s03->s07 /
#: s07->s03; none 0.945 / 0.998 / 0.882 / 0.853; 0.5 N, 0.05 N m 0.971 / 0.998 / 0.946 /
#: 0.901; 1 N, 0.1 N m 0.969 / 0.998 / 0.947 / 0.945; 2 N, 0.2 N m 0.967 / 0.987 / 0.947 /
#: 0.946): the one setting at or above the supervised HMM and the random forest (within
#: 0.001) on every split.  A wrist-sensor scale: on the synthetic hand-held tool's light
#: touches (bench_free_contact's recordings) a learned graph went 0.983 -> 0.971 of points
#: at 100 Hz, 0.978 -> 0.976 at 500 Hz; a graph's Gaussian model sets its own
#: (``wrench_offset_sd = [N, N m]``) for an apparatus whose forces are far smaller.
PHASE_OFFSET_SD = (1.0, 0.1)
#: channel reductions of :func:`trial_signals`
REDUCE = ("mean", "none")


def factor_for(fs: float) -> int:
    """The integer decimation that brings ``fs`` nearest :data:`TARGET_RATE_HZ` from
    above or at it: 4 at 1000 Hz (7.1), 2 at 500 Hz, 1 at 250 Hz and below."""
    fs = float(fs)
    if not fs > 0:
        raise ValueError(f"rate must be > 0 Hz; got {fs!r}")
    return max(1, int(fs // TARGET_RATE_HZ))


def cutoff_for(fs: float) -> float | None:
    """The lowpass cutoff (Hz) before :func:`factor_for`'s decimation: the output's
    Nyquist rate (``fs / 8`` at 1000 Hz, 7.1), or None when nothing is decimated."""
    factor = factor_for(fs)
    return None if factor == 1 else float(fs) / (2.0 * factor)


def hf_block_for(fs: float) -> int:
    """Differences averaged into one y_h sample: two decimation steps (8 at 1000 Hz, 7.1)."""
    return 2 * factor_for(fs)


def window_of(signal: str, fs: float) -> int:
    """Input samples a conditioned sample of ``signal`` depends on at input rate ``fs``:
    the decimation step for the lowpassed signals; for y_h[k] the ``2 f`` differences
    ``y(n) - y(n-1)``, ``n = f k + 1 .. f k + 2 f`` (7.1 at f = 4), i.e. ``2 f + 1``
    inputs; raw kinematics sampled at the newest input depend on one."""
    if signal in ("velocity", "position", PHASE):
        return 1
    if signal == "hf":
        return hf_block_for(fs) + 1
    return factor_for(fs)


@dataclass(frozen=True, eq=False)
class Signal:
    """One trial's conditioned signal.

    name : the signal (one of :data:`STREAMS`).  y : (N, C).  index : (N,) newest
    input sample of each conditioned sample.  times : (N,) its time (s) in the
    trial's time base.  fs : conditioned rate (Hz).  trial_id : the trial.
    """

    name: str
    y: np.ndarray
    index: np.ndarray
    times: np.ndarray
    fs: float
    trial_id: str = ""


def source_of(signal: str) -> str:
    """The measurement a signal is computed from: ``strain`` for strain and hf."""
    return "strain" if signal in ("strain", "hf") else signal


def default_signal(trial) -> str:
    """``strain`` when the trial has strain gauges, else ``wrench``."""
    return "strain" if getattr(trial, "strain", None) is not None else "wrench"


def _field(trial, name: str) -> str:
    return f"/trials/{getattr(trial, 'id', '?')}/measurements/{name}"


def resolve_signal(trial, signal: str | None, *, path=None, known=SIGNALS) -> str:
    """``signal``, or the trial's default when None; DataError (naming the signal the
    trial has) when the trial lacks the measurement it needs."""
    if signal is None:
        signal = default_signal(trial)
    if signal not in known:
        raise UsageError(f"signal must be one of {', '.join(known)}; got {signal!r}")
    source = source_of(signal)
    if getattr(trial, source, None) is None:
        has = [s for s in ("strain", "wrench") if getattr(trial, s, None) is not None]
        hint = f"; it has {has[0]}: use --signal {has[0]}" if has else ""
        raise DataError(f"trial has no {source} (needed for --signal {signal}){hint}",
                        file=str(path) if path else None, field=_field(trial, source))
    return signal


def lowpass(x, *, fs: float) -> np.ndarray:
    """``x`` (N, ...) through the 7.1 lowpass (second-order Butterworth at
    :func:`cutoff_for`, ``fs / 8`` at 1000 Hz) and :func:`factor_for`'s decimation
    (4:1 at 1000 Hz); output k is at input sample ``factor * k``.  At 250 Hz and
    below nothing is filtered or dropped (a copy of ``x``)."""
    x = np.asarray(x, dtype=np.float64)
    cutoff = cutoff_for(fs)
    if cutoff is None:
        return x.copy()
    return lowpass_decimate(x, fs=float(fs), cutoff_hz=cutoff, factor=factor_for(fs))


def _raw(trial, name: str, path) -> np.ndarray:
    raw = getattr(trial, name, None)
    if raw is None:
        raise DataError(f"trial has no {name}", file=str(path) if path else None,
                        field=_field(trial, name))
    return np.asarray(raw, dtype=np.float64)


def condition(trial, signal: str | None = None, *, path=None, source: str | None = None
              ) -> Signal:
    """The 7.1-conditioned ``signal`` of ``trial`` (default :func:`default_signal`).

    ``strain``: ``y_l`` (:func:`~contactlab.conditioning.condition_strains`'s
    ``low``); ``wrench``, ``position``, ``velocity``: the measurement through
    :func:`lowpass`; ``hf``: ``y_h`` with the log floor at half the converter
    step of its source (the strains; ``source="wrench"`` takes the log energy of
    the wrench instead).  DataError naming the field when the trial lacks it or
    has no samples.
    """
    if source is None:
        signal = resolve_signal(trial, signal, path=path, known=STREAMS)
        source = source_of(signal)
    elif signal != "hf":
        raise UsageError("source= applies to the hf signal only")
    raw = _raw(trial, source, path)
    time = np.asarray(trial.time, dtype=np.float64)
    if len(time) == 0:
        raise DataError("trial has no samples", file=str(path) if path else None,
                        field=_field(trial, "time"))
    sig = condition_array(raw, signal, fs=float(trial.rate_hz))
    index = np.minimum(sig.index, len(time) - 1)
    return Signal(signal, sig.y, index, time[index], sig.fs, str(getattr(trial, "id", "")))


def condition_array(raw, signal: str, *, fs: float) -> Signal:
    """The conditioning of :func:`condition` on a bare array ``raw`` (N,) or (N, C)
    sampled at ``fs``: ``signal`` ``"strain"`` or ``"hf"`` treat it as strains (y_l,
    y_h with the log floor at half its converter step), any other name lowpasses and
    decimates it.  ``times`` count from 0 at input sample 0."""
    raw = np.asarray(raw, dtype=np.float64)
    fs = float(fs)
    factor = factor_for(fs)
    if signal == "hf":          # y_h only: the lowpass branch of 7.1 is not needed
        block = hf_block_for(fs)
        y = log_energy(difference(raw), block=block, factor=factor,
                       floor=quantisation_floor(raw))
        index = factor * np.arange(len(y)) + block
    else:                       # y_l of the strains, or any other channel, alike
        y = lowpass(raw, fs=fs)
        index = factor * np.arange(len(y))
    index = np.asarray(index, dtype=np.int64)
    y = np.asarray(y, dtype=np.float64)
    y = y[:, None] if y.ndim == 1 else y
    return Signal(signal, y, index, index / fs, fs / factor)


def conditioned_signal(trial, signal: str | None = None) -> tuple[np.ndarray, np.ndarray, float]:
    """``(y, times, fs_out)`` of :func:`condition` (the form the segmenter takes)."""
    s = condition(trial, signal)
    return s.y, s.times, s.fs


def trial_signals(trial, signals, *, reduce: str = "none", path=None, payload=None
                  ) -> tuple[dict[str, np.ndarray], np.ndarray, float]:
    """The observer's measurement streams of a trial on one conditioned time base.

    Returns ``({signal: (n, C)}, index (n,), fs)``: ``hf``/``strain``/``wrench``
    from :func:`condition`, ``velocity``/``position`` the raw channels at the
    conditioned samples' newest input sample (``index``; every
    :func:`factor_for`-th sample from the factor's last when no conditioned signal is
    asked for).  ``reduce="mean"`` replaces a
    conditioned signal's channels by their mean.  All streams are cut to the
    shortest.  ``payload``: a :class:`~contactlab.payload.Payload` whose correction the
    contact signals' base-frame force subtracts (a trial with its orientation only).
    """
    if reduce not in REDUCE:
        raise ValueError(f"reduce must be one of {REDUCE}; got {reduce!r}")
    _check_sources(trial, signals, path)
    out: dict[str, np.ndarray] = {}
    indices: list[np.ndarray] = []
    contact = None              # (y, index) of the contact signals: computed once
    for s in signals:
        if s in ("velocity", "position", PHASE):
            continue
        if s in CONTACT_SIGNALS:    # position then force, both through the 7.1 lowpass
            if contact is None:
                w = condition(trial, "wrench", path=path)
                p = condition(trial, "position", path=path)
                contact = (np.concatenate([p.y[:, :3], _base_force(trial, w, path, payload)],
                                          axis=1),
                           w.index)
            out[s] = contact[0]
            indices.append(contact[1])
            continue
        if s not in SIGNALS:
            raise DataError(f"unknown signal {s!r} (known: {', '.join(STREAMS)})",
                            file=str(path) if path else None, field=_field(trial, "")[:-1])
        c = condition(trial, s, path=path)
        y = c.y
        if reduce == "mean" and y.shape[1] > 1:
            y = y.mean(axis=1, keepdims=True)
        out[s] = y
        indices.append(c.index)
    n_in = len(trial.time)
    if indices:
        n = min(len(v) for v in indices)
        index = indices[0][:n]
    else:
        factor = factor_for(trial.rate_hz)
        index = np.arange(factor - 1, n_in, factor)
        n = len(index)
    for s in signals:
        if s == "velocity":
            out[s] = _velocity_at(trial, index, path)
        elif s == "position":
            out[s] = _raw(trial, s, path)[index]
        elif s == PHASE:
            out[s] = phase_stream(trial, path)[np.asarray(index)]
    if COMPENSATED in out:
        c = out[COMPENSATED][:n].copy()
        v = out["velocity"] if "velocity" in out else _velocity_at(trial, index, path)
        c[:, 3:6] = compensate_friction(c[:, 3:6], v[:n, :3])
        out[COMPENSATED] = c
    out = {k: np.ascontiguousarray(v[:n]) for k, v in out.items()}
    fs = float(trial.rate_hz) / factor_for(trial.rate_hz)
    return out, index[:n], fs


def _base_force(trial, wrench: Signal, path, payload=None) -> np.ndarray:
    """The conditioned force of ``wrench`` (the trial's conditioned wrench) in the
    position's (base) axes.

    The constraint form (8.10-8.11) pairs a motion and a force in one frame; the
    position is the end effector's in the base frame, and a wrist sensor measures
    in its own.  A trial that carries its orientation and a wrench as measured
    (``wrench_frame == "sensor"``) has its raw force rotated into the base frame
    before the 7.1 lowpass (the lowpass is linear: this is the conditioned
    base-frame force); without an orientation the force is taken as it is (a tool
    that does not turn, or a wrench already in the base frame).  ``payload``
    (:class:`~contactlab.payload.Payload`, a trial with its orientation): its
    correction is subtracted from the base-frame force, before the lowpass."""
    q = _sensor_orientation(trial)
    if q is None and payload is None:
        return wrench.y[:, :3]
    from contactlab.archive.importer import rotate_vectors

    raw = _raw(trial, "wrench", path)[:, :3]
    if q is None:                       # a base-frame wrench, with its orientation
        q = np.asarray(trial.orientation, dtype=np.float64)[: len(raw)]
        f = raw[: len(q)]
    else:
        q = q[: len(raw)]
        f = rotate_vectors(q, raw[: len(q)])
    if payload is not None:
        f = f - payload.correction(q)
    return condition_array(f, "wrench", fs=float(trial.rate_hz)).y[: len(wrench.y)]


def _sensor_orientation(trial) -> np.ndarray | None:
    """The tool's orientation (n, 4) when ``trial`` carries it and its wrench is as
    measured (in the sensor's axes): what turns the force into the base frame; else None."""
    q = getattr(trial, "orientation", None)
    if q is None or getattr(trial, "wrench_frame", "sensor") != "sensor":
        return None
    return np.asarray(q, dtype=np.float64)


def _base_wrench(trial, raw: np.ndarray) -> np.ndarray:
    """The raw wrench (n, 6) in the base frame's axes where :func:`_sensor_orientation`
    gives an orientation (force and torque each rotated,
    :func:`~contactlab.archive.importer.rotate_wrench`); else as it is."""
    q = _sensor_orientation(trial)
    if q is None:
        return raw
    from contactlab.archive.importer import rotate_wrench

    n = min(len(raw), len(q))
    return rotate_wrench(q[:n], raw[:n])


def _check_sources(trial, signals, path) -> None:
    """DataError naming the measurement a stream of :func:`trial_signals` needs and the
    trial lacks (the streams are what a feature graph's models read, so the hint names a
    graph, not ``--signal``)."""
    for s in signals:
        if s in CONTACT_SIGNALS:
            needs = ("wrench", "position")
        elif s == PHASE:
            needs = ("wrench",)
        elif s == "velocity":
            needs = ("velocity",) if getattr(trial, "position", None) is None else ()
        else:
            needs = (source_of(s),)
        for src in needs:
            if getattr(trial, src, None) is not None:
                continue
            hint = ""
            if src == "strain" and getattr(trial, "wrench", None) is not None:
                hint = ("; it has a wrench: a graph whose models read the wrench and position "
                        "(the bundled free-contact) recognises it")
            raise DataError(f"trial has no {src} (a model reads the {s!r} signal, computed "
                            f"from it){hint}", file=str(path) if path else None,
                            field=_field(trial, src))


def _velocity_at(trial, index, path) -> np.ndarray:
    """The ``velocity`` stream at the conditioned samples ``index``: the recorded
    velocity, or :func:`derived_velocity` for a trial recorded without one."""
    if getattr(trial, "velocity", None) is None and getattr(trial, "position", None) is not None:
        v = derived_velocity(trial)
        return v[np.minimum(index // factor_for(trial.rate_hz), len(v) - 1)]
    return _raw(trial, "velocity", path)[index]


def phase_cutoff(fs: float) -> float:
    """The task-phase lowpass's cutoff (Hz) at rate ``fs``: :data:`PHASE_CUTOFF_HZ`, at
    most 0.4 times the rate."""
    return min(PHASE_CUTOFF_HZ, 0.4 * float(fs))


def phase_filter(fs: float) -> tuple[np.ndarray, np.ndarray]:
    """``(b, a)`` of the task-phase lowpass at rate ``fs``: second-order Butterworth at
    :func:`phase_cutoff`."""
    from scipy.signal import butter

    return butter(2, phase_cutoff(fs) / (float(fs) / 2.0))


#: the weight of one y_h sample (:func:`sample_weight`): y_h[k] averages the ``2 f``
#: differences ``n = f k + 1 .. f k + 2 f`` (7.1), so neighbouring samples share half
#: their differences at every rate; for independent differences the averages' integrated
#: autocorrelation time is ``1 + 2 * 1/2 = 2``
HF_SAMPLE_WEIGHT = 0.5


def phase_sample_weight(fs: float) -> float:
    """The share of an independent sample that one sample of the task-phase stream at
    rate ``fs`` carries: ``sum h^2 / (sum h)^2`` over the lowpass's impulse response
    ``h``, the inverse of the integrated autocorrelation time ``tau = sum_k rho(k)`` of
    white noise through it: the mean of ``n`` filtered samples has the variance of the
    mean of ``n w`` independent ones (Priestley 1981, 5.3).  A per-sample model of the
    stream counts each sample's log-likelihood with this weight, so that a phase's
    evidence grows with its duration, not with the recording's rate (0.11 at 100 Hz,
    0.055 at 200 Hz).  It follows from the filter alone; nothing is fitted."""
    from scipy.signal import lfilter

    b, a = phase_filter(fs)
    # the impulse response until it has decayed (poles inside the unit circle: geometric
    # decay; 40 periods of the cutoff leave less than 1e-12 of its peak)
    n = int(np.ceil(40.0 * float(fs) / phase_cutoff(fs))) + 16
    imp = np.zeros(n)
    imp[0] = 1.0
    h = lfilter(b, a, imp)
    return float(np.sum(h * h) / np.sum(h) ** 2)


def sample_weight(signal: str, fs: float | None) -> float:
    """The weight of one sample of ``signal`` at rate ``fs`` in a per-sample model's
    log-likelihood (the share of an independent sample it carries):
    :func:`phase_sample_weight` for the lowpassed task-phase stream,
    :data:`HF_SAMPLE_WEIGHT` for y_h, 1 for every other stream (or an unknown rate)."""
    if signal == PHASE and fs:
        return phase_sample_weight(fs)
    if signal == "hf":
        return HF_SAMPLE_WEIGHT
    return 1.0


def phase_stream(trial, path=None) -> np.ndarray:
    """The task-phase stream at the input rate: the wrench (in the base frame's axes when the
    trial carries the tool's orientation and a wrench as measured, as the contact signals'
    force is: a phase's load and push keep their direction in the world while the tool
    turns) and the velocity (recorded, else
    the position's first difference times the rate; none without either) through a causal
    second-order Butterworth lowpass at :data:`PHASE_CUTOFF_HZ` (at most 0.4 times the
    rate), started at rest on the first sample -- (N, 9), or (N, 6) with no kinematics.
    Task phases differ in force level, velocity direction and load over seconds; the
    lowpass keeps that and drops the sensor noise and the impacts' ringing."""
    from scipy.signal import lfilter, lfilter_zi

    fs = float(trial.rate_hz)
    parts = [_base_wrench(trial, _raw(trial, "wrench", path))]
    if getattr(trial, "velocity", None) is not None:
        parts.append(_raw(trial, "velocity", path)[:, :3])
    elif getattr(trial, "position", None) is not None:
        p = _raw(trial, "position", path)[:, :3]
        parts.append(np.diff(p, axis=0, prepend=p[:1]) * fs)
    x = np.concatenate(parts, axis=1)
    if len(x) == 0:
        return x
    b, a = phase_filter(fs)
    zi = lfilter_zi(b, a)[:, None] * x[:1]
    return np.ascontiguousarray(lfilter(b, a, x, axis=0, zi=zi)[0])


def phase_offset_sd(channels: int, wrench_sd=None) -> np.ndarray:
    """Per channel of a phase stream of ``channels`` (9: wrench then velocity; 6: the
    wrench alone), the standard deviation of its offset between recordings: ``wrench_sd``
    (force N, torque N m; default :data:`PHASE_OFFSET_SD`) on the wrench, 0 on the
    velocity."""
    if channels not in (6, 9):
        raise ValueError(f"a phase stream has 6 or 9 channels; got {channels}")
    out = np.zeros(channels)
    out[:3], out[3:6] = PHASE_OFFSET_SD if wrench_sd is None else wrench_sd
    return out


def velocity_noise_level(velocity) -> float:
    """The white-noise level of a velocity stream (n, 3): the median over the axes of
    :func:`contactlab.constraints.noise.raw_noise_sd` (0 with fewer than 5 samples)."""
    from contactlab.constraints.noise import raw_noise_sd

    v = np.asarray(velocity, dtype=np.float64)
    sd = raw_noise_sd(v) if len(v) >= 5 else np.full(v.shape[1], np.nan)
    return float(np.nanmedian(sd)) if np.isfinite(sd).any() else 0.0


def compensate_friction(force, velocity, *, level: float | None = None) -> np.ndarray:
    """Force (n, 3) with its component along the velocity (n, 3) removed (8.29), where
    the finger moves: at a speed above three times the velocity's white-noise ``level``,
    by default estimated from the same stream (:func:`velocity_noise_level`; the
    estimators' rule of three accuracies, with the accuracy measured, not assumed).
    Slower samples pass unchanged (the direction of a still finger's velocity is its
    noise; the thesis is silent, our choice)."""
    from contactlab.constraints.friction import friction_filter

    v = np.asarray(velocity, dtype=np.float64)
    level = velocity_noise_level(v) if level is None else float(level)
    return friction_filter(force, v, min_speed=3.0 * level)


def derived_velocity(trial) -> np.ndarray:
    """Velocity (m/s) of a trial recorded without one, as chapter 1 derives it from the
    encoders: the first difference of the position times the rate, through the 7.1
    lowpass and decimation of :func:`lowpass` (row j is at input sample
    ``factor_for(rate) * j``; ``p(-1) := p(0)``, so it starts from rest).  At 1000 Hz
    this is :func:`contactlab.conditioning.velocity_from_position`; :func:`lowpass`
    also serves other rates."""
    fs = float(trial.rate_hz)
    p = _raw(trial, "position", None)
    return lowpass(np.diff(p, axis=0, prepend=p[:1]) * fs, fs=fs)


def loudest_channel(strain, rows=slice(None)) -> int:
    """The strain channel whose first difference has the most energy in ``rows`` (the
    channel where y_h of 7.1 sees an event best)."""
    d = np.diff(np.asarray(strain, float)[rows], axis=0)
    return int(np.argmax((d * d).sum(axis=0)))


def first_impact(result) -> tuple[int, int, int]:
    """The first impact of a simulated trial (a :class:`~contactlab.sim.SimResult`): its
    first and end samples and the strain channel that sees it best
    (:func:`loudest_channel`); ValueError when the trial has no impact."""
    if len(result.impact_intervals) == 0:
        raise ValueError("the simulated trial has no impact")
    i0, i1 = (int(v) for v in result.impact_intervals[0])
    return i0, i1, loudest_channel(result.strain, slice(i0, i1))


# -- ground truth at the conditioned rate -------------------------------------------------

def codes_at(codes, index, *, window: int = 1) -> np.ndarray:
    """One code per conditioned sample: ``codes[index[k]]`` when the input window
    ``index[k] - window + 1 .. index[k]`` (clipped to the record) holds one code, else -1.

    ``codes`` are per input sample; ``index`` the conditioned samples' newest input
    samples; ``window`` the input span a sample depends on (:func:`window_of`).
    """
    codes = np.asarray(codes, np.int64)
    index = np.clip(np.asarray(index, np.int64), 0, len(codes) - 1)
    if window <= 1:
        return codes[index]
    lo = np.clip(index - window + 1, 0, None)
    run = np.r_[0, np.cumsum(np.diff(codes) != 0)]          # run id of each input sample
    return np.where(run[lo] == run[index], codes[index], -1)


def relabel(trial, label_map: dict | None):
    """``trial`` with its label names mapped by ``label_map`` (name -> new name;
    unmapped names become None, i.e. unlabelled), or ``trial`` itself without a map.
    Integer labels are matched by their names (``"1"``)."""
    if not label_map:
        return trial
    from types import SimpleNamespace

    names = [label_map.get(str(n)) for n in (getattr(trial, "label_names", None) or [])]
    fields = {k: getattr(trial, k, None) for k in ("id", "rate_hz", "time", "labels", "strain",
                                                  "wrench", "position", "velocity", "action",
                                                  "command", "orientation")}
    return SimpleNamespace(**fields, label_names=names,
                           wrench_frame=getattr(trial, "wrench_frame", "sensor"))


def truth_codes(trial, index, names=None, *, window: int = 1, path=None) -> np.ndarray | None:
    """Ground truth per conditioned sample (newest input samples ``index``) as codes
    into ``names``; None when the trial has no per-sample labels.

    ``names`` defaults to the trial's label names (``trial.label_names``); a
    label not in ``names`` becomes -1.  Codes are -1 where unlabelled or, with ``window > 1``,
    where the sample's input window is not all one label (:func:`codes_at`).
    DataError naming the field for labels that do not match the trial.
    """
    raw = getattr(trial, "labels", None)
    if raw is None:
        return None
    field = f"/trials/{getattr(trial, 'id', '?')}/ground_truth/labels"
    file = str(path) if path else None
    own = getattr(trial, "label_names", None)
    if own is None:
        raise DataError("labels have no 'names' attribute", file=file, field=field)
    raw = np.asarray(raw)
    if raw.ndim != 1 or raw.shape[0] != len(trial.time):
        raise DataError(f"expected one label per sample ({len(trial.time)}); got shape "
                        f"{raw.shape}", file=file, field=field)
    raw = raw.astype(np.int64)
    bad = (raw < -1) | (raw >= len(own))
    if bad.any():
        raise DataError(f"unknown label code {int(raw[bad][0])} (names has {len(own)})",
                        file=file, field=field)
    names = list(own) if names is None else list(names)
    table = np.array([names.index(n) if n in names else -1 for n in own] + [-1], np.int64)
    return codes_at(table[raw], index, window=window)
