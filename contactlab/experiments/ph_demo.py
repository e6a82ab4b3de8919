"""ph-demo: Page-Hinkley and lowpass+threshold on a change in mean (figs 6.4, 6.6).

A Gaussian signal with standard deviation 1 steps in mean from 0 to 1.0 at tick
126. Page-Hinkley on the change-in-mean increments (``dmu = 1, sigma = 1``,
threshold ``T^2 = 15``) detects the change and estimates its time as the last
tick its statistic was zero; the lowpass ``x(n+1) = 0.98 x(n) + 0.02 y(n+1)``
with threshold 0.50 detects it later and estimates nothing. The thesis shows
one draw (149 / 128 / 153); one draw is one sample of a random process, so we
also run 10,000 independent draws and report the distributions the thesis's
numbers sit in.

Ticks are 0-based sample indices: ``y[126]`` is the first sample with mean 1.0.
"""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from contactlab.detection import LowpassThreshold, MeanChangeDetector  # noqa: E402
from contactlab.fileio import write_text_atomic  # noqa: E402
from contactlab.progress import progress  # noqa: E402
from contactlab.report.page import ReportPage  # noqa: E402

CHANGE_TICK = 126
N_TICKS = 600          # long enough that every draw detects (delays stay under ~120)
DMU = 1.0
SIGMA = 1.0
PH_THRESHOLD = 15.0    # T^2
LP_A = 0.98
LP_THRESHOLD = 0.50
N_SEEDS = 10_000
CHUNK = 2_500
THESIS = {"change_tick": 126, "detection_tick": 149, "change_estimate_tick": 128,
          "lowpass_detection_tick": 153}
QUANTILES = (0.05, 0.25, 0.5, 0.75, 0.95)


def signal(rng: np.random.Generator, n_draws: int, *, n_ticks: int = N_TICKS) -> np.ndarray:
    """``n_draws`` independent signals as columns: N(0,1), mean +DMU from CHANGE_TICK on."""
    y = rng.standard_normal((n_ticks, n_draws)) * SIGMA
    y[CHANGE_TICK:] += DMU
    return y


def detectors() -> tuple[MeanChangeDetector, LowpassThreshold]:
    """The two detectors of figs 6.4 and 6.6, fresh."""
    return (MeanChangeDetector(mu0=0.0, dmu=DMU, sigma=SIGMA, threshold=PH_THRESHOLD),
            LowpassThreshold(a=LP_A, threshold=LP_THRESHOLD))


def simulate(*, seed: int, n_seeds: int = N_SEEDS, quiet: bool = True) -> dict:
    """Run both detectors on ``n_seeds`` draws; draw 0 is the demo draw.

    Returns per-draw arrays (length ``n_seeds``): ``ph_detect`` and
    ``lp_detect`` (first alarm at or after the change, -1 if none),
    ``ph_last_zero`` (PH change estimate of that alarm), ``ph_false`` and
    ``lp_false`` (alarms before the change), plus draw 0's signal and traces.
    """
    rng = np.random.default_rng(seed)
    out = {k: [] for k in ("ph_detect", "ph_last_zero", "lp_detect", "ph_false", "lp_false")}
    demo = {}
    starts = range(0, n_seeds, CHUNK)
    for start in progress(starts, total=len(starts), desc="ph-demo draws", quiet=quiet):
        m = min(CHUNK, n_seeds - start)
        y = signal(rng, m)
        ph, lp = detectors()
        pa = ph.run(y, trace=start == 0)
        la = lp.run(y, trace=start == 0)
        t, lz, _ = pa.first(m, at_or_after=CHANGE_TICK)
        out["ph_detect"].append(t)
        out["ph_last_zero"].append(lz)
        out["lp_detect"].append(la.first(m, at_or_after=CHANGE_TICK)[0])
        out["ph_false"].append(np.bincount(pa.detector[pa.time < CHANGE_TICK], minlength=m))
        out["lp_false"].append(np.bincount(la.detector[la.time < CHANGE_TICK], minlength=m))
        if start == 0:
            demo = {"y": y[:, 0].copy(), "df": pa.trace[:, 0, 0].copy(),
                    "x": la.trace[:, 0, 0].copy()}
    res = {k: np.concatenate(v) for k, v in out.items()}
    res["demo"] = demo
    return res


def _stats(v: np.ndarray, thesis_value: float | None = None) -> dict:
    v = v.astype(float)
    q = np.quantile(v, QUANTILES)
    d = {"n": int(v.size), "mean": float(v.mean()), "sd": float(v.std(ddof=1)),
         **{f"q{int(p * 100):02d}": float(x) for p, x in zip(QUANTILES, q, strict=True)}}
    if thesis_value is not None:
        # mid-rank percentile of the thesis's single value in our distribution
        d["thesis_value"] = thesis_value
        d["thesis_percentile"] = float(100 * ((v < thesis_value).mean()
                                              + 0.5 * (v == thesis_value).mean()))
    return d


