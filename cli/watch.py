"""contactlab watch: the 6.4 observer on a live source, one JSON object per line."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import click

from contactlab import defaults as D
from contactlab.cli.import_ import ColumnMap


@click.command()
@click.option("--source", "source_text", required=True, metavar="SOURCE",
              help="sim:SPEC (the simulator, the spec's trials one after another), "
                   "netft:HOST[:PORT], phantom, - (CSV lines on standard input: a header, "
                   "then rows) or csv:PATH (a file or named pipe).")
@click.option("--graph", "graph_file", required=True, metavar="GRAPH",
              type=click.Path(dir_okay=False, path_type=Path),
              help="Feature-graph TOML file or bundled name (as for recognize).")
@click.option("--models", "models_file", required=True, metavar="MODELS",
              type=click.Path(dir_okay=False, path_type=Path),
              help="Models file from 'contactlab train --graph'.")
@click.option("--columns", "-c", type=ColumnMap(), default=None,
              help="CSV sources: FIELD=COL[,COL...] entries separated by ';' as for import "
                   "(time is required; strain, wrench, position, velocity, action).")
@click.option("--rate", "rate_hz", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Input rate, Hz [default: CSV, 1 / median step of the first rows; "
                   "hardware, 1000].")
@click.option("--chunk", type=click.IntRange(min=1), default=40, show_default=True,
              help="Input rows per step of the simulator and the CSV reader (40 rows: "
                   "40 ms at 1000 Hz, 10 conditioned samples).")
@click.option("--realtime/--no-realtime", default=True, show_default=True,
              help="sim: release the rows at the recorded pace, or as fast as they are "
                   "taken.")
@click.option("--trials", "n_trials", type=click.IntRange(min=1), default=None,
              help="sim: trials to run [default: the spec's count]; hardware: recordings "
                   "(reconnections) at most.")
@click.option("--seed", type=int, default=1, show_default=True, help="sim: the run seed.")
@click.option("--duration", "duration_s", type=click.FloatRange(min=0, min_open=True),
              default=3600.0, show_default=True, help="Hardware: length of a recording, s.")
@click.option("--probs-every", type=click.FloatRange(min=0), default=0.0, show_default=True,
              metavar="S", help="Print the node probabilities every S seconds of data "
                                "(0: never).")
@click.option("--action", default=None, metavar="A",
              help="Commanded action for every sample (action-dependent graphs), "
                   "overriding the source's action channel or command.")
@click.option("--threshold", type=float, default=D.OBSERVER_THRESHOLD, show_default=True,
              help="Page-Hinkley decision threshold T^2 (7.3.1).")
@click.option("--record", type=click.Path(dir_okay=False, path_type=Path), default=None,
              metavar="ARCHIVE", help="Also write what was seen, with the recognition "
                                      "results (results/recognize), to this archive.")
@click.option("--force", is_flag=True, help="Replace the --record archive if it exists.")
def watch(source_text, graph_file, models_file, columns, rate_hz, chunk, realtime, n_trials,
          seed, duration_s, probs_every, action, threshold, record, force):
    """Recognise the contact state of a live source as it runs (the observer of 6.4).

    Prints one JSON object per line on stdout, flushed as written: each
    change of the most probable node ("event": "change": time, node, its
    probability, the estimated change time, the detection delay and the
    latency from the rows' arrival), the node probabilities every
    --probs-every seconds ("probs"), each recording's final path ("path";
    it may revise changes printed live, and says so) and a summary at the
    end of the input. The final path equals what 'recognize' gives on the
    --record archive.

    \b
    Examples:
      contactlab watch --source sim:hf-test --trials 1 --no-realtime \\
          --graph hf-context --models graph-models.h5
      contactlab watch --source csv:wrist.csv --graph free-contact --models fc-models.h5 \\
          --columns "time=t;wrench=fx,fy,fz,tx,ty,tz;position=x,y,z" --record watched.h5
      contactlab watch --source netft:192.168.1.1 --graph my-wrench-graph.toml \\
          --models m.h5

    \b
    Any robot can pipe its log in (CSV with a header, time from the data):
      robot_log | contactlab watch --source - --graph free-contact --models m.h5 \\
          --columns "time=t;wrench=fx,fy,fz,tx,ty,tz;position=x,y,z"

    A graph whose models read a signal the source lacks (a Net F/T alone
    has no position or strains) is refused. A malformed CSV line or a
    stalled stream gives one line on stderr; a Net F/T that stops or drops
    the connection is reconnected (a new recording). Ctrl-C ends the run:
    the recording in progress is kept in the --record archive with its
    results.
    """
    from contactlab.errors import UsageError
    from contactlab.live.sources import open_source
    from contactlab.live.watch import watch as run
    from contactlab.observer.recognize import RecognizeStage

    if not threshold > 0:
        raise click.BadParameter(f"must be > 0; got {threshold}", param_hint="'--threshold'")
    if force and record is None:
        raise click.UsageError("--force goes with --record")
    if record is not None and record.exists() and not force:
        raise UsageError(f"{record} exists (--force replaces it)")
    act = int(action) if action is not None and action.lstrip("-").isdigit() else action
    stage = RecognizeStage(graph=graph_file, models=models_file, action=act,
                           threshold=threshold, write=False)
    if act is not None:
        try:
            stage.graph.action_index(act)
        except KeyError as exc:
            raise click.BadParameter(str(exc.args[0]), param_hint="'--action'") from None
    source = open_source(source_text, chunk=chunk, realtime=realtime, trials=n_trials,
                         seed=seed, duration_s=duration_s, rate_hz=rate_hz, columns=columns,
                         stdin=sys.stdin)
    _check_signals(stage, source)

    def emit(obj: dict) -> None:
        sys.stdout.write(json.dumps(obj) + "\n")
        sys.stdout.flush()

    run(source, stage, emit=emit, probs_every=probs_every or None, record=record, force=force)


def _check_signals(stage, source) -> None:
    """Refuse, in one line, a graph whose models read a signal the source lacks."""
    from contactlab.live.conditioner import LiveConditioner
    from contactlab.observer.observer import Observer

    from contactlab.observer.recognize import observer_keywords

    obs = Observer(stage.graph, stage.built, **observer_keywords(stage.observer_kw, 250.0))
    LiveConditioner(obs.signals, rate_hz=1000.0, fields=source.fields,
                    reduce=stage.models.reduce,
                    source=f"--source {source.name}")
