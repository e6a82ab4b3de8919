"""contactlab segment: change-detector segmentation of strains or forces (7.2.1)."""

from __future__ import annotations

import click

from contactlab import defaults as D

from contactlab.cli.common import (archives_argument, count, echo_summaries, json_option,
                                   json_summaries, parallel_options, quiet_option)
from contactlab.cli.inputs import checks_archive
from contactlab.detection.level_shift import LEVEL_DEFAULTS


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
@archives_argument
@click.option("--signal", type=click.Choice(["strain", "wrench", "hf"]), default=None,
              help="Signal to segment after 7.1 conditioning: 250 Hz strains, 250 Hz "
                   "wrench, or the high-frequency log-energy.  [default: strain when the "
                   "trial has strain gauges, else wrench]")
@click.option("--order", type=int, default=D.SEGMENT_ORDER, show_default=True,
              help="AR order of every channel's square-root estimator.")
@click.option("--method", type=click.Choice(["auto", "glr", "page-hinkley", "level"]),
              default=D.SEGMENT_METHOD, show_default=True,
              help="auto: level on a wrench, glr on strains (the --json entry of each "
                   "trial names the one run); glr: two-model AR likelihood-ratio test (finds "
                   "changes of the AR coefficients as well as of the level; the most "
                   "accurate on the synthetic strain suite); page-hinkley: the thesis's "
                   "sequential test of the innovations' size (fig 7.6); level: changes "
                   "of the force level of a wrist sensor (contact made and broken, phases "
                   "that press harder), excursions inside a phase reported apart as events.")
@click.option("--threshold", type=float, default=None,
              help="Decision threshold: for glr the likelihood ratio per degree of freedom "
                   f"(default {D.GLR_THRESHOLD:g}, the best on the benchmark suite); for "
                   f"page-hinkley T^2 (default {D.SEGMENT_THRESHOLD:g}, the thesis's); for "
                   "level the share of the recording's largest level changes a change must "
                   f"reach (default {LEVEL_DEFAULTS['fraction']:g}, the best on wrist "
                   "recordings of other groups).")
@click.option("--window", "window_s", type=float, default=None, metavar="SECONDS",
              help="glr and level: seconds of signal on each side of a candidate change "
                   f"(default glr {D.GLR_WINDOW_S:g}, the best on the benchmark suite; "
                   f"level {LEVEL_DEFAULTS['window_s']:g}).")
@click.option("--sweep", "sweep_values", callback=_thresholds, default=None,
              metavar="T1,T2,...",
              help="Segment at each threshold (fig 7.7); prints, writes nothing.  The "
                   "level test's thresholds are shares of the largest level changes, in "
                   "(0, 1].")
@click.option("--change-size", type=float, default=D.CHANGE_SIZE, show_default=True,
              help="page-hinkley only: covariance change q tested up (q) and down (1/q).")
@click.option("--combine", type=click.Choice(["sum", "channel"]), default="sum",
              show_default=True,
              help="page-hinkley only: sum: the thesis's one chi-square test over all channels; channel: one "
                   "Page-Hinkley test per channel, a change when any fires (finds changes "
                   "confined to a few channels; beyond the thesis).")
@click.option("--tolerance", type=float, default=D.TOLERANCE_S, show_default=True,
              help="Seconds within which a boundary matches the ground truth.")
@click.option("--label-map", "label_map", default=None, metavar="L=STATE,...",
              help="Score against the labels' states: labels mapped to one state are one "
                   "segment (e.g. \"1=free,2=contact,3=free,4=contact\"); unmapped labels "
                   "are unlabelled, and boundaries found there are not scored.")
@click.option("--trial", "trials", multiple=True, help="Only this trial (repeatable).")
@click.option("--no-write", is_flag=True,
              help="Compute and print the boundaries, but do not write results/segment.")
