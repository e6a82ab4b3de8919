"""``contactlab graph``: inspect feature-graph files (thesis 5.3, 9.1)."""

from __future__ import annotations

from pathlib import Path

import click

from contactlab.cli.common import count, echo_json, json_option


def _trained(spec) -> str:
    """``", trained on LABEL"`` for a model fitted by ``train --graph``; empty for one
    whose parameters the graph gives inline (a velocity model's sigma, an impact prior)."""
    inline = ("sigma" in spec.params if spec.kind.startswith("velocity")
              else "theta_mean" in spec.params if spec.kind == "impact" else False)
    return "" if inline else f", trained on {spec.trained}"


@click.group(name="graph")
def graph() -> None:
    """Feature graphs: show and check graph files, learn one from labels.

    \b
    Example:
      contactlab graph show datasets_spec/graphs/hf-context.toml --out hf.png
    """


@graph.command(name="show")
@click.argument("graph_file", metavar="GRAPH", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--out", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Draw the graph into this PNG/PDF/SVG file.")
@click.option("--force", is_flag=True, help="Overwrite --out if it exists.")
@json_option
def show(graph_file: Path, out: Path | None, force: bool, as_json: bool) -> None:
    """Validate GRAPH, print its nodes and edges, optionally draw it.

    A graph with a mistake gets a one-line error naming the file and field.

    \b
    Example:
      contactlab graph show datasets_spec/graphs/hf-context-free.toml
      contactlab graph show datasets_spec/graphs/hf-context.toml --out hf-graph.png --json
    """
    from contactlab.observer.draw import draw_graph
    from contactlab.observer.graph import load_graph

    g = load_graph(graph_file)
    if out is not None:
        draw_graph(g, out, force=force)
    if as_json:
        d = g.to_dict()
        if out is not None:
            d["figure"] = str(out)
        echo_json(d)
        return
    named = g.thesis and f"({g.thesis})" not in g.title
    click.echo(f"{g.name}: {g.title}" + (f" (thesis {g.thesis})" if named else ""))
    if not g.edge_probabilities:
        click.echo("  changes: " + ("priced from the training labels (change_prior = trained)"
                                    if g.trained_change_prior else
                                    "free (change_prior = none)"))
    for n in g.nodes:
        models = ", ".join(f"{r}={m}" if r != m else m for r, m in n.models)
        flags = [f for f, on in (("transient", n.transient), ("self", n.self_transition)) if on]
        succ = [g.nodes[j].name for j in g.successors(g.index(n.name)) if j != g.index(n.name)]
        always = ", ".join(succ) or ("- (edges by action below)" if g.action_edges else "-")
        p0 = "trained" if g.initial_trained else format(n.initial, ".3g")
        click.echo(f"  {n.name:>6}  p0={p0}  [{models}]  {n.label}"
                   f"  -> {always}" + (f"  ({', '.join(flags)})" if flags else ""))
    for name, spec in g.models.items():
        click.echo(f"  model {name}: {spec.kind} on {spec.signal}{_trained(spec)}")
    names = g.node_names
    for a, edges in sorted(g.action_edges.items()):
        act = g.actions[a] if a < len(g.actions) else str(a)
        click.echo(f"  while {act} ({count(len(edges), 'edge')}):")
        by_src: dict = {}
        for i, j in sorted(edges):
            by_src.setdefault(i, []).append(names[j])
        for i, js in by_src.items():            # one line per source node, not one long line
            click.echo(f"    {names[i]} -> {', '.join(js)}")
    if out is not None:
        click.echo(f"wrote {out}")


def _register() -> None:
    from contactlab.cli.graph_learn import learn

    graph.add_command(learn)


_register()
