"""contactlab recognize: the 6.4 contact-state observer over an archive (7.3.1-7.3.3)."""

from __future__ import annotations

from pathlib import Path

import click

from contactlab import defaults as D

from contactlab.cli.common import (archives_argument, echo_summaries, json_option,
                                   json_summaries, parallel_options, quiet_option)
from contactlab.cli.inputs import checks_archive


@click.command()
@archives_argument
@click.option("--graph", "graph_file", required=True, metavar="GRAPH",
              type=click.Path(dir_okay=False, path_type=Path),
              help="Feature-graph TOML file (datasets_spec/GRAPHS.md).")
@click.option("--models", "models_file", required=True, metavar="MODELS",
              type=click.Path(dir_okay=False, path_type=Path),
              help="Models file from 'contactlab train --graph' (datasets_spec/MODELS.md).")
@click.option("--action", default=None, metavar="A",
              help="Commanded action (name or code) for every sample, overriding the "
                   "archive's action channel (action-dependent graphs).")
@click.option("--threshold", type=float, default=D.OBSERVER_THRESHOLD, show_default=True,
              help="Page-Hinkley decision threshold T^2 (7.3.1).")
@click.option("--change-size", type=float, default=D.OBSERVER_CHANGE_SIZE, show_default=True,
              help="Change magnitude q of the detectors (7.3.1).")
@click.option("--prune", "p_prune", type=float, default=None,
              help="Probability mass P_prune kept when pruning paths (6.4); 1 keeps every path "
                   "within --gap.  [default: the graph's 'p_prune', else "
                   f"{D.OBSERVER_PRUNE}]")
@click.option("--gap", type=float, default=D.OBSERVER_GAP, show_default=True,
              help="Drop paths this far below the best log-likelihood (9.1.1).")
@click.option("--sides", type=click.Choice(list(D.OBSERVER_SIDE_CHOICES)), default=None,
              help="Detector tests on each model's innovations: 'increase' (the thesis's "
                   "covariance increase, 6.14), 'both' (and a decrease), 'mean' (the "
                   "increase plus a two-sided mean change of sqrt(q-1) sd), 'all'.  "
                   f"[default: the graph's 'sides', else {D.OBSERVER_SIDES}]")
@click.option("--transitions", type=click.Choice(list(D.OBSERVER_TRANSITION_CHOICES)),
              default=D.OBSERVER_TRANSITIONS, show_default=True,
              help="'graph': a successor starts from its predecessor's log-likelihood plus "
                   "log p of the edge, where the graph's edge sets give probabilities (a "
                   "forward projection's or EM's), else, where the graph's change_prior is "
                   "'trained' (the default; the thesis's graphs say 'none'), log(h / R): h "
                   "the node's rate of labelled changes in the models' training, R its other "
                   "successors, as a supervised HMM counts them; 'none': every allowed "
                   "transition alike, as in 6.4.  A graph's trained start (initial = "
                   "'trained') applies either way.")
@click.option("--transient-max", "transient_max", type=float, default=None,
              metavar="SECONDS",
              help="The longest a path stays in a transient (impact) node; then the samples "
                   "after go to the node's successors, as after a detected change.  0: no "
                   "limit (6.4 as written).  [default: per transient node, its longest "
                   "labelled run in the trials the models were trained on; where training "
                   f"had none, {D.OBSERVER_TRANSIENT_MAX_S:g} s, a stated default about twice "
                   "the longest impact labelled in the simulated hf training runs]")
@click.option("--payload/--no-payload", "payload", default=True, show_default=True,
              help="On a trial with the tool's orientation, fit the payload's weight and "
                   "the sensor's offset to the free space a first pass finds and recognise "
                   "again on the corrected force (see below).")
@click.option("--label-map", "label_map", default=None, metavar="L=NODE,...",
              help="Map the archive's labels onto node names for the accuracy "
                   "[default: the map the models were trained with].")
@click.option("--trial", "trials", multiple=True, help="Only this trial (repeatable).")
@click.option("--explain", "explain", default=None, metavar="TRIAL",
              help="Explain the recognition of one trial instead (nothing written): per true "
                   "transition, what each detector of the path's models did at the change, "
                   "the hypotheses started and pruned (and why), and how well each node's "
                   "model explains the 0.25 s after it; and how the models alone label the "
                   "true segments.  Needs ground truth named like the graph's nodes.")
@click.option("--no-write", is_flag=True, help="Do not write results/recognize.")
@click.option("--csv", "csv_out", default=None, metavar="OUT.csv",
              type=click.Path(dir_okay=False, path_type=Path),
              help="Also write the recognised path as CSV for other tools: OUT.csv, one row "
                   "per sample (trial, time_s, node, node_prob, p_<node>...), and "
                   "OUT-boundaries.csv, one row per change of node (trial, time_s, from, to).")
