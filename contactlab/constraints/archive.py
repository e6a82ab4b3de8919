"""Per-segment constraint estimation of archive trials (``contactlab estimate``).

Each trial's force (``wrench[:, :3]``), position and, when present,
velocity are lowpassed and decimated to 250 Hz as in 7.1
(:func:`contactlab.signals.condition`).  The
trial is cut into segments -- the ground truth, the automatic segmentation of
:mod:`contactlab.segmentation`, or the boundaries a results stage holds -- and
optionally each segment into blocks of ``block`` samples; every piece gets a
:class:`~contactlab.constraints.CartesianConstraint` fit with a degree
decision.  Where the archive holds the true contact normals, the angular error
of the estimate is reported beside it.

Blocks are decided sequentially by default: each block's fit uses every sample
of its segment up to the block's end (the running estimate of 8.1.1.1, whose
frame is the same everywhere on a Cartesian contact), so a block that moved
along one line only is decided with what the segment explored before it.
``sequential=False`` fits each block alone -- the test of 8.2 as the thesis
ran it, on 0.1-s blocks.  At 0.1 mm / 20 mN of noise a 0.1-s block of a hand's
motion rarely explores every direction: on the synthetic contact suite the
blocks alone are right on 0.46 of the blocks, sequentially on 0.93 (0.97 and
1.00 at 0.01 mm / 10 mN).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from contactlab.archive.results import TrialResults
from contactlab.constraints.alignment import angular_error_deg
from contactlab.constraints.cartesian import CartesianConstraint, min_samples
from contactlab.constraints.compliance import CompliantConstraint
from contactlab.errors import DataError, UsageError
from contactlab.signals import cutoff_for, default_signal
from contactlab.stages import Stage, TrialOutcome, run_stage

__all__ = ["MODELS", "EstimateStage", "estimate_archive", "constraint_signals", "planar_signals",
           "segment_table"]

MODELS = ("cartesian", "polygon-A", "polygon-B", "polygon-AA", "polygon-BB", "polygon-AB",
          "polygon-line-line")

def constraint_signals(trial):
    """``(times, position, force, velocity_or_None)`` at 250 Hz (7.1 conditioning,
    :func:`contactlab.signals.condition`)."""
    from contactlab.signals import condition

    for name in ("wrench", "position"):
        if getattr(trial, name) is None:
            raise DataError("missing dataset (needed for constraint estimation)",
                            field=f"/trials/{trial.id}/measurements/{name}")
    wrench = condition(trial, "wrench")
    position = condition(trial, "position").y
    velocity = condition(trial, "velocity").y if trial.velocity is not None else None
    return wrench.times, position, wrench.y[:, :3], velocity


def segment_table(trial, segments: str, times: np.ndarray):
    """``(starts_s, ends_s, labels, source)`` of the pieces to estimate."""
    end = float(times[-1]) + 1e-9 if len(times) else 0.0
    if segments == "truth":
        seg = trial.segments
        if seg is None or len(seg) == 0:
            raise DataError("no ground-truth segments (use --segments auto)",
                            field=f"/trials/{trial.id}/ground_truth/segments")
        return (seg["start_s"].to_numpy(float), seg["end_s"].to_numpy(float),
                [None if lab is None else str(lab) for lab in seg["label"]], "truth")
    if segments == "auto":
        from contactlab.segmentation import segment_trial

        signal = default_signal(trial)
        b = segment_trial(trial, signal=signal).boundaries_s
        source = f"auto ({signal})"
    else:
        res = trial.results(segments)
        if "boundaries_s" not in res:
            raise DataError("results stage has no boundaries_s",
                            field=f"/trials/{trial.id}/results/{segments}/boundaries_s")
        b = np.asarray(res["boundaries_s"], dtype=np.float64).reshape(-1)
        source = f"results/{segments}"
    t0 = float(times[0]) if len(times) else 0.0
    edges = np.concatenate([[t0], np.sort(b), [end]])
    return edges[:-1], edges[1:], [None] * (len(edges) - 1), source


def _true_normals(trial, start_s: float, end_s: float):
    """Normals (3, m) of the surfaces in contact for most of [start, end), or None."""
    contact = trial.truth("contact")
    normals = trial.truth("contact_normals")
    if contact is None or normals is None:
        return None
    t = np.asarray(trial.time, dtype=np.float64)
    sel = (t >= start_s) & (t < end_s)
    if not sel.any():
        return None
    c = np.asarray(contact)[sel]
    c = c[:, None] if c.ndim == 1 else c
    active = c.mean(axis=0) > 0.5
    mid = np.flatnonzero(sel)[sel.sum() // 2]
    nrm = np.asarray(normals)[mid][active]
    nrm = nrm / np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-300)
    if len(nrm):
        q, r = np.linalg.qr(nrm.T)
        nrm = q[:, np.abs(np.diag(r)) > 1e-9].T
    return nrm.T


class EstimateStage(Stage):
    """``contactlab estimate`` as a stage: the parameters of :func:`estimate_archive`."""

    name = "estimate"

    def __init__(self, *, model: str = "cartesian", segments: str | None = None,
                 block: int | None = None, friction: bool = True, motion: str = "position",
                 write: bool = True, estimator: CartesianConstraint | None = None,
                 position_sd: float | None = None, force_sd: float | None = None,
                 sequential: bool = True, compliance: bool = True):
        if model not in MODELS:
            raise UsageError(f"model must be one of {', '.join(MODELS)}; got {model!r}")
        if block is not None and block < min_samples(3):
            raise UsageError(f"block must be >= {min_samples(3)} samples; got {block}")
        self.model, self.segments, self.block, self.write = model, segments, block, write
        self.sequential = bool(sequential)
        self.compliance = bool(compliance)
        self.estimator = estimator or CartesianConstraint(friction=friction, motion=motion)
        # noise levels: given, or estimated per trial unless an estimator was given
        self.fixed_noise = estimator is not None
        self.position_sd, self.force_sd = position_sd, force_sd

    def run_trial(self, trial) -> TrialOutcome:
        """Estimate every piece of one trial; its rows and results/estimate."""
        est = self.estimator
        if self.model == "cartesian":
            if not self.fixed_noise:
                est = _with_noise(est, trial, self.position_sd, self.force_sd)
            if self.compliance:
                est = CompliantConstraint(est)
            rows, (datasets, source) = _estimate_trial(trial, est, self.segments, self.block,
                                                       sequential=self.sequential)
        else:
            rows, (datasets, source) = _estimate_trial_polygon(
                trial, self.model[len("polygon-"):], self.segments, self.block)
        params = est.get_params() if self.model == "cartesian" else {}
        if self.model == "cartesian":
            params["compliance"] = self.compliance
        results = TrialResults(
            datasets,
            attrs={"model": self.model, "segments": source,
                   "normals": "normals[i, :, j]: unit normal j of piece i (NaN padded); "
                              "log_likelihoods: 8.18 per degree 0..3"},
            parameters={**params, "block": self.block, "model": self.model,
                        "sequential": self.sequential if self.block else None})
        entry = {"segments": rows}
        if self.model == "cartesian":
            entry["noise"] = {"position_sd": float(np.mean(est.position_sd)),
                              "force_sd": float(np.mean(est.force_sd))}
        return TrialOutcome(entry, results)

    def summarize(self, path, outcomes: dict[str, TrialOutcome]) -> dict:
        """Per-trial rows and counts over all pieces."""
        out = {tid: o.entry for tid, o in outcomes.items()}
        return {"trials": out, "summary": _summary(out)}


def estimate_archive(path, *, model: str = "cartesian", segments: str | None = None,
                     block: int | None = None, trials=None, friction: bool = True,
                     motion: str = "position", quiet: bool = True, write: bool = True,
                     estimator: CartesianConstraint | None = None,
                     position_sd: float | None = None, force_sd: float | None = None,
                     sequential: bool = True, workers: int = 1,
                     scheduler: str | None = None, compliance: bool = True) -> dict:
    """Estimate the constraint of every segment of every trial of archive ``path``.

    ``segments``: "truth", "auto", a results stage name, or None (truth when the
    trial has it, else auto).  ``block``: estimate consecutive blocks of this
    many 250 Hz samples inside each segment instead of whole segments; with
    ``sequential`` (default) each block is decided with its segment's samples
    up to the block's end, else from the block alone (8.2 as the thesis ran it).
    ``position_sd`` (m) and ``force_sd`` (N): the measurement noise of the raw
    signals; each one not given is estimated from every trial's own data
    (:mod:`contactlab.constraints.noise`) -- unless an ``estimator`` is given,
    whose accuracies are then used as they are.
    Writes ``results/estimate`` of all trials in one atomic step when
    ``write`` (:func:`contactlab.stages.run_stage`; ``workers`` / ``scheduler``
    as there).  ``compliance``: estimate each plane's and edge's compliance and a
    turning frame with it (:mod:`contactlab.constraints.compliance`); False fits the
    rigid constraint form as the thesis wrote it.
    Returns ``{"trials": {id: {"segments": [...]}}, "summary": {...}}``.
    """
    stage = EstimateStage(model=model, segments=segments, block=block, friction=friction,
                          motion=motion, write=write, estimator=estimator,
                          position_sd=position_sd, force_sd=force_sd, sequential=sequential,
                          compliance=compliance)
    return run_stage(stage, [path], trials=trials, workers=workers, scheduler=scheduler,
                     quiet=quiet)[Path(path)]


def _with_noise(est: CartesianConstraint, trial, position_sd, force_sd) -> CartesianConstraint:
    """``est`` with the trial's measurement accuracies at the conditioned rate: the raw
    noise given, or estimated from the trial (one level per quantity, the RMS over
    axes), times the lowpass's noise gain (:mod:`contactlab.constraints.noise`)."""
    from contactlab.constraints.noise import conditioned_noise_sd, lowpass_noise_gain

    fs = float(trial.rate_hz)
    cutoff = cutoff_for(fs)

    def level(given, data):
        if given is not None:
            return float(given) * math.sqrt(lowpass_noise_gain(fs=fs, cutoff_hz=cutoff))
        s = conditioned_noise_sd(np.asarray(data, dtype=np.float64), fs=fs, cutoff_hz=cutoff)
        return float(np.sqrt(np.mean(s ** 2)))

    params = est.get_params()
    params["position_sd"] = level(position_sd, trial.position)
    params["force_sd"] = level(force_sd, np.asarray(trial.wrench)[:, :3])
    if trial.velocity is not None:
        params["velocity_sd"] = level(None, trial.velocity)
    return CartesianConstraint(**params)


