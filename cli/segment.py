"""contactlab segment: change-detector segmentation of strains or forces (7.2.1)."""

from __future__ import annotations

import click

from contactlab.cli.common import archive_argument, echo_json, json_option, quiet_option
from contactlab.cli.inputs import checks_archive


def _thresholds(ctx, param, value):
    if value is None:
        return None
    try:
        out = [float(v) for v in value.split(",") if v.strip()]
    except ValueError:
        raise click.BadParameter(f"expected comma-separated numbers; got {value!r}") from None
    if not out or any(not (t > 0) for t in out):
        raise click.BadParameter(f"expected numbers > 0; got {value!r}")
    return out


@click.command()
@archive_argument
@click.option("--signal", type=click.Choice(["strain", "wrench", "hf"]), default="strain",
              show_default=True,
              help="Signal to segment after 7.1 conditioning: 250 Hz strains, 250 Hz "
                   "wrench, or the high-frequency log-energy.")
@click.option("--order", type=int, default=2, show_default=True,
              help="AR order of every channel's square-root estimator.")
@click.option("--threshold", type=float, default=200.0, show_default=True,
              help="Page-Hinkley decision threshold T^2.")
@click.option("--sweep", "sweep_values", callback=_thresholds, default=None,
              metavar="T1,T2,...",
              help="Segment at each threshold (fig 7.7); prints, writes nothing.")
@click.option("--change-size", type=float, default=2.5, show_default=True,
              help="Covariance change q tested up (q) and down (1/q).")
@click.option("--combine", type=click.Choice(["sum", "channel"]), default="sum",
              show_default=True,
              help="sum: the thesis's one chi-square test over all channels; channel: one "
                   "Page-Hinkley test per channel, a change when any fires (finds changes "
                   "confined to a few channels; beyond the thesis).")
@click.option("--tolerance", type=float, default=0.1, show_default=True,
              help="Seconds within which a boundary matches the ground truth.")
@click.option("--trial", "trials", multiple=True, help="Only this trial (repeatable).")
@json_option
@quiet_option
@checks_archive
def segment(archive, signal, order, threshold, sweep_values, change_size, combine, tolerance,
            trials, as_json, quiet):
    """Segment every trial of ARCHIVE with the AR + Page-Hinkley detector of 7.2.1.

    Per channel a square-root AR estimator; the sum of squared normalised
    innovations (chi-square) into a two-sided Page-Hinkley test for a change
    of covariance size; estimators and detector restart after each change.
    Boundaries (the first sample of each new segment, s), the detector's
    change-time estimates and alarm times are written to each trial's
    results/segment (never over the measurements).
    With --combine channel each channel gets its own two-sided test (same
    change size and threshold) and the first to fire restarts all; the firing
    channel is reported as alarm_channels.
    Where the archive has ground-truth segments, boundary precision, recall
    and F1 within --tolerance are reported (ruptures' metric).

    \b
    Examples:
      contactlab segment runs.h5
      contactlab segment runs.h5 --signal wrench --threshold 100 --json
      contactlab segment runs.h5 --trial stroke-a-000 --sweep 50,100,200,400
      contactlab segment runs.h5 --combine channel --threshold 50 --json
    """
    from contactlab.segmentation import run_archive

    source = click.get_current_context().get_parameter_source("threshold")
    if sweep_values is not None and source is not click.core.ParameterSource.DEFAULT:
        raise click.UsageError("give --threshold or --sweep, not both")
    if order < 1:
        raise click.BadParameter(f"must be >= 1; got {order}", param_hint="'--order'")
    if not change_size > 1:
        raise click.BadParameter(f"must be > 1; got {change_size}", param_hint="'--change-size'")
    if not tolerance > 0:
        raise click.BadParameter(f"must be > 0; got {tolerance}", param_hint="'--tolerance'")
    if not threshold > 0:
        raise click.BadParameter(f"must be > 0; got {threshold}", param_hint="'--threshold'")
    summary = run_archive(archive, signal=signal, order=order, threshold=threshold,
                          thresholds=sweep_values, change_size=change_size,
                          combine=combine, tolerance_s=tolerance, trials=list(trials) or None,
                          quiet=quiet)
    if as_json:
        echo_json(summary)
        return
    for tid, entry in summary["trials"].items():
        if sweep_values is None:
            bs = ", ".join(f"{b:.3f}" for b in entry["boundaries_s"])
            click.echo(f"{tid}: {len(entry['boundaries_s'])} boundaries [{bs}] s")
        else:
            for t, e in entry["sweep"].items():
                bs = ", ".join(f"{b:.3f}" for b in e["boundaries_s"])
                click.echo(f"{tid}: threshold {t}: {len(e['boundaries_s'])} boundaries [{bs}] s")
    m = summary.get("metrics")
    if m:
        for key, val in m.items():
            if isinstance(val, dict) and val.get("f1") is not None:
                click.echo(f"{key}: precision {val['precision']:.2f} recall {val['recall']:.2f} "
                           f"F1 {val['f1']:.2f} within {val['tolerance_s']} s")
    if sweep_values is None:
        click.echo(f"results written to {archive} (results/segment)")
