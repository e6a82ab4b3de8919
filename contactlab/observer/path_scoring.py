"""Scoring a decoded node path against the expected one (9.1.1): impact excursions that return
to where they left are tolerated (:func:`reduce_impacts`), and a path that strays onto a node
outside the expected ones is flagged (:func:`score_path`)."""

from __future__ import annotations

__all__ = ["reduce_impacts", "score_path"]


def reduce_impacts(nodes, impact: str = "1") -> list[str]:
    """A merged node sequence without impact excursions that return to where they left
    (``a -> impact -> a`` becomes ``a``), repeated until none is left."""
    seq = list(nodes)
    changed = True
    while changed:
        changed = False
        out: list[str] = []
        i = 0
        while i < len(seq):
            if (out and seq[i] == impact and i + 1 < len(seq) and seq[i + 1] == out[-1]):
                i += 2
                changed = True
                continue
            if out and out[-1] == seq[i]:
                i += 1
                continue
            out.append(seq[i])
            i += 1
        seq = out
    return seq


def score_path(merged_nodes, expected, *, impact: str = "1") -> dict:
    """A decoded path scored against the ``expected`` node sequence (9.1.1's counting).

    ``strict``: the merged path is exactly ``expected``; ``correct``: it is after
    :func:`reduce_impacts`; ``final``: after :func:`reduce_impacts` it starts with
    ``expected`` but its last node and ends in that node (the thesis's fig 9.1 run, counted
    correct, "initially selects feature 4 ... but quickly returns to the correct feature,
    number 3" after an impact during the contact); ``distractor``: it visits a node outside
    ``expected``.  ``impact`` is the impact node's name."""
    nodes = list(merged_nodes)
    red = reduce_impacts(nodes, impact)
    head = list(expected[:-1])
    return {"strict": nodes == list(expected),
            "correct": red == list(expected),
            "final": red[:len(head)] == head and bool(nodes) and nodes[-1] == expected[-1],
            "distractor": any(n not in expected for n in nodes)}