def _estimate_trial(trial, est, segments, block, *, sequential=True):
    times, position, force, velocity = constraint_signals(trial)
    mode = segments or ("truth" if trial.segments is not None and len(trial.segments) else "auto")
    starts, ends, labels, source = segment_table(trial, mode, times)
    pieces = []                                    # (samples reported, samples fitted, label)
    for s, e, lab in zip(starts, ends, labels):
        idx = np.flatnonzero((times >= s) & (times < e))
        if block:
            for j in range(0, len(idx) - block + 1, block):
                pieces.append((idx[j:j + block], idx[:j + block] if sequential
                               else idx[j:j + block], lab))
            if len(idx) < block:
                pieces.append((idx, idx, lab))
        else:
            pieces.append((idx, idx, lab))
    rows = []
    k = 3
    S = len(pieces)
    deg = np.full(S, -1, dtype=np.int64)
    ll = np.full((S, k + 1), np.nan)
    normals = np.full((S, k, k), np.nan)
    sd = np.full(S, np.nan)
    err = np.full(S, np.nan)
    st, en, nn = np.zeros(S), np.zeros(S), np.zeros(S, dtype=np.int64)
    for i, (idx, used, lab) in enumerate(pieces):
        row = {"start_s": float(times[idx[0]]) if len(idx) else None,
               "end_s": float(times[idx[-1]]) if len(idx) else None, "label": lab,
               "n": int(len(idx))}
        if len(used) != len(idx):
            row["n_fitted"] = int(len(used))
        st[i] = row["start_s"] if len(idx) else np.nan
        en[i] = row["end_s"] if len(idx) else np.nan
        nn[i] = len(idx)
        if len(idx) < min_samples(k):
            row.update(status="too short", degree=None, normals=[], log_likelihoods=None)
            rows.append(row)
            continue
        kw = {}
        if len(used) != len(idx) and isinstance(est, CompliantConstraint):
            kw["at"] = (len(used) - 0.5 * len(idx)) / len(used)   # the block's middle
        fit = est.estimate(position[used], force[used],
                           None if velocity is None else velocity[used], **kw)
        row.update(status=fit.status_, reason=fit.reason_, degree=fit.degree_,
                   normals=fit.normals_.T.tolist(),
                   log_likelihoods=fit.log_likelihoods_.tolist(),
                   angle_sd_deg=fit.angle_sd_deg_)
        for key in ("compliance_m_per_n", "compliance_sd_m_per_n", "turn_deg"):
            if key in fit.parameters:
                row[key] = float(fit.parameters[key])
        ll[i] = fit.log_likelihoods_
        sd[i] = fit.angle_sd_deg_
        if fit.degree_ is not None and fit.determined_:
            deg[i] = fit.degree_
            normals[i, :, :fit.degree_] = fit.normals_
        truth = _true_normals(trial, float(times[idx[0]]), float(times[idx[-1]]) + 1e-9)
        if truth is not None:
            row["true_degree"] = int(truth.shape[1])
            if fit.determined_ and fit.degree_ == truth.shape[1]:
                err[i] = float(angular_error_deg(fit.normals_, truth))
                row["angle_error_deg"] = err[i]
        rows.append(row)
    if block and sequential:
        sd = _with_block_spread(est, pieces, rows, deg, normals, sd, position, force, velocity)
    datasets = {"start_s": st, "end_s": en, "n": nn, "degree": deg, "log_likelihoods": ll,
                "normals": normals, "angle_sd_deg": sd, "angle_error_deg": err}
    return rows, (datasets, source)


