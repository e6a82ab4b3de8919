"""contactlab estimate: per-segment constraint estimation (thesis 8.1.1, 8.2)."""

from __future__ import annotations

import click

from contactlab.cli.common import (archives_argument, echo_summaries, json_option,
                                   json_summaries, parallel_options, quiet_option)
from contactlab.cli.inputs import checks_archive
from contactlab.constraints.archive import MODELS


@click.command()
@archives_argument
@click.option("--model", type=click.Choice(MODELS), default="cartesian", show_default=True,
              help="Constraint model: Cartesian linear constraints in R^3 (8.1.1), or a "
                   "planar polygon contact (8.1.2-8.1.3; needs position columns x, y, "
                   "theta and wrench columns fx, fy, tz).")
@click.option("--segments", default=None, metavar="truth|auto|STAGE",
              help="Pieces to estimate: ground-truth segments, automatic segmentation "
                   "(7.2.1), or the boundaries_s of a results stage.  [default: truth when "
                   "the trial has it, else auto]")
@click.option("--block", type=click.IntRange(min=7), default=None, metavar="N",
              help="Estimate consecutive blocks of N samples of the conditioned signals "
                   "inside each segment, at the rate nearest 250 Hz an integer decimation "
                   "reaches (250 Hz from 1000 or 500 Hz; a 200 Hz wrist recording keeps "
                   "200 Hz, so a block is N / 200 s; the thesis's degree test uses 25 at "
                   "250 Hz, 0.1 s).")
@click.option("--sequential/--independent", default=True, show_default=True,
              help="With --block: decide each block with every sample of its segment up "
                   "to the block's end (the running estimate; the default, the more "
                   "accurate on the synthetic contact suite), or from the block alone "
                   "(the degree test of 8.2 as the thesis ran it).  The running estimate's "
                   "angle sd adds the spread between the segment's blocks beyond their "
                   "noise (a compliant surface, a creeping frame; "
                   "contactlab.constraints.dispersion).")
@click.option("--motion", type=click.Choice(["position", "velocity"]), default="position",
              show_default=True, help="Use positions (preferred, 8.1.1) or velocities.")
@click.option("--position-noise", type=click.FloatRange(min=0, min_open=True), default=None,
              metavar="M", help="Position measurement noise (m, sd per axis, raw rate).  "
                                "[default: estimated from each trial's data]")
@click.option("--force-noise", type=click.FloatRange(min=0, min_open=True), default=None,
              metavar="N", help="Force measurement noise (N, sd per axis, raw rate).  "
                                "[default: estimated from each trial's data]")
@click.option("--compliance/--rigid", default=True, show_default=True,
              help="Estimate each plane's and edge's compliance (its penetration following "
                   "the pressing force, m/N) with its frame, and with --block a frame that "
                   "turns (printed as 'turned', from the segment's average frame to the "
                   "block's), and widen the angle sd by their uncertainty; the compliance is "
                   "positive where the position gives way against the measured force (a "
                   "sensor reading the surface's reaction on the tool), negative for a sensor "
                   "reading the force the tool applies "
                   "(contactlab.constraints.compliance; beyond the thesis); or fit the rigid "
                   "constraint form as the thesis wrote it.")
@click.option("--no-friction", is_flag=True,
              help="Skip the friction compensation filter (8.29).")
