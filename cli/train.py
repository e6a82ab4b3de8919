"""contactlab train: per-class temporal models (AR orthogonal-parameter priors, 7.2.2, A.2.3)."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from contactlab import defaults as D

from contactlab.cli.common import archive_argument, count, echo_json, json_option, quiet_option
from contactlab.cli.inputs import check_inputs, checks_archive


@click.command()
@archive_argument
@click.option("--labels", "labels", default="truth", show_default=True, metavar="truth|STAGE",
              help="Classes from the ground truth, or from a results stage's segments "
                   "(e.g. 'segment'), each named by its majority ground-truth label.")
@click.option("--out", "out", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="Models file to write (HDF5, datasets_spec/MODELS.md).")
@click.option("--signal", type=click.Choice(["strain", "wrench", "hf"]), default=None,
              help="Conditioned signal (7.1) to model.  [default: strain when the trials "
                   "have strain gauges, else wrench]")
@click.option("--order", type=int, default=None,
              help=f"AR order p.  [default: {D.TRAIN_ORDER}; with --graph {D.GRAPH_ORDER}]")
@click.option("--mean/--no-mean", default=None,
              help="Include a constant (mean) regressor.  [default: no; with --graph "
                   f"{'yes' if D.GRAPH_MEAN else 'no'}]")
@click.option("--block", type=int, default=D.BLOCK, show_default=True,
              help="Samples per training block (blocks never span a label change).")
@click.option("--classes", default=None, metavar="A,B,...",
              help="Train only these labels (default: every label with enough blocks).")
@click.option("--trial", "trials", multiple=True, help="Only this trial (repeatable).")
@click.option("--graph", "graph_file", default=None, metavar="GRAPH",
              type=click.Path(dir_okay=False, path_type=Path),
              help="Train every model this feature graph names (temporal models, impact-decay "
                   "priors) from the ground truth; the graph's models give the signal.")
@click.option("--label-map", "label_map", default=None, metavar="L=NODE,...",
              help="With --graph: map the archive's labels (names or integer codes) onto the "
                   "graph's labels, e.g. '1=free,2=contact,3=free'; unmapped labels are "
                   "ignored.")
@click.option("--reduce", type=click.Choice(["none", "mean"]), default=None,
              help="With --graph: model every channel of the signal (none) or their mean.  "
                   f"[default: {D.GRAPH_REDUCE}]")
@click.option("--em", "em", is_flag=True,
              help="With --graph: then learn the edges the graph lacks, and the transition "
                   "probabilities, with EM over every run of ARCHIVE (labels not needed; "
                   "10.1.3) and write the graph with them to --graph-out.")
@click.option("--graph-out", "graph_out", default=None, metavar="FILE.toml",
              type=click.Path(dir_okay=False, path_type=Path),
              help="With --em: the learned graph file.  [default: --out with .toml]")
@click.option("--force", is_flag=True, help="Overwrite --out (and --graph-out) if they exist.")
@json_option
@quiet_option
@checks_archive(values=False, walk_trials=False)   # the trials: where they are read
def train(archive, labels, out, signal, order, mean, block, classes, trials, graph_file,
          label_map, reduce, em, graph_out, force, as_json, quiet):
    """Train one temporal model per class of ARCHIVE and write them to --out.

    Every labelled run of the conditioned signal is cut into blocks; per
    block and channel a square-root RLS AR fit gives the orthogonal
    parameters (LPC coefficients, 7.3) and the driving-noise variance.  Per
    class and channel the models store the mean and covariance of those
    parameters, the mean noise variance and the pooled training structure,
    with the training provenance.

    \b
    Examples:
      contactlab train runs.h5 --labels truth --out models.h5
      contactlab train runs.h5 --classes free,contact --out m.h5 --force
      contactlab train runs.h5 --signal wrench --order 2 --block 100 --out m.h5 --force --json
      contactlab train hf.h5 --graph datasets_spec/graphs/hf-context-free.toml \\
          --out hf-models.h5
      contactlab train wrist.h5 --graph free-contact --out fc-models.h5
      contactlab train hf.h5 --graph hf-context-free --em --out em.h5 --graph-out learned.toml

    --classes takes label names as the archive spells them ('contactlab info'
    lists them), e.g. sanded_aluminium_80,polished_aluminium for stroke-a.

    With --graph GRAPH every model the graph names is trained from the
    ground-truth labels its declarations name (temporal: the prior above on
    the model's signal; impact: the linear-decay prior of 7.1 over every
    labelled impact; constraint: the frame and noise of chapter 8 over every
    labelled run; velocity: the F and M models of 9.1.1) and stored with
    provenance in one models file.  Its defaults (AR(1) with a mean on the
    channel mean) are the best settings found on the switching benchmark
    suite (benchmarks/bench_observer.py).  Graph names resolve like spec names
    (free-contact, guarded-move, ...).  --label-map maps a recording's own
    labels onto the graph's (free-contact's: free, contact), e.g. integer
    labels with --label-map "1=free,2=contact,3=free"; unmapped labels are
    ignored.

    --em (10.1.3): with the trained models, every run's per-sample node
    likelihoods feed Baum-Welch over the graph's nodes, every absent edge a
    candidate; an absent edge with at least one expected transition is added.
    The learned graph (the graph's edges, the added ones and, in edge sets
    with probabilities, their learned probabilities) goes to --graph-out, for
    'contactlab recognize --graph'.
    """
    from contactlab.fileio import check_writable
    from contactlab.temporal import train_temporal

    graph = graph_file is not None
    order = order if order is not None else (D.GRAPH_ORDER if graph else D.TRAIN_ORDER)
    mean = mean if mean is not None else (D.GRAPH_MEAN if graph else False)
    if order < 1:
        raise click.BadParameter(f"must be >= 1; got {order}", param_hint="'--order'")
    if block < 1:
        raise click.BadParameter(f"must be >= 1; got {block}", param_hint="'--block'")
    if (em or graph_out is not None) and graph_file is None:
        raise click.UsageError(f"{'--em' if em else '--graph-out'} needs --graph")
    if graph_out is not None and not em:
        raise click.UsageError("--graph-out needs --em")
    if em:
        graph_out = graph_out if graph_out is not None else out.with_suffix(".toml")
        if Path(graph_out).resolve() == Path(out).resolve():
            raise click.UsageError("--graph-out must differ from --out")
        check_writable(graph_out, force=force, inputs=(archive, graph_file))
    check_writable(out, force=force, inputs=(archive, graph_file))
    if graph_file is not None:
        _train_graph(archive, graph_file, out=out, labels=labels, signal=signal, order=order,
                     mean=mean, block=block, classes=classes, trials=trials, reduce=reduce,
                     force=force, as_json=as_json, quiet=quiet, label_map=label_map,
                     graph_out=graph_out if em else None)
        return
    check_inputs([archive], trials)
    if label_map is not None:
        raise click.UsageError("--label-map needs --graph")
    if reduce is not None:
        raise click.UsageError("--reduce needs --graph")
    names = None if classes is None else [c.strip() for c in classes.split(",") if c.strip()]
    if names is not None and not names:
        raise click.BadParameter("expected comma-separated labels", param_hint="'--classes'")
    models = train_temporal(archive, labels=labels, signal=signal, order=order, mean=mean,
                            block=block, trials=list(trials) or None, classes=names,
                            quiet=quiet, command=" ".join(["contactlab"] + sys.argv[1:]))
    models.save(out, force=force)
    summary = {"out": str(out), "signal": models.signal, "fs": models.fs,
               "labels": models.labels, "channels": models.channels,
               "blocks": {k: m.n_blocks for k, m in models.models.items()},
               "skipped": models.provenance.get("skipped", {}),
               "order": order, "mean": mean, "block": block}
    if as_json:
        echo_json(summary)
        return
    for k, m in models.models.items():
        click.echo(f"{k}: {count(m.n_blocks, 'block')}, {count(m.channels, 'channel')}")
    for k, n in summary["skipped"].items():
        click.echo(f"{k}: skipped ({count(n, 'block')}; a covariance of {order + int(mean)} "
                   "parameters needs more)")
    click.echo(f"models written to {out}")


def _train_graph(archive, graph_file, *, out, labels, signal, order, mean, block, classes,
                 trials, reduce, force, as_json, quiet, label_map=None, graph_out=None):
    """``train --graph``: every model the graph names, one models file."""
    from contactlab.observer.graph import load_graph
    from contactlab.observer.kinematics import (check_label_map, parse_label_map,
                                                unmatched_map_note)
    from contactlab.observer.recognize import untrained_priors_note
    from contactlab.observer.training import train_graph

    ctx = click.get_current_context()
    for opt, name in (("signal", "--signal"), ("classes", "--classes")):
        if ctx.get_parameter_source(opt) is not click.core.ParameterSource.DEFAULT:
            raise click.UsageError(f"{name} cannot be used with --graph (the graph's models "
                                   "name their signals and labels)")
    if labels != "truth":
        raise click.UsageError("--graph trains from the ground truth (--labels truth)")
    graph = load_graph(graph_file)
    lmap = parse_label_map(label_map)
    check_label_map(lmap, graph)
    gm = train_graph(archive, graph, order=order, mean=mean, block=block,
                     reduce=reduce or D.GRAPH_REDUCE,
                     trials=list(trials) or None, quiet=quiet,
                     command=" ".join(["contactlab"] + sys.argv[1:]), label_map=lmap)
    gm.save(out, force=force)
    summary = {"out": str(out), "graph": str(graph_file), "signal": gm.signal, "fs": gm.fs,
               "reduce": gm.reduce, "labels": gm.labels,
               "blocks": {k: m.n_blocks for k, m in gm.temporal.items()},
               "impact_segments": {k: getattr(m, "n_segments_", None)
                                   for k, m in gm.impacts.items()},
               "constraints": {k: {"degree": m.degree, "normals": m.normals.T.tolist(),
                                   "signal": m.signal,
                                   "segments": getattr(m, "n_segments_", None)}
                               for k, m in gm.kinematic.get("constraint", {}).items()},
               "velocity": {k: m.params() for k, m in gm.kinematic.get("velocity", {}).items()},
               "gaussian": {k: {"channels": m.channels, "samples": getattr(m, "n_samples_", None)}
                            for k, m in gm.kinematic.get("gaussian", {}).items()},
               "label_map": lmap,
               "order": order, "mean": mean, "block": block,
               "node_dwell": {k: {"seconds": s, "changes": c} for k, (s, c)
                              in (gm.provenance.get("node_dwell") or {}).items()},
               "node_first": gm.provenance.get("node_first") or {},
               "change_prior": graph.change_prior, "initial_trained": graph.initial_trained,
               "notes": unmatched_map_note(lmap, gm.provenance.get("labels_read"),
                                           Path(archive).name)
               + untrained_priors_note(graph, gm)}
    if graph_out is not None:
        summary["em"] = _learn(archive, graph, gm, graph_out, trials=trials, quiet=quiet)
    if as_json:
        echo_json(summary)
        return
    for k, m in gm.temporal.items():
        click.echo(f"{k}: temporal, {count(m.n_blocks, 'block')}, {count(m.channels, 'channel')}")
    for k, n in summary["impact_segments"].items():
        click.echo(f"{k}: impact decay, {count(n, 'impact')}")
    for k, c in summary["constraints"].items():
        normals = "; ".join(" ".join(f"{v:+.3f}" for v in n) for n in c["normals"]) or "none"
        click.echo(f"{k}: constraint degree {c['degree']} (normals {normals}), signal "
                   f"{c['signal']}, from {count(c['segments'], 'run')} labelled {k}")
    for k, p in summary["velocity"].items():
        click.echo(f"{k}: velocity " + ", ".join(f"{n} {v:.3g}" for n, v in p.items()))
    for k, g in summary["gaussian"].items():
        click.echo(f"{k}: phase Gaussian, {g['channels']} channels, {g['samples']} samples")
    if graph.trained_change_prior and summary["node_dwell"]:
        click.echo("changes priced from the labels: " + ", ".join(
            f"{k} {count(d['changes'], 'change')} in {d['seconds']:.3g} s"
            for k, d in summary["node_dwell"].items()))
    if graph.initial_trained and summary["node_first"]:
        click.echo("runs start in: " + ", ".join(
            f"{k} {count(n, 'run')}" for k, n in summary["node_first"].items()))
    for line in summary["notes"]:
        click.echo(f"note: {line}", err=True)
    click.echo(f"models written to {out}")
    if graph_out is not None:
        em = summary["em"]
        for e in em["added"]:
            where = f" (action {e['action']})" if e["action"] else ""
            click.echo(f"EM added {e['edge']}{where}: {e['expected_transitions']:.1f} expected "
                       f"transitions, jump probability {e['jump_probability']:.3f}")
        if not em["added"]:
            click.echo("EM added no edge")
        click.echo(f"learned graph written to {graph_out}")


def _learn(archive, graph, gm, graph_out, *, trials, quiet) -> dict:
    """``train --em``: EM over the archive's runs with the trained models; the graph file."""
    from contactlab.observer.graph_toml import write_graph
    from contactlab.observer.learning import learn_graph
    from contactlab.observer.recognize import bind_models

    graph, gm, built = bind_models(graph, gm)
    doc, summary = learn_graph(archive, graph, built, reduce=gm.reduce,
                               trials=list(trials) or None, quiet=quiet)
    doc["name"] = f"{graph.name}-em"
    write_graph(doc, graph_out, header=f"{graph.name} with edges learned by EM (10.1.3) "
                                      f"from {Path(archive).name}")
    summary["graph_out"] = str(graph_out)
    return summary
