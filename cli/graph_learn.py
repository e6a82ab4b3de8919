"""``contactlab graph learn``: a feature graph from labelled recordings (5.3, 10.1.3)."""

from __future__ import annotations

from pathlib import Path

import click

from contactlab.cli.common import archives_argument, count, echo_json, json_option, quiet_option
from contactlab.cli.inputs import checks_archive


@click.command(name="learn")
@archives_argument
@click.option("--label-map", "label_map", required=True, metavar="L=NODE,...",
              help="The recordings' labels (names or integer codes) onto node names, e.g. "
                   "'1=approach,2=engage,3=engage,4=mated': one node per name, in this "
                   "order; unmapped labels are outside the task.")
@click.option("--out", "out", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="Graph file to write (TOML, datasets_spec/GRAPHS.md).")
@click.option("--models", "extra", default="", metavar="FAMILY,...",
              help="Add these model families to every node besides its phase Gaussian: "
                   "constraint (a frame estimated per phase, degree 1 where the force "
                   "departs from the first phase's), velocity (the moving model M), "
                   "temporal (AR(1) with a mean of the wrench, at 250 Hz and above).  "
                   "[default: none]")
@click.option("--models-from", "base", default=None, metavar="GRAPH",
              help="Keep the nodes and models of GRAPH (a bundled name or a file; the label "
                   "map names its nodes) and learn only the edges, their probabilities and "
                   "the initial probabilities from the labels.")
@click.option("--name", default=None, help="Graph name.  [default: the --out file's stem]")
@click.option("--trial", "trials", multiple=True, help="Only this trial (repeatable).")
@click.option("--em", "em", is_flag=True,
              help="Then train the models on the first ARCHIVE's labels and refine the "
                   "edges and their probabilities with EM over every run of every ARCHIVE "
                   "(labels not needed; 10.1.3).")
@click.option("--force", is_flag=True, help="Overwrite --out if it exists.")
@json_option
@quiet_option
@checks_archive
def learn(archives, label_map, out, extra, base, name, trials, em, force, as_json, quiet):
    """Learn a feature graph from the labelled trials of ARCHIVE... and write it to --out.

    One node per node name of --label-map; each reads a Gaussian of its phase
    (mean and covariance trained from its labels) on the phase stream: the
    wrench (in the base frame when the recording has the tool's orientation)
    and the velocity through a 5 Hz lowpass.  Edges are the label
    changes the trials show, with their probabilities counted from the label
    sequences (the observer adds log p when a path changes node), and the
    graph asks the observer to keep each node's best path through the pruning
    (survivors = true: a phase whose first samples fit the next one better
    takes the lead back); the initial
    probabilities are the share of trials starting in each node.  'train
    --graph GRAPH' fits the models and 'recognize --graph GRAPH' runs it like
    any bundled graph; 'graph show' lists and draws it.  Labelled samples the
    map leaves out (a label for "outside the task") get a node of their own,
    'outside', so that a model explains them; train with the map printed (it
    adds LABEL=outside) and recognise with either map (with yours, those
    samples are left out of the score).

    \b
    Examples:
      contactlab graph learn wrist.h5 --label-map "free=free,contact=contact" --out task.toml
      contactlab graph learn wrist.h5 --label-map "free=free,contact=contact" \\
          --models constraint,velocity --out task-cv.toml --json
      contactlab graph learn wrist.h5 --label-map "free=free,contact=contact" --em \\
          --out task-em.toml
      contactlab graph show task.toml
      contactlab acquire --spec hf-train --out hf-train.h5 --seed 1 -q
      contactlab graph learn hf-train.h5 --models-from hf-gaussian \\
          --label-map "H0=H0,H1=H1,H2=H2,H3=H3" --out hf-learned.toml
    """
    from contactlab.fileio import check_writable
    from contactlab.observer.graph_learn import EXTRA_FAMILIES, learn_from_labels, refine_with_em
    from contactlab.observer.graph_toml import write_graph
    from contactlab.observer.kinematics import parse_label_map

    lmap = parse_label_map(label_map)
    if not lmap:
        raise click.BadParameter("expected L=NODE entries", param_hint="'--label-map'")
    families = [f.strip() for f in extra.split(",") if f.strip()]
    bad = [f for f in families if f not in EXTRA_FAMILIES]
    if bad:
        raise click.BadParameter(f"unknown family {bad[0]!r} (known: "
                                 f"{', '.join(EXTRA_FAMILIES)})", param_hint="'--models'")
    if base is not None and families:
        raise click.UsageError("--models adds to the phase Gaussians; --models-from keeps "
                               "another graph's models: give one of them")
    check_writable(out, force=force, inputs=tuple(archives))
    doc, summary = learn_from_labels(list(archives), lmap, trials=list(trials) or None,
                                     name=name or Path(out).stem, extra=families, quiet=quiet,
                                     base=base)
    if em:
        full = dict(e.split("=", 1) for e in summary["label_map"].split(","))
        doc, summary["em"] = refine_with_em(doc, list(archives), label_map=full,
                                            trials=list(trials) or None, quiet=quiet,
                                            source=str(out))
    write_graph(doc, out, header="Learned by contactlab graph learn from "
                + ", ".join(Path(a).name for a in archives))
    summary["out"] = str(out)
    summary["edges"] = {e: p for es in doc.get("edge_sets", [])
                        for e, p in zip(es["edges"], es["probabilities"])}
    for line in summary["notes"]:
        click.echo(f"note: {line}", err=True)
    if as_json:
        echo_json(summary)
        return
    click.echo(f"{len(summary['trials'])} labelled trials, nodes: {', '.join(summary['nodes'])}")
    for node, p in summary["initial"].items():
        if p:
            click.echo(f"  start in {node}: {p:.3g}")
    if em:
        ll = [v for v in summary["em"]["final_loglik"] if v is not None]
        click.echo(f"edges refined by EM over the runs of {count(len(archives), 'archive')}"
                   + (f" (final log-likelihood {sum(ll):.6g})" if ll else "")
                   + ": p per sample of the node left")
    for e, p in summary["edges"].items():
        n = summary["transitions"].get(e)
        click.echo(f"  {e}: p = {p:.3g}" + (f" ({n} seen)" if n else " (added by EM)"))
    click.echo(f"graph written to {out}")
    if summary["label_map"] != ",".join(f"{k}={v}" for k, v in lmap.items()):
        click.echo(f"labels outside the map have node {summary['nodes'][-1]!r}: train with "
                   f"--label-map \"{summary['label_map']}\"")
