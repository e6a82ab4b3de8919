"""contactlab label: likelihood labelling of blocks with trained temporal models (7.2.2)."""

from __future__ import annotations

from pathlib import Path

import click

from contactlab.cli.common import (archives_argument, count, echo_summaries, json_option,
                                   json_summaries, parallel_options, quiet_option)
from contactlab.cli.inputs import checks_archive


@click.command()
@archives_argument
@click.option("--models", "models", required=True,
              type=click.Path(dir_okay=False, path_type=Path),
              help="Models file written by 'contactlab train'.")
@click.option("--block", type=int, default=None,
              help="Samples per block [default: the models' training block].")
@click.option("--loo", is_flag=True,
              help="Leave-one-out (7.2.2) instead of using the models as given: "
                   "see --loo-unit.")
@click.option("--loo-unit", type=click.Choice(["trial", "block"]), default="trial",
              show_default=True,
              help="What --loo leaves out: a trial (classes refitted without it) or a "
                   "block (the thesis's sentence: scored under models refitted without it).")
@click.option("--labels", "labels", default=None, metavar="truth|STAGE",
              help="Where blocks and true classes come from [default: as in training].")
@click.option("--trial", "trials", multiple=True, help="Only this trial (repeatable).")
@parallel_options("archives")
@json_option
@quiet_option
@checks_archive
def label(archives, models, block, loo, loo_unit, labels, trials, workers, scheduler, as_json,
          quiet):
    """Label the blocks of each ARCHIVE with the class models in --models.

    Each block is given the class of largest likelihood, with E[Y] = Q S^1/2
    E[k] and V[Y] = Q S^1/2 V[k] (Q S^1/2)^T + V_nu per channel (7.3-7.5),
    channels independent.  Accuracy and the confusion matrix (rows: true
    class) are reported where the archive has ground truth, beside the error
    a normal fit to the blocks' mean log-energy y_h predicts (fig 7.8).
    Results go to each trial's results/label.  Each archive is one unit of
    work (--workers runs several archives at once).

    \b
    Examples:
      contactlab label runs.h5 --models models.h5
      contactlab label runs.h5 --models models.h5 --loo --json
      contactlab label runs.h5 --models models.h5 --loo --loo-unit block
    """
    from contactlab.stages import run_stage
    from contactlab.temporal.label import LabelStage

    if block is not None and block < 1:
        raise click.BadParameter(f"must be >= 1; got {block}", param_hint="'--block'")
    stage = LabelStage(models=models, block=block, loo=loo_unit if loo else False,
                       labels=labels, quiet=quiet)
    summaries = run_stage(stage, archives, trials=list(trials) or None, workers=workers,
                          scheduler=scheduler, quiet=quiet, check_trials=False)  # checked
    if as_json:
        json_summaries(summaries)
        return
    echo_summaries(summaries, _echo)


def _echo(archive, summary):
    for tid, entry in summary["trials"].items():
        acc = entry["accuracy"]
        click.echo(f"{tid}: {count(len(entry['predicted']), 'block')}"
                   + ("" if acc is None else f", {100 * acc:.1f}% correct"))
    if summary["accuracy"] is not None:
        conf = summary["confusion"]
        width = max(len(x) for x in conf["labels"])
        click.echo(f"accuracy {100 * summary['accuracy']:.1f}% over {count(summary['n_blocks'], 'block')}"
                   + (f" (leave-one-{summary['loo']}-out)" if summary["loo"] else ""))
        click.echo("confusion, share of each true class's blocks (rows true, columns chosen):")
        click.echo(f"  {'':{width}} " + " ".join(x.rjust(width) for x in conf["labels"]))
        for name, row in zip(conf["labels"], conf["rates"]):
            cells = " ".join("   -".rjust(width) if v is None or v != v else
                             f"{v:.3f}".rjust(width) for v in row)
            click.echo(f"  {name.rjust(width)} {cells}")
    if summary.get("predicted_error") is not None:
        click.echo(f"log-energy normal fit predicts error {summary['predicted_error']:.3g} "
                   f"(measured with that rule: {summary['log_energy']['measured_error']:.3g})")
    click.echo(f"results written to {archive} (results/label)")