#: the spread's frames are each estimated over this many blocks (the block and the ones
#: before it in its segment): a 0.1-s block alone lacks motion or force in some direction
#: about half the time on the synthetic contacts; 2 covered the errors of compliant
#: contacts better than 1 or 4 there (seed 3; 0.64 / 0.78 of plane / edge blocks within
#: 2 sd against 0.56 / 0.76 and 0.61 / 0.77)
WINDOW_BLOCKS = 2


def _with_block_spread(est, pieces, rows, deg, normals, sd, position, force, velocity):
    """The standard errors of the sequential fits widened by the spread of the segment's
    blocks estimated alone (:mod:`contactlab.constraints.dispersion`; each over
    :data:`WINDOW_BLOCKS` blocks): each block's pooled frame against the frames of the
    blocks so far; rows get ``angle_sd_noise_deg`` (the
    fit's own) and ``angle_sd_between_deg`` (tau) beside the widened ``angle_sd_deg``."""
    from contactlab.constraints.alignment import angular_error_deg
    from contactlab.constraints.dispersion import between_block_variance

    k = 3
    rigid = est.estimator if isinstance(est, CompliantConstraint) else est
    out = sd.copy()
    alone: list = []            # (degree, normals, sd) of each block fitted alone
    for idx, used, _ in pieces:
        if len(idx) < min_samples(k):
            alone.append(None)
            continue
        w = used[-WINDOW_BLOCKS * len(idx):]
        # the spread of the rigid fits: two blocks are too few to tell a compliance
        f = rigid.estimate(position[w], force[w], None if velocity is None else velocity[w])
        ok = f.degree_ is not None and f.determined_ and 0 < f.degree_ < k
        alone.append((f.degree_, f.normals_, f.angle_sd_deg_) if ok else None)
    first = 0
    for i, (idx, used, _) in enumerate(pieces):
        if len(used) == len(idx):                  # a segment's first block: no spread yet
            first = i
        m = int(deg[i])
        if not 0 < m < k or not np.isfinite(sd[i]):
            continue
        N = normals[i, :, :m]
        prior = [a for a in alone[first:i + 1] if a is not None and a[0] == m]
        if len(prior) < 2:
            continue
        angles = [float(angular_error_deg(a[1], N)) for a in prior]
        tau2 = between_block_variance(angles, [a[2] for a in prior])
        if alone[i] is not None and alone[i][0] == m:
            tau2 = max(tau2, 0.5 * (angles[-1] ** 2 - 2.0 * alone[i][2] ** 2))
        out[i] = float(np.hypot(sd[i], np.sqrt(tau2)))
        rows[i].update(angle_sd_noise_deg=float(sd[i]), angle_sd_between_deg=float(np.sqrt(tau2)),
                       angle_sd_deg=out[i])
    return out