@click.option("--force", is_flag=True, help="Replace the --csv files if they exist.")
@parallel_options("trials")
@json_option
@quiet_option
@checks_archive(values=False)   # the layout up front; each trial's values where it runs
def recognize(archives, graph_file, models_file, action, threshold, change_size, p_prune, gap,
              sides, transitions, transient_max, payload, label_map, trials, explain, no_write,
              csv_out, force, workers, scheduler, as_json, quiet):
    """Recognise the contact state of every trial of each ARCHIVE along a feature graph.

    Per trial the observer of 6.4 runs over the graph's signals; the
    per-sample node probabilities, the on-line MAP node, the final MAP path
    with its event times and the change history are written to each
    trial's results/recognize.  With ground truth named like the graph's
    nodes: the point-level confusion matrix and accuracy of the MAP path,
    and the table of detection delays (7.3.2).

    \b
    Examples:
      contactlab train train.h5 --graph datasets_spec/graphs/hf-context-free.toml \\
          --out graph-models.h5
      contactlab recognize test.h5 --graph datasets_spec/graphs/hf-context-free.toml \\
          --models graph-models.h5
      contactlab recognize test.h5 --graph datasets_spec/graphs/hf-context.toml \\
          --models graph-models.h5 --json
      contactlab recognize wrist.h5 --graph free-contact --models fc-models.h5 --json
      contactlab recognize wrist.h5 --graph free-contact --models fc-models.h5 \\
          --no-write --no-payload
      contactlab recognize wrist.h5 --graph free-contact --models fc-models.h5 \\
          --no-write --csv wrist-path.csv
      contactlab recognize test.h5 --graph datasets_spec/graphs/hf-context-free.toml \\
          --models graph-models.h5 --explain hf-000

    The defaults (T^2 8, q 2, the covariance-increase test plus a two-sided
    mean test) are the best settings found on the switching benchmark suite
    (benchmarks/bench_observer.py), where they match a supervised HMM on
    fixed-parameter data and beat it when parameters change per segment.

    A trial whose measurements fit none of the graph's models (mean
    chi-square per degree of freedom of the recognised path's innovations
    above 8; about 1 when they fit: a recording noisier than the training
    data, an unzeroed force sensor) gets a one-line warning on stderr and
    "misfit": true under trials.ID.fit in --json.  A trial's n_changes counts
    the changes its detectors reported (every alarm the observer acted on, not
    the recognised path's changes, which merged_path lists).

    A wrist sensor in a turning tool reads the tool's weight turning in its
    axes: on a trial with the tool's orientation (import with orientation or
    rpy, either wrench frame) and a graph with a free-space node on the
    contact signals, the weight (base frame) and the sensor's offset (sensor
    axes) are fitted to the free space the first pass finds (at least 0.5 s),
    and the trial is recognised again on the force less them, while the free
    space found grows (up to four passes).  A pass is kept only when its path
    is likelier by more than BIC's 3 log n for the six parameters.  The text
    output prints the fit under the trial; --json gives trials.ID.payload and
    trials.ID.payload_status (why it was or was not applied); --no-payload
    recognises once, as recorded.

    Train the models first ('contactlab train --graph' on labelled runs, with
    labels named like the graph's models' 'trained' labels); the context
    graph's action-dependent edges read the archive's action channel, or
    --action.  'contactlab recognise' is the same command.
    """
    from contactlab.observer.recognize import RecognizeStage
    from contactlab.stages import run_stage

    if not (threshold > 0):
        raise click.BadParameter(f"must be > 0; got {threshold}", param_hint="'--threshold'")
    if not change_size > 1:
        raise click.BadParameter(f"must be > 1; got {change_size}", param_hint="'--change-size'")
    if p_prune is not None and not 0 < p_prune <= 1:
        raise click.BadParameter(f"must be in (0, 1]; got {p_prune}", param_hint="'--prune'")
    if not gap > 0:
        raise click.BadParameter(f"must be > 0; got {gap}", param_hint="'--gap'")
    if transient_max is not None and not transient_max >= 0:
        raise click.BadParameter(f"must be >= 0; got {transient_max}",
                                 param_hint="'--transient-max'")
    act = action
    if action is not None and action.lstrip("-").isdigit():
        act = int(action)
    from contactlab.observer.graph import load_graph

    g = load_graph(graph_file)
    if act is not None:
        try:
            g.action_index(act)
        except KeyError as exc:
            raise click.BadParameter(str(exc.args[0]), param_hint="'--action'") from None
    from contactlab.observer.kinematics import check_label_map, parse_label_map

    lmap = parse_label_map(label_map)
    check_label_map(lmap, g)
    if csv_out is not None:
        from contactlab.export import check_csv_targets

        check_csv_targets(csv_out, force=force, inputs=[*archives, models_file, graph_file])
    elif force:
        raise click.UsageError("--force goes with --csv")
    stage = RecognizeStage(graph=g, models=models_file, action=act, threshold=threshold,
                           change_size=change_size, p_prune=p_prune, gap=gap, sides=sides,
                           write=not no_write and explain is None, label_map=lmap,
                           transitions=transitions, keep=csv_out is not None,
                           transient_max_s=transient_max, payload=payload)
    if explain is not None:
        _explain(stage, archives, explain, csv_out, as_json)
        return
    summaries = run_stage(stage, archives, trials=list(trials) or None, workers=workers,
                          scheduler=scheduler, quiet=quiet)
    runs = {path: summary.pop("_runs", []) for path, summary in summaries.items()}
    if csv_out is not None:
        from contactlab.export import export_recognition

        written = export_recognition(runs, stage.graph.node_names, csv_out, force=force)
        for summary in summaries.values():
            summary["csv"] = [str(p) for p in written]
    for summary in summaries.values():
        for line in summary["warnings"]:
            click.echo(f"warning: {line}", err=True)
        for line in summary.get("notes", []):
            click.echo(f"note: {line}", err=True)
    if as_json:
        json_summaries(summaries)
        return
    echo_summaries(summaries, _echo)
    if csv_out is not None:
        click.echo(f"recognised path written to {written[0]} and {written[1]}")