def summarize(sim: dict, *, seed: int) -> dict:
    """The JSON summary: the demo draw's ticks and the distributions over draws."""
    ok = (sim["ph_detect"] >= 0) & (sim["lp_detect"] >= 0)
    ph_delay = sim["ph_detect"][ok] - CHANGE_TICK
    lp_delay = sim["lp_detect"][ok] - CHANGE_TICK
    last_zero = sim["ph_last_zero"][ok]
    onset_err = last_zero + 1 - CHANGE_TICK
    pair = lp_delay - ph_delay
    df, x = sim["demo"]["df"], sim["demo"]["x"]
    det = int(sim["ph_detect"][0])
    return {
        "experiment": "ph-demo",
        "seed": seed,
        "tick_convention": "0-based sample index; y[126] is the first sample with mean 1.0",
        "change_tick": CHANGE_TICK,
        "detection_tick": det,
        "change_estimate_tick": int(sim["ph_last_zero"][0]),
        "change_onset_tick": int(sim["ph_last_zero"][0]) + 1,
        "lowpass_detection_tick": int(sim["lp_detect"][0]),
        "demo_df_at_detection": float(df[det]) if det >= 0 else None,
        "demo_x_at_lowpass_detection": (float(x[sim["lp_detect"][0]])
                                        if sim["lp_detect"][0] >= 0 else None),
        "thesis": THESIS,
        "n_draws": int(sim["ph_detect"].size),
        "distribution": {
            "ph_delay": _stats(ph_delay, THESIS["detection_tick"] - CHANGE_TICK),
            "lowpass_delay": _stats(lp_delay, THESIS["lowpass_detection_tick"] - CHANGE_TICK),
            "ph_change_estimate_tick": _stats(last_zero, THESIS["change_estimate_tick"]),
            "ph_onset_error": _stats(onset_err, THESIS["change_estimate_tick"] + 1 - CHANGE_TICK),
            "lowpass_minus_ph_delay": {**_stats(pair),
                                       "p_ph_earlier": float((pair > 0).mean()),
                                       "p_tie": float((pair == 0).mean()),
                                       "p_lowpass_earlier": float((pair < 0).mean())},
        },
        "false_alarms_before_change": {"ph": int(sim["ph_false"].sum()),
                                       "lowpass": int(sim["lp_false"].sum())},
        "missed_within_n_ticks": {"ph": int((sim["ph_detect"] < 0).sum()),
                                  "lowpass": int((sim["lp_detect"] < 0).sum()),
                                  "n_ticks": N_TICKS},
        "settings": {"dmu": DMU, "sigma": SIGMA, "ph_threshold_T2": PH_THRESHOLD,
                     "lowpass_a": LP_A, "lowpass_threshold": LP_THRESHOLD},
    }


# -- figures ---------------------------------------------------------------------------
def _fig_ph(sim: dict, summary: dict):
    y, df = sim["demo"]["y"], sim["demo"]["df"]
    det, lz = summary["detection_tick"], summary["change_estimate_tick"]
    end = min(len(y), max(det, summary["lowpass_detection_tick"], 200) + 40)
    t = np.arange(end)
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    ax1.plot(t, y[:end], ".", ms=3, color="0.4", label="signal y")
    ax1.plot(t, np.where(t >= CHANGE_TICK, DMU, 0.0), color="C2", lw=1.5, label="true mean")
    ax1.set_ylabel("y")
    ax1.legend(loc="upper left", fontsize=8)
    ax2.plot(t, df[:end], color="C0", label="decision function DF (6.18)")
    ax2.axhline(PH_THRESHOLD, color="C3", ls="--", lw=1, label=f"threshold T^2 = {PH_THRESHOLD:g}")
    ax2.axvline(CHANGE_TICK, color="C2", lw=1, label=f"true change ({CHANGE_TICK})")
    ax2.axvline(lz, color="C1", ls=":", lw=1.5, label=f"last zero = change estimate ({lz})")
    ax2.axvline(det, color="C3", lw=1, label=f"detection ({det})")
    ax2.set_xlabel("tick (0-based sample index)")
    ax2.set_ylabel("DF")
    ax2.legend(loc="upper left", fontsize=8)
    ax1.set_title(f"Page-Hinkley on a change in mean 0 -> {DMU:g} (thesis fig 6.4: "
                  f"detects {THESIS['detection_tick']}, estimate {THESIS['change_estimate_tick']})",
                  fontsize=9)
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    return fig


