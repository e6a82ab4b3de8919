"""Writing feature-graph documents (``datasets_spec/GRAPHS.md``) as TOML files.

:func:`load_graph` reads them; :func:`dumps_graph` writes the plain subset of TOML a graph
needs (strings, numbers, booleans, lists, inline tables), top-level keys first (TOML
attaches keys after a table header to that table); :func:`write_graph` writes a file
atomically; :func:`graph_document` turns a loaded :class:`FeatureGraph` back into a document
(so a learned graph is written with its node order, models and edge sets)."""

from __future__ import annotations

import json
import math
import os
import tempfile
from pathlib import Path

from contactlab.observer.graph import FeatureGraph, parse_graph

__all__ = ["dumps_graph", "write_graph", "graph_document"]

_TOP = ("name", "title", "thesis", "description", "actions", "initial", "sides", "p_prune",
        "survivors", "change_prior", "edges")


def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ValueError(f"not a finite number: {v}")
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{_key(k)} = {_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(f"cannot write {type(v).__name__} to a graph file")


def _key(k: str) -> str:
    return k if k.replace("_", "").replace("-", "").isalnum() else json.dumps(k)


def dumps_graph(doc: dict, *, header: str = "") -> str:
    """TOML text of a graph document; ``header`` lines become ``#`` comments on top."""
    lines = [f"# {h}".rstrip() for h in header.splitlines()]
    for k in _TOP:
        if k in doc:
            lines.append(f"{k} = {_value(doc[k])}")
    for name, spec in doc.get("models", {}).items():
        lines += ["", f"[models.{_key(name)}]"] + [f"{_key(k)} = {_value(v)}" for k, v in spec.items()]
    for table in ("nodes", "edge_sets"):
        for item in doc.get(table, []):
            lines += ["", f"[[{table}]]"] + [f"{_key(k)} = {_value(v)}" for k, v in item.items()]
    return "\n".join(lines) + "\n"


def write_graph(doc: dict, path, *, header: str = "") -> Path:
    """Validate ``doc`` (:func:`parse_graph`) and write it to ``path`` atomically."""
    path = Path(path)
    parse_graph(doc, source=str(path))
    text = dumps_graph(doc, header=header)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def graph_document(graph: FeatureGraph) -> dict:
    """A document that :func:`parse_graph` turns back into ``graph``."""
    d = graph.to_dict()
    doc = {"name": d["name"], "title": d["title"]}
    if d["thesis"]:
        doc["thesis"] = d["thesis"]
    if d["actions"]:
        doc["actions"] = d["actions"]
    if d.get("sides"):
        doc["sides"] = d["sides"]
    if d.get("p_prune") is not None:
        doc["p_prune"] = d["p_prune"]
    if d.get("survivors"):
        doc["survivors"] = True
    if d.get("change_prior", "trained") != "trained":
        doc["change_prior"] = d["change_prior"]
    if d.get("initial_trained"):
        doc["initial"] = "trained"
    doc["edges"] = [f"{a} -> {b}" for a, b in d["edges"]]
    doc["models"] = d["models"]
    nodes = []
    for n in d["nodes"]:
        node = {"name": n["name"], "label": n["label"], "models": n["models"]}
        if n["initial"] and not d.get("initial_trained"):
            node["initial"] = n["initial"]
        if n["transient"]:
            node["transient"] = True
        if not n["self_transition"]:
            node["self_transition"] = False
        nodes.append(node)
    doc["nodes"] = nodes
    doc["edge_sets"] = [{"actions": es["actions"], "edges": [f"{a} -> {b}" for a, b in es["edges"]],
                         **({"probabilities": es["probabilities"]} if "probabilities" in es else {})}
                        for es in d["edge_sets"]]
    if not doc["edge_sets"]:
        del doc["edge_sets"]
    return doc
