"""Drawing a feature graph (matplotlib): nodes on a circle, transient nodes as
diamonds, each node's description, models and initial probability outside the
circle, self-transitions marked with a loop sign, action-dependent edges
coloured by action; optional node probabilities shade the nodes (fig 7.10)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from contactlab.errors import UsageError
from contactlab.fileio import atomic_path
from contactlab.observer.graph import FeatureGraph

__all__ = ["draw_graph", "plot_graph", "plot_node_path", "plot_recognised_run"]


def plot_node_path(ax, t, labels, graph: FeatureGraph, *, truth=None,
                   truth_label: str = "simulator labels", fontsize: float = 7) -> None:
    """A recognised node sequence over time on ``ax``: the final MAP path's node index
    per sample (``labels``) and, dashed, ``truth`` (node indices, < 0 unknown), the
    y axis labelled with each node's name and description."""
    n = min(len(t), len(labels))
    ax.step(t[:n], labels[:n], where="post", lw=1.2, label="final MAP path")
    if truth is not None:
        tr = np.where(truth[:n] >= 0, truth[:n], np.nan)
        ax.step(t[:n], tr, where="post", lw=1.0, ls="--", label=truth_label)
    names = list(graph.node_names)
    ax.set_yticks(range(len(names)))
    ax.set_yticklabels([f"{nm}: {nd.label}" for nm, nd in zip(names, graph.nodes)],
                       fontsize=fontsize)
    ax.set_ylabel("node")
    ax.set_xlabel("time (s)")


def plot_recognised_run(run: dict, graph: FeatureGraph, *, title: str):
    """Position, force and the final MAP node of one recognised run beside its labels
    (``run`` as :func:`contactlab.observer.recognize.typical_run` returns it)."""
    import matplotlib.pyplot as plt

    rec, t = run["rec"], run["t"]
    n = min(len(t), len(rec.result.labels))
    fig, ax = plt.subplots(3, 1, figsize=(9, 7.5), sharex=True)
    for k, axis in enumerate("xyz"):
        ax[0].plot(t[:n], 1e3 * run["position"][:n, k], lw=0.8, label=axis)
        ax[1].plot(t[:n], run["force"][:n, k], lw=0.8, label=f"F{axis}")
    ax[0].set_ylabel("position (mm)")
    ax[1].set_ylabel("force (N)")
    plot_node_path(ax[2], t[:n], rec.result.labels, graph, truth=rec.truth, fontsize=6)
    for a in ax:
        a.legend(loc="upper right", fontsize=7)
        a.grid(alpha=0.3)
    ax[0].set_title(title, fontsize=9)
    fig.tight_layout()
    return fig


