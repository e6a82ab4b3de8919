"""hf-models: the four high-frequency models of 7.3 and their normal-fit confusion (fig 7.9).

The 15 training runs of datasets_spec/hf-train.toml (5 diagonal moves with an
impact and rest against a block, 5 without, 5 x moves ending against a wall)
are simulated through the acquire path into ``out_dir/tmp`` (deleted after).

* Signal: y_h of 7.1, the block-averaged log|strain difference| at 250 Hz. The
  thesis does not say which strain channel(s) it used; we use the **mean over
  the 8 strain channels** (one signal, as the thesis's 2-D fig 7.9 implies),
  log floor at half the ADC step (the strains are quantised).
* Segments: the simulator's ground truth (``labels = "hf"``: H0 stationary
  free, H1 moving free, H2 touching still, H3 inside an impact interval),
  where the thesis hand-segmented; a 250 Hz sample counts for a class only if
  all 9 input samples its y_h value depends on carry that label.
* H0-H2: cut into units of 100 (never across a label change); per unit an AR(1)
  model with a mean, whose two LPC (orthogonal) coefficients are ~ the unit's
  mean and its AR coefficient (eq. 7.3, A.42), and the driving variance (7.3).
  A normal per class fitted to the 2-D (k_mu, k_a) scatter gives the predicted
  confusion of the equal-prior likelihood rule (Monte Carlo, 200,000 draws per
  class), beside the thesis's.
* H3: not a stationary model. The thesis models the falling edge of an impact
  by the linear decay ``y_h(n) = mu + a n + nu`` (7.1); we fit it to y_h over
  each truth impact interval (impacts are shorter than 100 samples) and report
  the fitted start level, decay rate and residual variance per impact.
"""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from contactlab.archive import open_archive, validate_archive  # noqa: E402
from contactlab.estimators import LinearDecayModel, estimate  # noqa: E402
from contactlab.acquire.simulated import record_spec  # noqa: E402
from contactlab.metrics import confusion_matrix  # noqa: E402
from contactlab.temporal import block_features  # noqa: E402
from contactlab.temporal.blocks import mask_runs, truth_blocks  # noqa: E402
from contactlab.temporal.energy import normal_confusion_mc, normal_params  # noqa: E402
from contactlab.fileio import write_text_atomic  # noqa: E402
from contactlab.progress import bar  # noqa: E402
from contactlab.report.page import ReportPage  # noqa: E402
from contactlab.experiments.scratch import scratch_dir  # noqa: E402

SPEC = "hf-train"
BLOCK = 100            # 7.3: "segmented into units of 100 measurements"
ORDER = 1              # 7.3: "a mean and a single AR coefficient"
MEAN = True
STATIONARY = ("H0", "H1", "H2")
N_DRAWS = 200_000
#: a smaller unit, reported as a sample-size check only (not the thesis's setting)
CHECK_BLOCK = 50
THESIS = {"confusion": [[0.92, 0.0, 0.08], [0.0, 0.97, 0.03], [0.13, 0.03, 0.84]],
          "runs": 15}


def stationary_features(archive, *, block: int = BLOCK) -> dict:
    """Units of ``block`` samples of the channel-mean y_h inside H0/H1/H2 runs: ``k``
    (n, 2) LPC coefficients (k_mu, k_a), ``coef`` (n, 2) (mu, a_1), ``noise_var`` (n,),
    ``labels`` (n,) in 0..2, ``trial`` (n,) index, ``group`` name per trial."""
    out = {"k": [], "coef": [], "noise_var": [], "labels": [], "trial": []}
    groups = []
    with open_archive(archive) as arc:
        for i, trial in enumerate(arc):
            groups.append(str(trial.attrs.get("group", "")))
            b = truth_blocks(trial, signal="hf", block=block, classes=range(len(STATIONARY)))
            f = block_features(b["y"].mean(axis=1), order=ORDER, mean=MEAN, block=block,
                               starts=b["starts"])
            out["k"].append(f.orthogonal[:, 0])
            out["coef"].append(f.coef[:, 0])
            out["noise_var"].append(f.ml_noise_var[:, 0])
            out["labels"].append(b["labels"])
            out["trial"].append(np.full(len(b["labels"]), i))
    res = {k: np.concatenate(v) for k, v in out.items()}
    res["groups"] = groups
    return res


