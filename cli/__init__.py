"""The ``contactlab`` command line: one module per verb, each a thin layer
over the library (import name ``contactlab.cli``)."""

from __future__ import annotations

import click

from contactlab import __version__
from contactlab.cli.common import ContactlabGroup, not_available
from contactlab.cli.estimate import estimate
from contactlab.cli.graph import graph
from contactlab.cli.acquire import acquire
from contactlab.cli.import_ import import_cmd
from contactlab.cli.info import info
from contactlab.cli.report import report
from contactlab.cli.reproduce import reproduce
from contactlab.cli.label import label
from contactlab.cli.segment import segment
from contactlab.cli.train import train
from contactlab.cli.validate import validate


@click.group(cls=ContactlabGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--debug", is_flag=True, help="Show tracebacks instead of one-line errors.")
@click.version_option(__version__, prog_name="contactlab")
def main(debug: bool) -> None:
    """Statistical contact sensing over HDF5 trace archives (Eberman 1995).

    \b
    Stages: acquire, segment, label, estimate, recognize, train, report,
    plus validate, import, info and reproduce. Example:
      contactlab reproduce ph-demo --out reports
    """


main.add_command(validate)
main.add_command(info)
main.add_command(import_cmd)
main.add_command(report)
main.add_command(reproduce)
main.add_command(acquire)
main.add_command(segment)
main.add_command(graph)
main.add_command(train)
main.add_command(label)
main.add_command(estimate)
main.add_command(not_available("recognize", "Feature graphs and observer"))