def plot_graph(graph: FeatureGraph, ax, *, probabilities=None) -> None:
    """Draw ``graph`` into matplotlib axes ``ax`` (``probabilities``: (K,) node shading)."""
    import matplotlib.pyplot as plt

    K = graph.n_nodes
    ang = np.pi / 2 - 2 * np.pi * np.arange(K) / K
    xy = np.c_[np.cos(ang), np.sin(ang)] if K > 1 else np.zeros((1, 2))
    cmap = plt.get_cmap("tab10")
    # marker diameter (points) wide enough for the longest node name at 9 pt (~5.5 pt a
    # character), so names like "contact" stay inside their node; arrows stop at its edge
    diam = max(30.0, 5.5 * max(len(n.name) for n in graph.nodes) + 10.0)
    crowded = K > CROWDED              # small markers, names only: words would overlap
    if crowded:
        diam = max(2.0, min(7.0, 500.0 / K))
    lw = 0.4 if crowded else 1.2

    def arrow(i, j, color, rad):
        ax.annotate("", xy=xy[j], xytext=xy[i], arrowprops=dict(
            arrowstyle="-|>", color=color, lw=lw, shrinkA=diam / 2 + 1, shrinkB=diam / 2 + 1,
            connectionstyle=f"arc3,rad={rad}"))

    for i, j in sorted(graph.edges):
        arrow(i, j, "0.3", 0.12)
    handles = []
    for k, (a, edges) in enumerate(sorted(graph.action_edges.items())):
        color = cmap((k + 1) % 10)
        for i, j in sorted(edges):
            arrow(i, j, color, 0.25)
        name = graph.actions[a] if a < len(graph.actions) else str(a)
        handles.append(plt.Line2D([], [], color=color, label=f"while {name}"))
    p = np.zeros(K) if probabilities is None else np.asarray(probabilities, dtype=float)
    loops = False
    for k, n in enumerate(graph.nodes):
        face = plt.get_cmap("Reds")(0.15 + 0.7 * p[k]) if probabilities is not None else "white"
        ax.scatter(*xy[k], s=diam ** 2, marker="D" if n.transient else "o", facecolor=face,
                   edgecolor="black", zorder=3)
        if crowded:                    # up to twice CROWDED nodes: the name alone, radially
            if K <= 2 * CROWDED:       # outside its node, turned to read along the radius
                u = xy[k] / max(np.hypot(*xy[k]), 1e-12)
                rot = float(np.degrees(np.arctan2(u[1], u[0])))
                rot = rot - 180 if rot > 90 else rot + 180 if rot < -90 else rot
                ax.annotate(n.name, xy=xy[k], xytext=tuple((6 + 1.6 * len(n.name)) * u),
                            textcoords="offset points", ha="center", va="center", fontsize=5,
                            zorder=4, rotation=rot, rotation_mode="anchor")
            continue
        ax.text(*xy[k], n.name, ha="center", va="center", zorder=4, fontsize=9)
        # the description goes outside the circle, away from the edges between nodes,
        # on a white box so that arrows passing behind it do not cross the words
        # (the top and bottom nodes' descriptions go to their right, clear of the
        # title above and the legend below)
        u = xy[k] if K > 1 else np.array([0.0, -1.0])
        if abs(u[0]) < 0.3:
            u = np.array([1.0, 0.0])
        ha = "left" if u[0] > 0.3 else "right" if u[0] < -0.3 else "center"
        va = "bottom" if u[1] > 0.3 else "top" if u[1] < -0.3 else "center"
        loop = "\u21bb " if n.self_transition else ""
        loops |= bool(loop)
        models = "/".join(n.model_names)
        p0 = "trained" if graph.initial_trained else format(n.initial, ".2g")
        ax.annotate(f"{loop}{n.label}\n[{models}] p0={p0}", xy=xy[k],
                    xytext=tuple((diam / 2 + 5) * u), textcoords="offset points", ha=ha, va=va,
                    fontsize=7, zorder=5,
                    bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.85))
    if crowded:
        ax.text(0.5, -0.02, f"{K} nodes: {'names, ' if K > 2 * CROWDED else ''}descriptions and models omitted "
                f"(contactlab graph show lists them)", transform=ax.transAxes, ha="center",
                va="top", fontsize=7)
    if loops:
        handles.append(plt.Line2D([], [], ls="none", marker="$\u21bb$", color="0.3",
                                  label="self-transition"))
    if handles or probabilities is not None:
        if probabilities is not None:
            handles.append(plt.Line2D([], [], ls="none", marker="o", markersize=8,
                                      markerfacecolor=plt.get_cmap("Reds")(0.85),
                                      markeredgecolor="black", label="darker: more probable"))
        ax.legend(handles=handles, loc="lower left", fontsize=7, frameon=False)
    ax.set_xlim(-1.9, 1.9)
    ax.set_ylim(-1.7, 1.6)
    ax.set_aspect("equal")
    ax.axis("off")
    ax.set_title(graph.title, fontsize=10)


#: Above this many nodes a drawing shows names only (descriptions would overlap).
CROWDED = 24

#: File suffixes draw_graph writes (the format follows the suffix).
FIGURE_SUFFIXES = (".png", ".pdf", ".svg")


def draw_graph(graph: FeatureGraph, path, *, force: bool = False, probabilities=None) -> Path:
    """Write a drawing of ``graph`` to ``path`` (format from the suffix), atomically."""
    import matplotlib.pyplot as plt

    path = Path(path)
    if path.suffix.lower() not in FIGURE_SUFFIXES:
        raise UsageError(f"{path}: --out: unsupported figure format {path.suffix or '(none)'!r} "
                         f"(use {', '.join(FIGURE_SUFFIXES)})")
    fig, ax = plt.subplots(figsize=(6, 6))
    try:
        plot_graph(graph, ax, probabilities=probabilities)
        with atomic_path(path, force=force) as tmp:
            # tight: descriptions beside the outer nodes reach past the axes
            fig.savefig(tmp, format=path.suffix.lstrip(".") or "png", dpi=120,
                        bbox_inches="tight", pad_inches=0.15)
    finally:
        plt.close(fig)
    return path