def impact_fits(archive, *, code: int = 3) -> list[dict]:
    """The linear-decay model (7.1) fitted to the channel-mean y_h over every run of
    truth code ``code`` (H3): start level mu, slope a (per 250 Hz sample), residual
    variance, length, and the data for plotting."""
    rows = []
    with open_archive(archive) as arc:
        for trial in arc:
            b = truth_blocks(trial, signal="hf", block=1, classes=[code])
            y = b["y"].mean(axis=1)
            runs = mask_runs(b["codes"] == code)
            for s, e in runs:
                if e - s < 3:
                    continue
                f = estimate(LinearDecayModel(), y[s:e])
                rows.append({"trial": trial.id, "group": str(trial.attrs.get("group", "")),
                             "start": int(s), "length": int(e - s),
                             "mu": float(f.coef[0, 0]), "slope": float(f.coef[0, 1]),
                             "noise_var": float(f.variance[0]),
                             "y": y[max(s - 25, 0):e + 50].tolist(),
                             "offset": int(s - max(s - 25, 0))})
    return rows


def predicted_confusion(k, labels, *, seed: int) -> dict:
    """Normal fit per stationary class to the feature rows ``k`` (n, d) and the
    Monte-Carlo confusion of the equal-prior rule under those normals; also the
    resubstitution confusion of the same rule on the units themselves."""
    fits = [normal_params(k[labels == c]) for c in range(len(STATIONARY))]
    means = [m for m, _ in fits]
    covs = [c for _, c in fits]
    pred = normal_confusion_mc(np.asarray(means), np.asarray(covs), n=N_DRAWS, seed=seed)
    from scipy import stats

    ll = np.column_stack([stats.multivariate_normal(m, c).logpdf(k) for m, c in fits])
    counts, rates = confusion_matrix(labels, np.argmax(ll, axis=1), len(STATIONARY))
    return {"means": [m.tolist() for m in means], "covs": [c.tolist() for c in covs],
            "predicted": pred.tolist(), "resubstitution": rates.tolist(),
            "resubstitution_counts": counts.tolist()}


def run(*, out_dir: Path, seed: int, quiet: bool = False) -> dict:
    """Simulate the 15 training runs, fit the models, write the page and results.json."""
    out_dir = Path(out_dir)
    with scratch_dir(out_dir) as tmp:
        with bar(total=3, desc="hf-models", quiet=quiet, unit="step") as pbar:
            arc = record_spec(SPEC, tmp / f"{SPEC}.h5", seed=seed)
            problems = [str(p) for p in validate_archive(arc)]
            pbar.update(1)
            feats = stationary_features(arc)
            check = stationary_features(arc, block=CHECK_BLOCK)
            pbar.update(1)
            impacts = impact_fits(arc)
            pbar.update(1)
        pc = predicted_confusion(feats["k"], feats["labels"], seed=seed)
        k3 = np.column_stack([feats["k"], np.log(feats["noise_var"])])
        pc3 = predicted_confusion(k3, feats["labels"], seed=seed)
        pcc = predicted_confusion(check["k"], check["labels"], seed=seed)
        return _report(feats, pc, pc3, pcc, check, impacts, problems, out_dir=out_dir,
                       seed=seed)


# ---------------------------------------------------------------------------
# report
# ---------------------------------------------------------------------------
def _ellipse(mean, cov, r: float):
    w, v = np.linalg.eigh(np.asarray(cov))
    t = np.linspace(0, 2 * np.pi, 200)
    pts = (v * np.sqrt(np.maximum(w, 0)) * r) @ np.vstack([np.cos(t), np.sin(t)])
    return mean[0] + pts[0], mean[1] + pts[1]


