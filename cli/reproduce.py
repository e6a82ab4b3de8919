"""contactlab reproduce: run thesis experiments and write their reports."""

from __future__ import annotations

from pathlib import Path

import click

from contactlab.cli.common import (echo_json, json_option, parallel_options, quiet_option,
                                   seed_option)
from contactlab.experiments import EXPERIMENTS


@click.command()
@click.argument("names", nargs=-1)
@click.option("--all", "run_all", is_flag=True, help="Run every implemented experiment.")
@click.option("--list", "list_only", is_flag=True, help="List the experiments and their status.")
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), default=Path("reports"),
              show_default=True, help="Directory the reports are written under (out/NAME/).")
@seed_option
@parallel_options("experiments")
@json_option
@quiet_option
def reproduce(names, run_all, list_only, out, seed, workers, scheduler, as_json, quiet):
    """Run thesis experiments end to end; write figures and tables beside the thesis's.

    Each experiment writes OUT/NAME/index.html, report.pdf, results.json and
    its PNG figures; OUT/index.html lists them all. With --json and one
    experiment, the object is that experiment's summary; with several, it is
    {"experiments": {NAME: summary}}.

    The pages committed under reports/ are made in the portable numerics
    environment (make reproduce, or python -m contactlab.portable contactlab
    reproduce ...; contactlab/portable.py), which gives the same numbers on
    x86-64 Linux machines with AVX2 and FMA of any make; run as it is, a
    result that hangs on a near tie (a decision, a contact run) can differ by
    processor.

    \b
    Examples:
      contactlab reproduce --list
      contactlab reproduce ph-demo --out reports --seed 1
      contactlab reproduce ph-demo --json
      contactlab reproduce --all
    """
    if list_only:
        from contactlab.experiments.headlines import HEADLINES

        rows = [{"name": e.name, "title": e.title, "thesis": e.thesis, "status": e.status,
                 "what": HEADLINES.get(e.name, ("", ""))[0],
                 "headline": HEADLINES.get(e.name, ("", ""))[1]}
                for e in EXPERIMENTS.values()]
        if as_json:
            echo_json({"experiments": rows})
        else:
            width = max(len(r["name"]) for r in rows)
            status = max(len(r["status"]) for r in rows)
            for r in rows:
                click.echo(f"{r['name']:<{width}}  {r['status']:<{status}}  {r['thesis']}")
                click.echo(f"    {r['what']}" + (f": {r['headline']}" if r["headline"] else ""))
        return
    from contactlab.experiments.runner import reproduce as run_experiments
    from contactlab.experiments.runner import resolve

    experiments = resolve(list(names), run_all=run_all)
    summaries = run_experiments(experiments, out=out, seed=seed, quiet=quiet, workers=workers,
                                scheduler=scheduler)
    if as_json:
        if len(summaries) == 1:
            (name, summary), = summaries.items()
            echo_json({"name": name, "out_dir": str(out / name), "seed": seed, **summary})
        else:
            echo_json({"out_dir": str(out), "seed": seed, "experiments": summaries})
        return
    for name, summary in summaries.items():
        click.echo(f"{name}: {out / name / 'index.html'} ({summary.get('wall_time_s', 0):.1f} s)")
        if summary.get("headline"):
            click.echo(f"  {summary['headline']}")
    click.echo(f"index: {out / 'index.html'}")