def _fig_lp(sim: dict, summary: dict):
    y, x = sim["demo"]["y"], sim["demo"]["x"]
    det, ph_det = summary["lowpass_detection_tick"], summary["detection_tick"]
    end = min(len(y), max(det, ph_det, 200) + 40)
    t = np.arange(end)
    fig, ax = plt.subplots(figsize=(8, 4))
    ax.plot(t, y[:end], ".", ms=2, color="0.75", label="signal y")
    ax.plot(t, x[:end], color="C0", label=f"lowpass x, a = {LP_A:g}")
    ax.axhline(LP_THRESHOLD, color="C3", ls="--", lw=1, label=f"threshold {LP_THRESHOLD:g}")
    ax.axvline(CHANGE_TICK, color="C2", lw=1, label=f"true change ({CHANGE_TICK})")
    ax.axvline(det, color="C3", lw=1, label=f"lowpass detection ({det})")
    ax.axvline(ph_det, color="C0", ls=":", lw=1, label=f"Page-Hinkley detection ({ph_det})")
    ax.set_ylim(-1.0, 2.5)
    ax.set_xlabel("tick (0-based sample index)")
    ax.set_ylabel("x")
    ax.legend(loc="upper left", fontsize=8)
    ax.set_title(f"Lowpass + threshold on the same draw (thesis fig 6.6: detects "
                 f"{THESIS['lowpass_detection_tick']})", fontsize=9)
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    return fig


def _fig_hist(sim: dict, summary: dict):
    ok = (sim["ph_detect"] >= 0) & (sim["lp_detect"] >= 0)
    ph = sim["ph_detect"][ok] - CHANGE_TICK
    lp = sim["lp_detect"][ok] - CHANGE_TICK
    lz = sim["ph_last_zero"][ok]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4))
    bins = np.arange(0, max(ph.max(), lp.max()) + 2) - 0.5
    ax1.hist(ph, bins=bins, alpha=0.6, color="C0", label="Page-Hinkley")
    ax1.hist(lp, bins=bins, alpha=0.6, color="C1", label="lowpass")
    ax1.axvline(THESIS["detection_tick"] - CHANGE_TICK, color="C0", ls="--",
                label="thesis PH (23)")
    ax1.axvline(THESIS["lowpass_detection_tick"] - CHANGE_TICK, color="C1", ls="--",
                label="thesis lowpass (27)")
    ax1.set_xlabel("detection tick - change tick")
    ax1.set_ylabel("draws")
    ax1.set_xlim(0, np.quantile(np.concatenate([ph, lp]), 0.999) + 5)
    ax1.legend(fontsize=8)
    ax1.set_title(f"Detection delay over {ok.sum():,} draws", fontsize=9)
    lo, hi = np.quantile(lz, [0.001, 0.999])
    bins = np.arange(lo, hi + 2) - 0.5
    ax2.hist(lz, bins=bins, color="C0", alpha=0.7)
    ax2.axvline(CHANGE_TICK - 1, color="C2", label="ideal last zero (125)")
    ax2.axvline(THESIS["change_estimate_tick"], color="C3", ls="--", label="thesis (128)")
    ax2.set_xlabel("Page-Hinkley change estimate (last zero tick)")
    ax2.legend(fontsize=8)
    ax2.set_title("Change-time estimate over draws", fontsize=9)
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    return fig


# -- report ----------------------------------------------------------------------------
def _ordinal(x: float) -> str:
    n = int(round(x))
    suffix = "th" if 10 <= n % 100 <= 20 else {1: "st", 2: "nd", 3: "rd"}.get(n % 10, "th")
    return f"{n}{suffix}"


def _row(name, thesis, ours, st):
    return [name, thesis, ours, round(st["mean"], 2), st["q50"], f"{st['q05']:g} - {st['q95']:g}",
            round(st["thesis_percentile"], 1) if "thesis_percentile" in st else ""]