def fig_scatter(feats: dict, pc: dict):
    """Fig 7.9: the (k_mu, k_a) units of H0-H2 with the 1- and 2-sigma contours."""
    fig, ax = plt.subplots(figsize=(6.2, 4.8))
    for c, name in enumerate(STATIONARY):
        sel = feats["labels"] == c
        color = f"C{c}"
        ax.scatter(feats["k"][sel, 0], feats["k"][sel, 1], s=14, color=color, alpha=0.75,
                   label=f"{name} ({int(sel.sum())} units)")
        for r, ls in ((1, "-"), (2, "--")):
            x, y = _ellipse(np.asarray(pc["means"][c]), pc["covs"][c], r)
            ax.plot(x, y, ls, color=color, lw=1)
    ax.set_xlabel("k_mu (LPC of the mean ~ unit mean of y_h)")
    ax.set_ylabel("k_a (LPC of the AR coefficient)")
    ax.set_title(f"Stationary models, units of {BLOCK} samples of y_h (1, 2 sigma)", fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def fig_impacts(impacts: list[dict]):
    """H3: y_h around each impact with the fitted linear decay."""
    fig, ax = plt.subplots(figsize=(6.2, 3.8))
    for i, r in enumerate(impacts):
        y = np.asarray(r["y"])
        n = np.arange(len(y)) - r["offset"]
        color = "C3" if r["group"].startswith("diagonal") else "C0"
        ax.plot(n / 250.0 * 1e3, y, color=color, lw=0.7, alpha=0.6)
        m = np.arange(r["length"])
        ax.plot(m / 250.0 * 1e3, r["mu"] + r["slope"] * m, color="k", lw=0.8)
    ax.set_xlabel("time from the start of the impact interval (ms)")
    ax.set_ylabel("y_h (channel mean)")
    ax.set_title("H3: linear decay fits (black) over the impact intervals; red diagonal-impact, "
                 "blue x-impact", fontsize=8)
    fig.tight_layout()
    return fig


def _conf_rows(label: str, m) -> list[list]:
    return [[f"{label}: {STATIONARY[i]}"] + [round(float(x), 3) for x in m[i]]
            for i in range(len(STATIONARY))]


def _report(feats, pc, pc3, pcc, check, impacts, problems, *, out_dir: Path, seed: int) -> dict:
    page = ReportPage(title="hf-models: high-frequency models (7.3, fig 7.9)", out_dir=out_dir)
    counts = np.bincount(feats["labels"], minlength=3).tolist()
    ccounts = np.bincount(check["labels"], minlength=3).tolist()
    page.paragraph(
        f"The {THESIS['runs']} training runs of datasets_spec/hf-train.toml (run seed {seed}) "
        "were simulated through the acquire path (archive valid: "
        f"{'yes' if not problems else 'NO'}). Units of {BLOCK} samples of y_h inside the "
        f"ground-truth runs of H0, H1 and H2: {counts[0]}, {counts[1]} and {counts[2]} units. "
        f"Per unit an AR({ORDER}) model with a mean gives two LPC coefficients and the driving "
        "variance; a normal fitted per class to the 2-D LPC scatter predicts the confusion "
        "below.")
    page.note(
        "Choices where the thesis is ambiguous: y_h is the mean over the 8 strain channels "
        "(the thesis does not say which channel; its fig 7.9 is one 2-D scatter); segments "
        "come from the simulator's ground truth instead of hand segmentation; H3 is the "
        "linear-decay impact model fitted over each impact interval, not a stationary unit "
        "(and so, as in the thesis, not in the normal-fit confusion).")
    rows = _conf_rows("thesis", THESIS["confusion"]) + _conf_rows("ours, normal fit",
                                                                  pc["predicted"])
    rows += _conf_rows("ours, resubstitution", pc["resubstitution"])
    page.table(rows, columns=["true class", "H0", "H1", "H2"],
               caption="Confusion of the stationary models (rows true class). 'normal fit': "
                       f"the equal-prior rule under the fitted normals, {N_DRAWS:,} Monte-Carlo "
                       "draws per class (the thesis's method); 'resubstitution': the same rule "
                       "applied to the training units themselves.")
    rows = _conf_rows("with log driving variance (3-D)", pc3["predicted"])
    rows += _conf_rows(f"units of {CHECK_BLOCK} ({ccounts[0]}/{ccounts[1]}/{ccounts[2]})",
                       pcc["predicted"])
    page.table(rows, columns=["true class", "H0", "H1", "H2"],
               caption="Checks, normal-fit predictions: adding the driving variance as a third "
                       f"feature; units of {CHECK_BLOCK} instead of {BLOCK} (more units, "
                       "especially for H1; a sample-size check, not the thesis's setting).")
    rows = []
    for c, name in enumerate(STATIONARY):
        sel = feats["labels"] == c
        rows.append([name, int(sel.sum()), round(float(feats["k"][sel, 0].mean()), 4),
                     round(float(feats["k"][sel, 0].std(ddof=1)), 4),
                     round(float(feats["k"][sel, 1].mean()), 3),
                     round(float(feats["k"][sel, 1].std(ddof=1)), 3),
                     f"{float(np.mean(feats['noise_var'][sel])):.3g}"])
    page.table(rows, columns=["class", "units", "k_mu mean", "k_mu sd", "k_a mean", "k_a sd",
                              "driving variance (mean)"],
               caption="The stationary models' features.")
    page.figure(fig_scatter(feats, pc), name="fig-7-9",
                caption="Fig 7.9 (ours): the two LPC coefficients of every unit of the three "
                        "stationary models, with the 1- and 2-sigma contours of the normal fits.")
    if impacts:
        slopes = np.array([r["slope"] for r in impacts])
        mus = np.array([r["mu"] for r in impacts])
        lens = np.array([r["length"] for r in impacts])
        page.table([[len(impacts), f"{lens.min()}-{lens.max()}", round(float(mus.mean()), 3),
                     round(float(mus.std(ddof=1)) if len(mus) > 1 else 0.0, 3),
                     f"{slopes.mean():.4f}",
                     f"{slopes.std(ddof=1) if len(slopes) > 1 else 0.0:.4f}"]],
                   columns=["impacts", "length (samples)", "mu mean", "mu sd",
                            "slope mean (per sample)", "slope sd"],
                   caption="H3: linear-decay fits y_h(n) = mu + a n over the impact intervals.")
        page.figure(fig_impacts(impacts), name="h3-impacts",
                    caption="H3 (the falling edge of an impact): y_h around every impact and "
                            "the linear decay fitted over its truth interval.")
    page.heading("Where ours differ from the thesis, and why")
    for line in _differences(feats, pc, impacts):
        page.paragraph(line)
    paths = page.write()
    summary = {"experiment": "hf-models", "seed": seed, "block": BLOCK, "archive_valid":
               not problems, "units": dict(zip(STATIONARY, counts)),
               "normal_fit_confusion": pc["predicted"],
               "resubstitution_confusion": pc["resubstitution"],
               "normal_fit_confusion_with_variance": pc3["predicted"],
               f"normal_fit_confusion_block{CHECK_BLOCK}": pcc["predicted"],
               f"units_block{CHECK_BLOCK}": dict(zip(STATIONARY, ccounts)),
               "class_means": pc["means"], "class_covs": pc["covs"],
               "impacts": [{k: v for k, v in r.items() if k not in ("y", "offset")}
                           for r in impacts],
               "thesis": THESIS, "html": str(paths["html"])}
    write_text_atomic(out_dir / "results.json", json.dumps(summary, indent=2) + "\n")
    return summary


def _level_text(mu, pc) -> str:
    sd = [float(np.sqrt(c[0][0])) for c in pc["covs"]]
    h1 = (mu[1] - mu[0]) / max(sd[0], sd[1])
    h2 = (mu[2] - mu[0]) / max(sd[0], sd[2])
    return (f"H1 lies {h1:.1f} within-class sd above H0 and H2 {h2:+.1f}: moving is "
            + ("clearly separated from stationary, as the thesis found" if h1 > 3 else
               "only partly separated from stationary") + ", while pressed "
            + ("overlaps stationary." if abs(h2) < 2 else "is separated from stationary.")
            + f" Pressed lies {(mu[2] - mu[1]) / max(sd[1], sd[2]):+.1f} sd from moving.")


def _differences(feats, pc, impacts) -> list[str]:
    diag = np.diag(np.asarray(pc["predicted"]))
    means = np.asarray(pc["means"])
    diag_text = ", ".join(f"{s} {d:.2f}" for s, d in zip(STATIONARY, diag))
    out = [f"Our normal-fit diagonal is {diag_text}"
           " (thesis 0.92, 0.97, 0.84). The class means of y_h (k_mu) are "
           + ", ".join(f"{s} {m:.3f}" for s, m in zip(STATIONARY, means[:, 0]))
           + f" (spread {np.ptp(means[:, 0]):.3f}, against a within-class sd of about "
           f"{np.mean([np.sqrt(c[0][0]) for c in pc['covs']]):.3f}). "
           + _level_text(means[:, 0], pc) + " The simulator's sensor chain and drive are "
           "identified from the thesis's signal facts, not from this table (reproduce "
           "apparatus): a 16-bit converter dithered by the amplifier noise, so the moving "
           "drive's vibration (brush and capstan-cable friction ripple, commutation ripple, "
           "control noise on encoder feedback) raises y_h above the stationary floor, and a "
           "finger pressed still carries the motors' force noise (the force DAC's steps and "
           "the amplifier noise) through the contact into the sensor. Ordered by level: "
           + " < ".join(STATIONARY[i] for i in np.argsort(means[:, 0]))
           + " (the thesis: pressed between stationary and moving, 7.3.3)."]
    counts = np.bincount(feats["labels"], minlength=3)
    out.append(f"Sample sizes: H1 has only {counts[1]} units of {BLOCK}, because our moves "
               "last 0.5 s (diagonal) and the 2-s x move meets its wall at 77-78 % of its time, while a "
               "unit is 0.4 s at 250 Hz; the thesis's training data had about 3000 H1 points "
               "(7.3.2). Its normal fit is therefore poorly determined; the check with units of "
               f"{CHECK_BLOCK} shows how much the prediction moves with more, shorter units.")
    if impacts:
        out.append("H3: every impact's y_h rises and then decays roughly linearly in the log "
                   "domain, as in fig 7.3; the fitted decay rates are in the table above.")
    return out