def planar_signals(trial):
    """``(times, configuration [x, y, theta], wrench [fx, fy, tau])`` at 250 Hz.

    The polygon models of 8.1.2 need a planar configuration with an angle, so the
    trial's position columns must name ``x``, ``y`` and ``theta`` (an imported
    planar trace); the wrench columns ``fx``, ``fy`` and a torque about z
    (``tz``/``mz``/``tau``) are taken by name.
    """
    from contactlab.signals import factor_for, lowpass

    tid = trial.id
    for name in ("wrench", "position"):
        if getattr(trial, name) is None:
            raise DataError("missing dataset (needed for constraint estimation)",
                            field=f"/trials/{tid}/measurements/{name}")
    pcols = [str(c) for c in trial.dataset_attrs("position").get("columns", [])]
    if not {"x", "y", "theta"} <= set(pcols):
        raise DataError("polygon models need a planar configuration: position columns "
                        f"x, y, theta (these are {', '.join(pcols) or 'unnamed'})",
                        field=f"/trials/{tid}/measurements/position/columns")
    wcols = [str(c).lower() for c in trial.dataset_attrs("wrench").get("columns", [])]
    torque = next((c for c in ("tz", "mz", "tau") if c in wcols), None)
    if not ({"fx", "fy"} <= set(wcols) and torque):
        raise DataError("polygon models need wrench columns fx, fy and tz",
                        field=f"/trials/{tid}/measurements/wrench/columns")
    fs = float(trial.rate_hz)
    position = np.asarray(trial.position, dtype=np.float64)
    wrench = np.asarray(trial.wrench, dtype=np.float64)
    config = lowpass(position[:, [pcols.index(c) for c in ("x", "y", "theta")]], fs=fs)
    w = lowpass(wrench[:, [wcols.index(c) for c in ("fx", "fy", torque)]], fs=fs)
    times = np.asarray(trial.time, dtype=np.float64)[factor_for(fs) * np.arange(len(config))]
    return times, config, w


