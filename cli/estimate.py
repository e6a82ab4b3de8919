"""contactlab estimate: per-segment constraint estimation (thesis 8.1.1, 8.2)."""

from __future__ import annotations

import click

from contactlab.cli.common import archive_argument, echo_json, json_option, quiet_option
from contactlab.cli.inputs import checks_archive
from contactlab.constraints.archive import MODELS


@click.command()
@archive_argument
@click.option("--model", type=click.Choice(MODELS), default="cartesian", show_default=True,
              help="Constraint model: Cartesian linear constraints in R^3 (8.1.1), or a "
                   "planar polygon contact (8.1.2-8.1.3; needs position columns x, y, "
                   "theta and wrench columns fx, fy, tz).")
@click.option("--segments", default=None, metavar="truth|auto|STAGE",
              help="Pieces to estimate: ground-truth segments, automatic segmentation "
                   "(7.2.1), or the boundaries_s of a results stage.  [default: truth when "
                   "the trial has it, else auto]")
@click.option("--block", type=click.IntRange(min=7), default=None, metavar="N",
              help="Estimate consecutive blocks of N samples (250 Hz) inside each segment "
                   "(the thesis's degree test uses 25).")
@click.option("--motion", type=click.Choice(["position", "velocity"]), default="position",
              show_default=True, help="Use positions (preferred, 8.1.1) or velocities.")
@click.option("--no-friction", is_flag=True,
              help="Skip the friction compensation filter (8.29).")
@click.option("--trial", "trials", multiple=True, help="Only this trial (repeatable).")
@json_option
@quiet_option
@checks_archive
def estimate(archive, model, segments, block, motion, no_friction, trials, as_json, quiet):
    """Estimate the constraint frame and degree of every segment of ARCHIVE.

    Force (wrench[:, :3]), position and velocity are lowpassed and decimated
    to 250 Hz (7.1); each segment gets the constraint-form estimator
    (8.21-8.28, log-likelihood criterion) after the friction filter (8.29),
    with the degree of constraint chosen by the highest log-likelihood over
    0..3 (8.2).  Pieces with too little motion or force to decide are reported
    as undetermined.  Results go to each trial's results/estimate.

    \b
    Examples:
      contactlab estimate runs.h5
      contactlab estimate runs.h5 --segments auto --json
      contactlab estimate runs.h5 --block 25 --trial cartesian-004 --json
      contactlab estimate planar.h5 --model polygon-B --json
    """
    from contactlab.constraints.archive import estimate_archive

    summary = estimate_archive(archive, model=model, segments=segments, block=block,
                               trials=list(trials) or None, friction=not no_friction,
                               motion=motion, quiet=quiet)
    if as_json:
        echo_json(summary)
        return
    if model != "cartesian":
        _echo_polygon(summary, archive)
        return
    for tid, entry in summary["trials"].items():
        for r in entry["segments"]:
            head = f"{tid} [{_s(r['start_s'])}, {_s(r['end_s'])}] s n={r['n']}"
            if r.get("degree") is None or r.get("status") != "ok":
                click.echo(f"{head}: {r.get('status')} {r.get('reason', '')}".rstrip())
                continue
            nrm = "; ".join("(" + ", ".join(f"{v:+.3f}" for v in n) + ")" for n in r["normals"])
            extra = f", error {r['angle_error_deg']:.2f} deg" if "angle_error_deg" in r else ""
            click.echo(f"{head}: degree {r['degree']} normals [{nrm}] "
                       f"sd {r['angle_sd_deg']:.2f} deg{extra}")
    s = summary["summary"]
    click.echo(f"{s['pieces']} pieces: {s['decided']} decided, {s['undetermined']} "
               f"undetermined, {s['too_short']} too short; results written to {archive} "
               f"(results/estimate)")


def _echo_polygon(summary, archive):
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