def write_report(sim: dict, summary: dict, out_dir: Path) -> dict:
    """The page (index.html, report.pdf, figures) and results.json."""
    dist = summary["distribution"]
    page = ReportPage(title="ph-demo: Page-Hinkley vs lowpass on a change in mean "
                            "(thesis 6.3.1, figs 6.4, 6.6)", out_dir=out_dir)
    page.paragraph(
        f"Gaussian signal, standard deviation {SIGMA:g}, mean 0 stepping to {DMU:g} at tick "
        f"{CHANGE_TICK}. Page-Hinkley uses the change-in-mean increments "
        f"Xi = (dmu/sigma^2)(y - mu0 - dmu/2) with threshold T^2 = {PH_THRESHOLD:g}; the "
        f"lowpass detector is x(n+1) = {LP_A:g} x(n) + {1 - LP_A:.2f} y(n+1) with threshold "
        f"{LP_THRESHOLD:.2f}. Draw 0 of seed {summary['seed']} is shown in the figures; the "
        f"table also gives the distribution over {summary['n_draws']:,} independent draws.")
    page.note(
        "Ticks are 0-based sample indices and y[126] is the first sample with the new mean, so "
        "the ideal 'last zero' of the Page-Hinkley statistic is tick 125 and the estimated onset "
        "of the change (the maximiser r of (6.15)) is last zero + 1. Delays are detection tick "
        "minus 126. The thesis does not say how it counts ticks; with 1-based counting every "
        "thesis tick would be one lower in our indices.")
    page.figure(_fig_ph(sim, summary), name="fig-6-4",
                caption="Figure 6.4 reproduced: signal (top) and Page-Hinkley decision function "
                        "(bottom) with threshold, detection and the change estimate (last tick "
                        "at which the statistic was zero).")
    page.figure(_fig_lp(sim, summary), name="fig-6-6",
                caption="Figure 6.6 reproduced: lowpass filter output on the same draw with "
                        "threshold 0.50. It gives no change-time estimate.")
    rows = [
        _row("Page-Hinkley detection delay (ticks)", THESIS["detection_tick"] - CHANGE_TICK,
             summary["detection_tick"] - CHANGE_TICK, dist["ph_delay"]),
        _row("Page-Hinkley change estimate (last-zero tick)", THESIS["change_estimate_tick"],
             summary["change_estimate_tick"], dist["ph_change_estimate_tick"]),
        _row("lowpass detection delay (ticks)", THESIS["lowpass_detection_tick"] - CHANGE_TICK,
             summary["lowpass_detection_tick"] - CHANGE_TICK, dist["lowpass_delay"]),
        _row("lowpass minus Page-Hinkley delay (same draw)",
             THESIS["lowpass_detection_tick"] - THESIS["detection_tick"],
             summary["lowpass_detection_tick"] - summary["detection_tick"],
             dist["lowpass_minus_ph_delay"]),
    ]
    page.table(rows, columns=["quantity", "thesis (one draw)", f"ours (draw 0, seed "
                              f"{summary['seed']})", "mean over draws", "median", "5% - 95%",
                              "percentile of thesis value"],
               caption=f"The thesis's single draw against ours and against {summary['n_draws']:,}"
                       " draws. The last column is the mid-rank percentile of the thesis's "
                       "number in our distribution.")
    pair = dist["lowpass_minus_ph_delay"]
    page.paragraph(
        f"Over {summary['n_draws']:,} draws Page-Hinkley detects after "
        f"{dist['ph_delay']['mean']:.1f} ticks on average (median {dist['ph_delay']['q50']:g}) "
        f"and the lowpass detector after "
        f"{dist['lowpass_delay']['mean']:.1f} (median {dist['lowpass_delay']['q50']:g}). On the "
        f"same draw Page-Hinkley is earlier in {100 * pair['p_ph_earlier']:.1f} % of draws, "
        f"later in {100 * pair['p_lowpass_earlier']:.1f} % and tied in {100 * pair['p_tie']:.1f} "
        f"%. The thesis's draw (delays 23 and 27, change estimate 128) is an ordinary draw: its "
        f"numbers sit at the {_ordinal(dist['ph_delay']['thesis_percentile'])}, "
        f"{_ordinal(dist['lowpass_delay']['thesis_percentile'])} and "
        f"{_ordinal(dist['ph_change_estimate_tick']['thesis_percentile'])} percentiles of "
        f"ours. The "
        f"Page-Hinkley change estimate has median {dist['ph_change_estimate_tick']['q50']:g} "
        f"(ideal 125) with 90 % of draws within {dist['ph_change_estimate_tick']['q05']:g} - "
        f"{dist['ph_change_estimate_tick']['q95']:g}.")
    fa = summary["false_alarms_before_change"]
    miss = summary["missed_within_n_ticks"]
    page.paragraph(
        f"False alarms before the change over all draws: Page-Hinkley {fa['ph']}, lowpass "
        f"{fa['lowpass']} (a reset detector keeps watching and the detection is its first alarm "
        f"at or after tick {CHANGE_TICK}). Draws with no detection within {miss['n_ticks']} ticks:"
        f" Page-Hinkley {miss['ph']}, lowpass {miss['lowpass']}.")
    page.figure(_fig_hist(sim, summary), name="delay-histograms",
                caption="Left: detection delay of both detectors over all draws, with the "
                        "thesis's single values. Right: Page-Hinkley change estimate (last zero).")
    paths = page.write()
    write_text_atomic(out_dir / "results.json", json.dumps(summary, indent=2) + "\n")
    return paths


def run(*, out_dir: Path, seed: int, quiet: bool = False, n_seeds: int = N_SEEDS) -> dict:
    """Reproduce figs 6.4 and 6.6 and the distribution over ``n_seeds`` draws."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    sim = simulate(seed=seed, n_seeds=n_seeds, quiet=quiet)
    summary = summarize(sim, seed=seed)
    write_report(sim, summary, out_dir)
    return summary