@parallel_options("trials")
@json_option
@quiet_option
@checks_archive(values=False, walk_trials=False)   # run_stage checks each trial
def segment(archives, signal, order, method, threshold, window_s, sweep_values, change_size,
            combine, tolerance, label_map, trials, no_write, workers, scheduler, as_json,
            quiet):
    """Segment every trial of each ARCHIVE into stretches of one AR model per channel.

    Default (--method glr): per channel an AR model with a mean; at every
    sample the likelihood of one model against two (before and after) over
    --window seconds each side, summed over channels; peaks above the
    threshold are changes, each placed at its most likely sample between its
    neighbours.  Finds changes of the AR coefficients as well as of the level.
    The defaults are the best settings found on the synthetic benchmark suite
    (piecewise AR with level-only, coefficient-only and mixed changes, 1 kHz;
    make bench): chosen on its seed 1 and confirmed on the held-out seeds 2-5,
    where they find every change within 50 ms (F1 1.00 on each).

    --method page-hinkley is the thesis's detector (7.2.1, fig 7.6): per
    channel a square-root AR estimator; the sum of squared normalised
    innovations (chi-square) into a two-sided Page-Hinkley test for a change
    of covariance size; estimators and detector restart after each change.
    It sees changes of the innovations' size only.  With --combine channel
    each channel gets its own two-sided test (same change size and
    threshold) and the first to fire restarts all; the firing channel is
    reported as alarm_channels.

    --method level (what auto runs on a wrench: a wrist sensor without
    strain gauges) finds the changes of the force level a person marks:
    the force lowpassed at 2 Hz (zero phase); the difference of its means
    over 0.5 s before and after each sample; peaks above 40 % of the
    recording's largest such differences (and at least 0.5 N and 10 times
    the sensor noise) are changes; each is placed where the force leaves
    (or regains) the level nearer free space, so a touch-down is marked at
    the ramp's start and a lift-off at its end.  A dip or bump inside a
    phase that returns to its level within 2.5 s is an event, listed apart
    (events_s), not two boundaries.  On wrist recordings of other groups
    (wiping, snap-fit assembly) it found the labelled contact and phase
    changes with F1 0.89 within 0.25 s (README).

    Boundaries (the first sample of each new segment, s), change-time
    estimates and alarm times are written to each trial's results/segment
    (never over the measurements).
    Where the archive has ground-truth segments, boundary precision, recall
    and F1 within --tolerance are reported (ruptures' metric).

    \b
    Examples:
      contactlab segment runs.h5
      contactlab segment runs.h5 --signal wrench --json
      contactlab segment runs.h5 --no-write
      contactlab segment runs.h5 --trial stroke-a-000 --sweep 2,3,5,8
      contactlab segment wrist.h5 --sweep 0.2,0.4,0.6
      contactlab segment runs.h5 --method page-hinkley --threshold 100
      contactlab segment runs.h5 --method page-hinkley --combine channel --threshold 50
      contactlab segment runs.h5 --workers 2
      contactlab segment wrist.h5 --tolerance 0.25 --json
    """
    from contactlab.segmentation import SegmentStage
    from contactlab.stages import run_stage

    source = click.get_current_context().get_parameter_source("threshold")
    if sweep_values is not None and source is not click.core.ParameterSource.DEFAULT:
        raise click.UsageError("give --threshold or --sweep, not both")
    if order < 1:
        raise click.BadParameter(f"must be >= 1; got {order}", param_hint="'--order'")
    if not change_size > 1:
        raise click.BadParameter(f"must be > 1; got {change_size}", param_hint="'--change-size'")
    if not tolerance > 0:
        raise click.BadParameter(f"must be > 0; got {tolerance}", param_hint="'--tolerance'")
    ctx = click.get_current_context()
    if method != "page-hinkley":
        for name in ("combine", "change_size"):
            if ctx.get_parameter_source(name) is not click.core.ParameterSource.DEFAULT:
                flag = "--" + name.replace("_", "-")
                raise click.UsageError(f"{flag} belongs to --method page-hinkley")
    elif window_s is not None:
        raise click.UsageError("--window belongs to --method glr or level")
    from contactlab.observer.kinematics import parse_label_map

    lmap = parse_label_map(label_map)
    if threshold is not None and not threshold > 0:
        raise click.BadParameter(f"must be > 0; got {threshold}", param_hint="'--threshold'")
    if window_s is not None and not window_s > 0:
        raise click.BadParameter(f"must be > 0; got {window_s}", param_hint="'--window'")
    stage = SegmentStage(signal=signal, order=order, threshold=threshold,
                         thresholds=sweep_values, change_size=change_size, combine=combine,
                         tolerance_s=tolerance, method=method, window_s=window_s,
                         label_map=lmap, write=not no_write)
    summaries = run_stage(stage, archives, trials=list(trials) or None, workers=workers,
                          scheduler=scheduler, quiet=quiet)
    for summary in summaries.values():
        for line in summary.get("notes", []):
            click.echo(f"note: {line}", err=True)
    if as_json:
        json_summaries(summaries)
        return
    echo_summaries(summaries, lambda archive, summary: _echo(archive, summary, sweep_values,
                                                             written=stage.write))


def _echo(archive, summary, sweep_values, written=True):
    for tid, entry in summary["trials"].items():
        if sweep_values is None:
            bs = ", ".join(f"{b:.3f}" for b in entry["boundaries_s"])
            line = (f"{tid}: {count(len(entry['boundaries_s']), 'boundary', 'boundaries')} "
                    f"[{bs}] s ({entry.get('method', 'page-hinkley')})")
            if entry.get("events_s"):
                ev = ", ".join(f"{e:.3f}" for e in entry["events_s"])
                line += f"; {count(len(entry['events_s']), 'event')} inside a phase [{ev}] s"
            click.echo(line)
        else:
            for t, e in entry["sweep"].items():
                bs = ", ".join(f"{b:.3f}" for b in e["boundaries_s"])
                click.echo(f"{tid}: threshold {t}: {count(len(e['boundaries_s']), 'boundary', 'boundaries')} "
                           f"[{bs}] s")
    m = summary.get("metrics")
    if m:
        for key, val in m.items():
            if isinstance(val, dict) and val.get("f1") is not None:
                click.echo(f"{key}: precision {val['precision']:.2f} recall {val['recall']:.2f} "
                           f"F1 {val['f1']:.2f} within {val['tolerance_s']} s")
    if written:
        click.echo(f"results written to {archive} (results/segment)")