def _echo(archive, summary):
    from contactlab.observer.recognize import DELAY_BINS, payload_line

    for tid, e in summary["trials"].items():
        path = " -> ".join(f"{n}@{s:.3f}s" for n, s in e["merged_path"])
        acc = "" if e["accuracy"] is None else f" ({100 * e['accuracy']:.1f} % correct)"
        click.echo(f"{tid}: {path}{acc}")
        line = payload_line(e.get("payload"), e.get("payload_status"))
        if line:
            click.echo(f"  {line}")
    if summary["accuracy"] is not None:
        labels = summary["confusion"]["labels"]
        matrix = summary["confusion"]["matrix"]
        counts = [sum(row) for row in matrix]
        top = max(range(len(counts)), key=counts.__getitem__)
        click.echo(f"points marked correctly: {100 * summary['accuracy']:.1f} % "
                   f"(on-line MAP node: {100 * summary['accuracy_online']:.1f} %; "
                   f"always choosing the most frequent true node, {labels[top]}: "
                   f"{100 * counts[top] / max(sum(counts), 1):.1f} %)")
        width = max(8, *(len(x) for x in labels))
        click.echo("confusion, labelled points (rows true, columns chosen):")
        click.echo(f"  {'':{width}} " + " ".join(x.rjust(width) for x in labels))
        for name, row in zip(labels, matrix):
            click.echo(f"  {name:>{width}} " + " ".join(str(v).rjust(width) for v in row))
        d = summary["delays"]
        click.echo("delays (samples): " + " ".join(f"{b}:{d['counts'][b]}" for b in DELAY_BINS)
                   + f"  missed {d['missed']}, extra marks {d['extra']}")
    if summary["written"]:
        click.echo(f"results written to {archive} (results/recognize)")



def _explain(stage, archives, trial_id: str, csv_out, as_json: bool) -> None:
    """``--explain TRIAL``: :func:`contactlab.observer.explain.explain_trial` on one trial."""
    from contactlab.archive import open_archive
    from contactlab.archive.validate import raise_problems, trial_problems
    from contactlab.cli.common import echo_json
    from contactlab.observer.explain import explain_trial, format_explanation

    if len(archives) != 1:
        raise click.UsageError("--explain reads one archive")
    if csv_out is not None:
        raise click.UsageError("--explain writes no --csv")
    with open_archive(archives[0]) as arch:
        if trial_id not in arch.trial_ids:
            raise click.BadParameter(f"no trial {trial_id!r} in {archives[0]}",
                                     param_hint="'--explain'")
        trial = arch.trial(trial_id)
        raise_problems(archives[0], trial_problems(trial))
        label_map, _ = stage._trial_label_map(trial)
        ex = explain_trial(trial, stage.graph, stage.built, reduce=stage.models.reduce,
                           action=stage.action, observer_kw=stage.observer_kw,
                           label_map=label_map, path=archives[0], payload=stage.payload)
    if as_json:
        echo_json(ex)
        return
    for line in format_explanation(ex):
        click.echo(line)