def _estimate_trial_polygon(trial, kind: str, segments, block):
    """Per segment (or block) :func:`contactlab.planar.estimate_polygon` of ``kind``."""
    from contactlab.planar import estimate_polygon

    times, config, wrench = planar_signals(trial)
    mode = segments or ("truth" if trial.segments is not None and len(trial.segments) else "auto")
    starts, ends, labels, source = segment_table(trial, mode, times)
    rows = []
    st, en, ll, it = [], [], [], []
    for s, e, lab in zip(starts, ends, labels):
        idx = np.flatnonzero((times >= s) & (times < e))
        pieces = ([idx[j:j + block] for j in range(0, len(idx) - block + 1, block)] or [idx]
                  if block else [idx])
        for piece in pieces:
            if len(piece) == 0:
                continue
            fit = estimate_polygon(configuration=config[piece], wrench=wrench[piece], kind=kind)
            rows.append({"start_s": float(times[piece[0]]), "end_s": float(times[piece[-1]]),
                         "label": lab, "n": int(len(piece)), **fit.to_dict()})
            st.append(rows[-1]["start_s"])
            en.append(rows[-1]["end_s"])
            ll.append(fit.log_likelihood)
            it.append(fit.iterations)
    datasets = {"start_s": np.asarray(st, float), "end_s": np.asarray(en, float),
                "log_likelihood": np.asarray(ll, float), "iterations": np.asarray(it, np.int64)}
    return rows, (datasets, source)


def _summary(out: dict) -> dict:
    rows = [r for t in out.values() for r in t["segments"]]
    if rows and "kind" in rows[0]:                     # polygon models
        return {"pieces": len(rows), "decided": sum(r["status"] == "ok" for r in rows),
                "undetermined": sum(r["status"] == "undetermined" for r in rows)}
    decided = [r for r in rows if r.get("degree") is not None and r.get("status") == "ok"]
    with_truth = [r for r in rows if "true_degree" in r]
    # undetermined and too-short pieces with a true degree count as undecided (not right)
    right = sum(r.get("degree") == r["true_degree"] and r.get("status") == "ok"
                for r in with_truth)
    per_degree = {}
    for m in sorted({r["true_degree"] for r in with_truth}):
        rs = [r for r in with_truth if r["true_degree"] == m]
        ok = [r for r in rs if r.get("status") == "ok" and r.get("degree") is not None]
        entry = {"pieces": len(rs), "right": sum(r["degree"] == m for r in ok),
                 "wrong": sum(r["degree"] != m for r in ok), "undecided": len(rs) - len(ok)}
        # degrees 0 and k have no frame to estimate: no angle error is reported for them
        errs = [r for r in rs if r.get("angle_error_deg") is not None]
        if errs and 0 < m < 3:
            e = np.array([r["angle_error_deg"] for r in errs])
            sd = np.array([r.get("angle_sd_deg", np.nan) for r in errs])
            entry.update(median_angle_error_deg=float(np.median(e)),
                         angle_within_2sd=float(np.mean(e <= 2 * sd)))
            if any("angle_sd_noise_deg" in r for r in errs):    # the sd widened by the spread
                own = np.array([r.get("angle_sd_noise_deg", r.get("angle_sd_deg", np.nan))
                                for r in errs])
                entry["angle_within_2sd_noise_only"] = float(np.mean(e <= 2 * own))
        per_degree[str(m)] = entry
    errs = [r["angle_error_deg"] for r in decided if r.get("angle_error_deg") is not None
            and 0 < r.get("true_degree", 0) < 3]
    return {"pieces": len(rows), "decided": len(decided),
            "undetermined": sum(r.get("status") == "undetermined" for r in rows),
            "too_short": sum(r.get("status") == "too short" for r in rows),
            "degree_correct": right / len(with_truth) if with_truth else None,
            "median_angle_error_deg": float(np.median(errs)) if errs else None,
            "per_true_degree": per_degree}