@click.option("--trial", "trials", multiple=True, help="Only this trial (repeatable).")
@parallel_options("trials")
@json_option
@quiet_option
@checks_archive(values=False, walk_trials=False)   # run_stage checks each trial
def estimate(archives, model, segments, block, sequential, motion, position_noise,
             force_noise, compliance, no_friction, trials, workers, scheduler, as_json, quiet):
    """Estimate the constraint frame and degree of every segment of each ARCHIVE.

    Force (wrench[:, :3]), position and velocity are lowpassed and decimated
    to 250 Hz (7.1; other rates to the rate nearest 250 Hz an integer factor
    reaches); each segment gets the constraint-form estimator
    (8.21-8.28, log-likelihood criterion) after the friction filter (8.29),
    with the degree of constraint chosen by the highest log-likelihood over
    0..3 (8.2).  Pieces with too little motion or force to decide are reported
    as undetermined.  A plane's or edge's compliance is estimated with its
    frame (--rigid: not).  Units are normalised by the measurement noise (8.7-8.9),
    which is estimated from each trial's own data (the spread of second
    differences, never below the quantisation step) unless given.  The
    summary counts undetermined pieces as undecided and reports angle errors
    per true degree.  Results go to each trial's results/estimate.

    \b
    Examples:
      contactlab estimate runs.h5
      contactlab estimate runs.h5 --segments auto --json
      contactlab estimate runs.h5 --block 25 --trial cartesian-004 --json
      contactlab estimate runs.h5 --block 25 --independent
      contactlab estimate runs.h5 --position-noise 1e-5 --force-noise 0.01
      contactlab estimate runs.h5 --motion velocity --no-friction
      contactlab estimate runs.h5 --block 25 --rigid

    The polygon models (--model polygon-B, ...) need a planar archive: position
    columns x, y, theta and wrench columns fx, fy, tz ('contactlab import'
    with --columns "time=t;position=x,y,theta;wrench=fx,fy,fz,tx,ty,tz").
    """
    from contactlab.constraints.archive import EstimateStage
    from contactlab.stages import run_stage

    stage = EstimateStage(model=model, segments=segments, block=block,
                          friction=not no_friction, motion=motion,
                          position_sd=position_noise, force_sd=force_noise,
                          sequential=sequential, compliance=compliance)
    summaries = run_stage(stage, archives, trials=list(trials) or None, workers=workers,
                          scheduler=scheduler, quiet=quiet)
    if as_json:
        json_summaries(summaries)
        return
    echo_summaries(summaries, _echo_polygon if model != "cartesian" else _echo_cartesian)


def _echo_cartesian(archive, summary):
    for tid, entry in summary["trials"].items():
        for r in entry["segments"]:
            head = f"{tid} [{_s(r['start_s'])}, {_s(r['end_s'])}] s n={r['n']}"
            if r.get("degree") is None or r.get("status") != "ok":
                click.echo(f"{head}: {r.get('status')} {r.get('reason', '')}".rstrip())
                continue
            nrm = "; ".join("(" + ", ".join(f"{v:+.3f}" for v in n) + ")" for n in r["normals"])
            extra = ""
            if "compliance_m_per_n" in r:
                extra += (f", compliance {r['compliance_m_per_n'] * 1e3:.3f} +- "
                          f"{r['compliance_sd_m_per_n'] * 1e3:.3f} mm/N")
            if "turn_deg" in r:
                extra += f", turned {r['turn_deg']:.2f} deg"
            if "angle_error_deg" in r:
                extra += f", error {r['angle_error_deg']:.2f} deg"
            click.echo(f"{head}: degree {r['degree']} normals [{nrm}] "
                       f"sd {r['angle_sd_deg']:.2f} deg{extra}")
    s = summary["summary"]
    click.echo(f"{s['pieces']} pieces: {s['decided']} decided, {s['undetermined']} "
               f"undetermined, {s['too_short']} too short; results written to {archive} "
               f"(results/estimate)")
    if s.get("degree_correct") is not None:            # the archive has the true degrees
        per = []
        for m, e in s["per_true_degree"].items():
            text = f"degree {m}: {e['right']} right, {e['wrong']} wrong, {e['undecided']} undecided"
            if "angle_within_2sd" in e:
                text += (f", median angle error {e['median_angle_error_deg']:.2f} deg, "
                         f"{100 * e['angle_within_2sd']:.0f} % within 2 sd")
            per.append(text)
        click.echo(f"against the truth: degree right on {100 * s['degree_correct']:.1f} % of "
                   f"pieces; " + "; ".join(per))


def _echo_polygon(archive, summary):
    for tid, entry in summary["trials"].items():
        for r in entry["segments"]:
            head = f"{tid} [{_s(r['start_s'])}, {_s(r['end_s'])}] s n={r['n']}"
            if r["status"] != "ok":
                click.echo(f"{head}: {r['status']} {r.get('reason', '')}".rstrip())
                continue
            par = ", ".join(f"{k} {v:.4g} +- {r['standard_errors'].get(k) or float('nan'):.2g}"
                            for k, v in r["parameters"].items() if v is not None)
            click.echo(f"{head}: {r['kind']} {par} ({r['iterations']} iterations)")
    s = summary["summary"]
    click.echo(f"{s['pieces']} pieces: {s['decided']} estimated, {s['undetermined']} "
               f"undetermined; results written to {archive} (results/estimate)")


def _s(v):
    return "-" if v is None else f"{v:.3f}"
