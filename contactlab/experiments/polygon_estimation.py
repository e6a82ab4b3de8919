"""polygon-estimation: simulated accuracy of the planar polygon estimator (8.1.3.5, figs 8.4-8.5).

For each contact type (B, A, BB), contact-vector length L and noise ratio, a
planar trajectory of 100 points is simulated (:mod:`contactlab.planar.simulate`)
and the estimator of the matching model is run on it. Errors: for A and B the
angle between the estimated and true edge normals and ``|p_hat - p| / |p|``;
for BB (two perpendicular walls at distance L) the thesis's tableau measure:
the first two entries of the first two rows of the tableau (normalised by its
rotational entry) are position vectors, compared to the truth by relative
error, and the angular error is the larger of the two angles between
corresponding vectors.

Reading of the thesis's "signal-to-noise ratio": its values (0.707 ... 0.0001)
set the noise as a fraction of the signal, while its figures' x-axis is
"length x SNR", accurate near 100 (B) and 1000 (BB). Products of L with the
listed values never exceed 45, so the axis must be L / ratio (L times the
signal-to-noise ratio proper). We plot against L / ratio.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from contactlab.fileio import write_text_atomic  # noqa: E402
from contactlab.planar import Contact, PolygonNoise, estimate_polygon, simulate_polygon  # noqa: E402
from contactlab.planar.geometry import X, unit  # noqa: E402
from contactlab.planar.tableau import tableau  # noqa: E402
from contactlab.progress import bar  # noqa: E402
from contactlab.report.page import ReportPage  # noqa: E402

LENGTHS = (1, 2, 8, 16, 32, 64)
RATIOS = (0.707, 0.1, 0.01, 0.001, 0.0001)
KINDS = ("B", "A", "BB")
N_DRAWS = 12
SETTINGS = {"full": (LENGTHS, RATIOS, N_DRAWS), "light": ((1, 64), (0.1, 0.001), 3)}
#: "accurate": median angle error below 1 degree and relative position error below 1 %
ACCURATE_DEG, ACCURATE_REL = 1.0, 0.01
THESIS = {"B": 100, "A": 100, "BB": 1000}


def geometry(kind: str, length: float, rng: np.random.Generator) -> tuple[Contact, ...]:
    """Random contact geometry of contact-vector length ``length``, touching at x = 0.

    A, B: edge normal and vertex direction uniform on the circle, ``|p| = L``.
    BB: two perpendicular walls at distance L from the body origin (random
    orientation); each vertex sits on its wall at a random offset within
    ``+-L/2`` of the foot of the normal (the thesis does not place the vertices).
    """
    if kind in ("A", "B"):
        return (Contact.touching(kind, normal=unit(rng.uniform(0, 2 * np.pi)),
                                 point=length * unit(rng.uniform(0, 2 * np.pi))),)
    a = rng.uniform(0, 2 * np.pi)
    out = []
    for n in (unit(a), unit(a + np.pi / 2)):
        p = length * n + length * rng.uniform(-0.5, 0.5) * (X @ n)
        out.append(Contact.touching("B", normal=n, point=p))
    return tuple(out)


def errors(kind: str, truth, est) -> tuple[float, float]:
    """(angle error in degrees, relative position error) of one estimate."""
    if kind in ("A", "B"):
        c, e = truth[0], est.contacts[0]
        ang = np.degrees(np.arccos(np.clip(c.n @ e.n, -1.0, 1.0)))
        return float(ang), float(np.linalg.norm(e.p - c.p) / np.linalg.norm(c.p))
    T, Te = tableau(*truth), est.tableau
    P, Pe = T[:2, :2] / T[2, 2], Te[:2, :2] / Te[2, 2]
    rel = np.linalg.norm(Pe - P) / np.linalg.norm(P)
    cos = np.sum(P * Pe, 1) / (np.linalg.norm(P, axis=1) * np.linalg.norm(Pe, axis=1))
    ang = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))).max()
    return float(ang), float(rel)


def simulate(*, seed: int, setting: str = "full", quiet: bool = True) -> list[dict]:
    """One row per (kind, length, ratio, draw)."""
    lengths, ratios, draws = SETTINGS[setting]
    rng = np.random.default_rng(seed)
    rows = []
    pb = bar(total=len(KINDS) * len(lengths) * len(ratios) * draws, desc="polygon-estimation",
             quiet=quiet)
    for kind in KINDS:
        for L in lengths:
            for ratio in ratios:
                for k in range(draws):
                    truth = geometry(kind, L, rng)
                    sim = simulate_polygon(truth, rng=rng, stiffness=(1.0, 1.0, float(L) ** 2),
                                           noise_ratio=ratio)
                    sd = sim.noise_sd
                    noise = PolygonNoise(velocity=sd["velocity"], force=sd["force"],
                                         length=sd["velocity"] / sd["angular_velocity"])
                    t0 = time.perf_counter()
                    est = estimate_polygon(configuration=sim.configuration, wrench=sim.wrench,
                                           velocity=sim.velocity, kind=kind, noise=noise)
                    dt = time.perf_counter() - t0
                    row = {"kind": kind, "length": L, "ratio": ratio, "draw": k,
                           "product": L / ratio, "status": est.status,
                           "iterations": est.iterations, "converged": est.converged,
                           "estimate_s": dt}
                    if est.determined:
                        row["angle_deg"], row["rel_position"] = errors(kind, truth, est)
                    rows.append(row)
                    pb.update(1)
    pb.close()
    return rows


def _cells(rows: list[dict]) -> list[dict]:
    out = []
    keys = sorted({(r["kind"], r["length"], r["ratio"]) for r in rows},
                  key=lambda t: (KINDS.index(t[0]), t[1], -t[2]))
    for kind, L, ratio in keys:
        rs = [r for r in rows if (r["kind"], r["length"], r["ratio"]) == (kind, L, ratio)]
        ok = [r for r in rs if r["status"] == "ok"]
        its = np.array([r["iterations"] for r in ok])
        out.append({"kind": kind, "length": L, "ratio": ratio, "product": L / ratio,
                    "n": len(rs), "undetermined": len(rs) - len(ok),
                    "angle_deg_median": float(np.median([r["angle_deg"] for r in ok])),
                    "angle_deg_mean": float(np.mean([r["angle_deg"] for r in ok])),
                    "rel_position_median": float(np.median([r["rel_position"] for r in ok])),
                    "rel_position_mean": float(np.mean([r["rel_position"] for r in ok])),
                    "iterations_median": float(np.median(its)), "iterations_max": int(its.max()),
                    "not_converged": int(sum(not r["converged"] for r in ok))})
    return out


def _threshold(cells: list[dict], kind: str) -> float | None:
    """Smallest L / ratio from which every cell of ``kind`` is accurate."""
    cs = sorted((c for c in cells if c["kind"] == kind), key=lambda c: c["product"])
    good = [c["angle_deg_median"] < ACCURATE_DEG and c["rel_position_median"] < ACCURATE_REL
            for c in cs]
    for i, c in enumerate(cs):
        if all(good[i:]):
            return float(c["product"])
    return None


def summarize(rows: list[dict], *, seed: int, setting: str, wall: float) -> dict:
    cells = _cells(rows)
    its = {k: [r["iterations"] for r in rows if r["kind"] == k and r["status"] == "ok"]
           for k in KINDS}
    return {
        "experiment": "polygon-estimation", "seed": seed, "setting": setting,
        "lengths": list(SETTINGS[setting][0]), "ratios": list(SETTINGS[setting][1]),
        "draws": SETTINGS[setting][2], "x_axis": "length / ratio (length x signal-to-noise)",
        "accurate_definition": f"median angle error < {ACCURATE_DEG} deg and median relative "
                               f"position error < {ACCURATE_REL}",
        "thesis_accurate_product": THESIS,
        "ours_accurate_product": {k: _threshold(cells, k) for k in KINDS},
        "iterations": {k: {"median": float(np.median(v)), "p95": float(np.quantile(v, 0.95)),
                           "max": int(np.max(v))} for k, v in its.items()},
        "not_converged": int(sum(r["status"] == "ok" and not r["converged"] for r in rows)),
        "undetermined": int(sum(r["status"] != "ok" for r in rows)),
        "estimate_ms_median": float(1e3 * np.median([r["estimate_s"] for r in rows])),
        "cells": cells, "wall_time_s": round(wall, 2),
    }


def _figure(rows: list[dict], kind: str):
    ok = [r for r in rows if r["kind"] == kind and r["status"] == "ok"]
    prod = np.array([r["product"] for r in ok])
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for ax, key, label in ((axes[0], "angle_deg", "angle error (deg)"),
                           (axes[1], "rel_position", "relative position error")):
        y = np.array([max(r[key], 1e-12) for r in ok])
        lengths = sorted({r["length"] for r in ok})
        for i, L in enumerate(lengths):
            m = np.array([r["length"] == L for r in ok])
            ax.loglog(prod[m], y[m], ".", ms=4, color=plt.cm.viridis(i / max(len(lengths) - 1, 1)),
                      label=f"L = {L}")
        ps = np.unique(prod)
        med = [np.median(y[prod == p]) for p in ps]
        ax.loglog(ps, med, "k-", lw=1, label="median")
        ax.axvline(THESIS[kind], color="C3", ls="--", lw=1, label=f"thesis: accurate ~{THESIS[kind]}")
        ax.set_xlabel("length x SNR  (= L / noise ratio)")
        ax.set_ylabel(label)
        ax.legend(fontsize=7)
    fig.suptitle(f"Type {kind}: estimator accuracy against length x signal-to-noise", fontsize=10)
    fig.tight_layout()
    return fig


def write_report(rows: list[dict], summary: dict, out_dir: Path) -> dict:
    page = ReportPage(title="polygon-estimation: planar polygon constraint estimation "
                            "(thesis 8.1.3.5, figs 8.4-8.5)", out_dir=out_dir)
    page.paragraph(
        f"Simulated planar contacts (8.1.3.5): 100-point desired trajectories (unit-step random "
        f"walk, angle uniform in +-0.3 rad), a constraint solver minimising the stiffness energy "
        f"with K = diag(1, 1, L^2), noise on the bases completing the tangent and cotangent "
        f"spaces at ratio x the signal's standard deviation. Lengths {summary['lengths']}, noise "
        f"ratios {summary['ratios']}, {summary['draws']} random geometries per cell (seed "
        f"{summary['seed']}). The estimator is given the true noise levels as its units.")
    page.note(
        "The thesis calls 0.707 ... 0.0001 signal-to-noise ratios but plots against 'length x "
        "SNR' with accuracy near 100; with those values the product never exceeds 45, so we read "
        "them as noise-to-signal ratios and plot against L / ratio. We also read 'noise "
        "magnitude = average variance x SNR' as standard deviations (noise sd = ratio x signal "
        "sd), and take the rotational stiffness as L^2 (isotropic in body-size units); the "
        "thesis gives neither.")
    for kind, name in (("B", "fig-8-4"), ("A", "fig-8-4-type-A"), ("BB", "fig-8-5")):
        page.figure(_figure(rows, kind), name=name,
                    caption=f"Type {kind}: angle error and relative position error of each draw "
                            f"against L / ratio (colour = length), with the median per product.")
        plt.close("all")
    ours = summary["ours_accurate_product"]
    its = summary["iterations"]
    page.table([[k, f"~{THESIS[k]}", "never" if ours[k] is None else f"{ours[k]:g}",
                 its[k]["median"], its[k]["p95"], its[k]["max"]] for k in KINDS],
               columns=["type", "thesis: accurate from L x SNR", "ours: accurate from L / ratio",
                        "iterations median", "iterations 95 %", "iterations max"],
               caption=f"Where the estimates become accurate ({summary['accurate_definition']}, "
                       "and for every larger product), and the sweeps the iteration needs "
                       "to reach a change below 1e-10.")
    page.table([[c["kind"], c["length"], c["ratio"], c["product"], round(c["angle_deg_median"], 4),
                 round(c["rel_position_median"], 5), c["iterations_median"], c["undetermined"]]
                for c in summary["cells"]],
               columns=["type", "L", "ratio", "L / ratio", "angle err median (deg)",
                        "rel. position err median", "iterations median", "undetermined"],
               caption="Every cell.")
    page.heading("Where ours differ and why")
    page.paragraph(_differences(summary))
    paths = page.write()
    write_text_atomic(out_dir / "results.json", json.dumps(summary, indent=2) + "\n")
    return paths


def _differences(summary: dict) -> str:
    o = summary["ours_accurate_product"]
    fmt = {k: ("never within the grid" if v is None else f"{v:g}") for k, v in o.items()}
    return (
        f"Thesis: type B (and A) estimates are accurate near L x SNR ~ 100 and BB needs ~1000. "
        f"Ours (same definition of the axis as above): B accurate from {fmt['B']}, A from "
        f"{fmt['A']}, BB from {fmt['BB']}. The thesis gives no numeric accuracy criterion, so "
        f"'accurate' here is our threshold ({summary['accurate_definition']}); a looser one moves "
        f"every threshold left. Errors fall with the noise ratio for all three types, as in the "
        f"thesis, but in our simulation they hardly depend on L: {_l_effect(summary)}. With "
        f"the rotational stiffness scaled as L^2 and the noise a fixed fraction of the signal, "
        f"the problem is nearly scale-free in L (only the unit translational step is not), so "
        f"the collapse onto L x SNR the thesis reports does not appear; the thresholds above "
        f"therefore reflect the noise ratio. The thesis does not give its stiffness, so we "
        f"cannot tell which choice made its errors depend on L. Differences in level come from choices the thesis leaves open: the stiffness "
        f"matrix (we use diag(1, 1, L^2)), where the BB vertices sit on their walls, the noise "
        f"bases for two contacts, and the use of exact tangent velocities instead of finite "
        f"differences. For same-type pairs (BB) only the span of the two cotangents is "
        f"identifiable, so BB is scored by its tableau as the thesis does. The thesis claims "
        f"quadratic convergence for the one-contact iteration; the alternation between the two "
        f"blocks (8.64, 8.65) converges linearly, but fast: median {summary['iterations']['B']['median']:g} "
        f"sweeps for B, {summary['iterations']['A']['median']:g} for A and "
        f"{summary['iterations']['BB']['median']:g} for BB to a change below 1e-10.")


def _l_effect(summary: dict) -> str:
    """Median angle error at the smallest and largest L, per type, at one ratio."""
    cells = summary["cells"]
    lengths, ratios = summary["lengths"], summary["ratios"]
    ratio = ratios[len(ratios) // 2]
    parts = []
    for k in KINDS:
        a = [c["angle_deg_median"] for c in cells
             if c["kind"] == k and c["ratio"] == ratio and c["length"] in (lengths[0], lengths[-1])]
        if len(a) == 2:
            parts.append(f"{k} {a[0]:.3g} deg at L = {lengths[0]} vs {a[1]:.3g} deg at "
                         f"L = {lengths[-1]}")
    return f"at ratio {ratio:g}, " + ", ".join(parts)


def run(*, out_dir: Path, seed: int, quiet: bool = False, setting: str = "full") -> dict:
    """Reproduce figs 8.4-8.5 (``setting='light'`` for a quick smoke run)."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    rows = simulate(seed=seed, setting=setting, quiet=quiet)
    summary = summarize(rows, seed=seed, setting=setting, wall=time.perf_counter() - t0)
    write_report(rows, summary, out_dir)
    return summary
