"""The ``contactlab`` command line: one module per verb, each a thin layer
over the library (import name ``contactlab.cli``)."""

from __future__ import annotations

import os

# The one place matplotlib's backend is chosen: the CLI writes figures to files, so
# it uses Agg unless the user set MPLBACKEND.  The library chooses none at import.
os.environ.setdefault("MPLBACKEND", "Agg")
import copy

import click

from contactlab import __version__
from contactlab.cli.acquire import acquire
from contactlab.cli.common import ContactlabGroup
from contactlab.cli.estimate import estimate
from contactlab.cli.graph import graph
from contactlab.cli.import_ import import_cmd
from contactlab.cli.info import info
from contactlab.cli.label import label
from contactlab.cli.recognize import recognize
from contactlab.cli.report import report
from contactlab.cli.reproduce import reproduce
from contactlab.cli.segment import segment
from contactlab.cli.train import train
from contactlab.cli.validate import validate
from contactlab.cli.watch import watch


@click.group(cls=ContactlabGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--debug", is_flag=True, help="Show tracebacks instead of one-line errors.")
@click.version_option(__version__, prog_name="contactlab")
def main(debug: bool) -> None:
    """Statistical contact sensing over HDF5 trace archives (Eberman 1995).

    \b
    Stages: acquire, segment, label, estimate, recognize (or recognise),
    watch (live), train, report, plus validate, import, info and reproduce. Example:
      contactlab reproduce ph-demo --out reports
    """


# In pipeline order: data in, the analysis stages, then reporting.
for _command in (acquire, import_cmd, validate, info, segment, train, label, estimate,
                 recognize, watch, report, reproduce, graph):
    main.add_command(_command)

# the British spelling of the recognising verb, accepted and not listed
_recognise = copy.copy(recognize)
_recognise.hidden = True
main.add_command(_recognise, name="recognise")
