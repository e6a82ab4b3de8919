"""The simulated hand-moved Cartesian data set of 8.1.1.2, as the library gives it.

The ``cartesian`` dataset spec has four groups of four runs -- free space, one
wood plane, a line (two planes) and a corner (three) -- moved by hand over the
constraint.  :func:`load_groups` simulates them, conditions force
(``wrench[:, :3]``), position and velocity with the 7.1 settings of
:mod:`contactlab.signals` (250 Hz) and lumps each group's runs into one
:class:`GroupData` with the true surface normals; :func:`consecutive_blocks`
and :func:`random_blocks` draw the blocks the chapter-8 decisions are tested on.
The cartesian-estimation, constraint-degree and constraint-direction
experiments all read it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from contactlab.progress import progress
from contactlab.signals import factor_for

__all__ = ["SPEC", "GROUPS", "GroupData", "true_normals", "load_groups",
           "load_group_pair", "consecutive_blocks", "strided_blocks", "fitting_strides",
           "free_exploration", "RATE_HZ", "STRIDES",
           "random_blocks", "reported_normals"]

SPEC = "cartesian"
#: the groups' sample rate (8.1: "sampled at 250 Hz"), Hz
RATE_HZ = 250.0
#: strides of the blocks spread over a run (:func:`strided_blocks`): 0.1-1.5 s for 25
STRIDES = (1, 2, 4, 8, 16)
GROUPS = ("free", "plane", "line", "corner")


@dataclass
class GroupData:
    """One group's four runs lumped into one block, 250 Hz, SI units.

    ``normals`` (3, m): the true unit normals of the surfaces of the group;
    ``run`` (n,): which run each sample came from; ``contact`` (n,): number of
    surfaces touched at each sample (ground truth).  ``reported_normals`` (n, 3, m):
    the same surfaces' normals in the frame of the *reported* positions at each
    sample: the PHANToM's kinematic error maps a true displacement dp to
    ``J(p) dp`` (``J = Id + A + Q(p, .)``, :meth:`contactlab.sim.sensor.Encoders.kinematic_error`),
    so a surface ``n^T dp = 0`` reads as ``(J^{-T} n)^T dp' = 0``.
    """

    name: str
    position: np.ndarray
    force: np.ndarray
    velocity: np.ndarray
    normals: np.ndarray
    run: np.ndarray
    contact: np.ndarray
    reported_normals: np.ndarray | None = None

    @property
    def degree(self) -> int:
        return int(self.normals.shape[1])

    def __len__(self) -> int:
        return int(self.position.shape[0])


def true_normals(result) -> np.ndarray:
    """Orthonormal (3, m) normals of the surfaces of a trial (from the simulator)."""
    cols = []
    for s in range(len(result.surfaces)):
        touched = np.flatnonzero(result.contact[:, s])
        if touched.size:
            cols.append(result.contact_normals[touched[touched.size // 2], s])
    if not cols:
        return np.zeros((3, 0))
    q, _ = np.linalg.qr(np.asarray(cols, dtype=np.float64).T)
    return q


def reported_normals(normals: np.ndarray, position: np.ndarray, encoders) -> np.ndarray:
    """Normals (n, 3, m) of surfaces with true normals (3, m) in the reported-position frame
    at each reported position (n, 3) (:class:`GroupData`).  The Jacobian is evaluated at
    the reported position: the kinematic error moves it by ~1 % of its distance from
    the workspace centre, a change of J of order 1e-4."""
    a, q = encoders.kinematic_error()
    J = np.eye(3) + a + np.einsum("ijk,nk->nij", q, np.asarray(position, float))
    out = np.linalg.solve(np.swapaxes(J, 1, 2), np.broadcast_to(normals, (len(J),) + normals.shape))
    return out / np.maximum(np.linalg.norm(out, axis=1, keepdims=True), 1e-300)


def load_groups(*, seed: int, tare: bool = True, quiet: bool = True,
                duration_s: float | None = None) -> dict[str, GroupData]:
    """Simulate the 16 runs of the ``cartesian`` spec and lump each group.

    Force (``wrench[:, :3]``), position and velocity are lowpassed (fs/8) and
    decimated 4:1 (7.1).  ``tare``: subtract the free-space group's mean force
    from every group (sensor zeroing; module notes).  ``duration_s`` shortens
    every run (tests).
    """
    from contactlab.acquire import load_spec, simulate_trial
    from contactlab.acquire.sim import hardware
    from contactlab.signals import condition

    spec = load_spec(SPEC)
    encoders = hardware(spec)["encoders"]
    parts: dict[str, dict[str, list]] = {}
    normals: dict[str, np.ndarray] = {}
    k = 0
    jobs = [(g, j) for g in spec.groups for j in range(g.trials)]
    for g, j in progress(jobs, total=len(jobs), desc="cartesian runs", quiet=quiet):
        _, r = simulate_trial(spec, k, seed, duration_s=duration_s)
        k += 1
        d = parts.setdefault(g.name, {"p": [], "f": [], "v": [], "run": [], "c": []})
        d["p"].append(condition(r, "position").y)
        d["f"].append(condition(r, "wrench").y[:, :3])
        d["v"].append(condition(r, "velocity").y)
        n = len(d["p"][-1])
        d["run"].append(np.full(n, j))
        d["c"].append(np.asarray(r.contact).reshape(len(r.time), -1).sum(axis=1)[::factor_for(r.rate_hz)][:n])
        if g.name not in normals:
            normals[g.name] = true_normals(r)
    groups = {name: GroupData(name, np.concatenate(d["p"]), np.concatenate(d["f"]),
                              np.concatenate(d["v"]), normals[name], np.concatenate(d["run"]),
                              np.concatenate(d["c"]),
                              reported_normals(normals[name], np.concatenate(d["p"]), encoders))
              for name, d in parts.items()}
    if tare and "free" in groups:
        zero = groups["free"].force.mean(axis=0)
        for gd in groups.values():
            gd.force = gd.force - zero
    return groups


def load_group_pair(*, seed: int, quiet: bool = True,
                             duration_s: float | None = None) -> tuple[dict, dict, float]:
    """The groups to test on (``seed``), the independent groups to train on (``seed + 1``)
    and the seconds both took to simulate (:func:`load_groups`)."""
    import time

    t0 = time.perf_counter()
    test = load_groups(seed=seed, quiet=quiet, duration_s=duration_s)
    train = load_groups(seed=seed + 1, quiet=quiet, duration_s=duration_s)
    return test, train, time.perf_counter() - t0


def consecutive_blocks(gd: GroupData, *, n_blocks: int, block: int, rng) -> np.ndarray:
    """Indices (n_blocks, block) of runs of consecutive samples inside one run."""
    return strided_blocks(gd, n_blocks=n_blocks, block=block, stride=1, rng=rng)


def strided_blocks(gd: GroupData, *, n_blocks: int, block: int, stride: int,
                   rng) -> np.ndarray:
    """Indices (n_blocks, block) of every ``stride``-th sample inside one run: ``block``
    samples that span ``(block - 1) * stride + 1`` samples of the run (``stride`` 1:
    consecutive samples)."""
    span = (block - 1) * stride + 1
    if span > len(gd.run):
        raise ValueError(f"{block} samples every {stride} span {span}, longer than the group")
    ok = np.flatnonzero(np.r_[gd.run[span - 1:] == gd.run[:len(gd.run) - span + 1],
                              np.zeros(span - 1, dtype=bool)])
    if not ok.size:
        raise ValueError(f"no run of group {gd.name} holds {span} samples")
    starts = rng.choice(ok, size=n_blocks, replace=True)
    return starts[:, None] + stride * np.arange(block)[None]


def fitting_strides(groups, block: int, strides=STRIDES) -> list[int]:
    """The ``strides`` whose ``block`` samples (:func:`strided_blocks`) fit inside the
    longest run of every group of ``groups`` (one :class:`GroupData` or several)."""
    gds = [groups] if isinstance(groups, GroupData) else list(groups)
    longest = min(int(np.bincount(gd.run).max()) for gd in gds)
    return [s for s in strides if (block - 1) * s + 1 <= longest]


def free_exploration(gd: GroupData, index: np.ndarray, *, position_sd: float) -> np.ndarray:
    """Per block (rows of ``index``), the smallest rms excursion of its positions along the
    group's true free directions, in units of the position noise ``position_sd``: how well
    the block explores the least-explored free direction (nan where the group has no free
    direction, or none constrained)."""
    m = gd.degree
    if m in (0, gd.normals.shape[0]):
        return np.full(len(index), np.nan)
    q, _ = np.linalg.qr(np.c_[gd.normals, np.eye(gd.normals.shape[0])])
    free = q[:, m:gd.normals.shape[0]]
    p = gd.position[index]
    p = p - p.mean(axis=1, keepdims=True)
    sv = np.linalg.svd(p @ free, compute_uv=False)[:, -1]
    return sv / np.sqrt(index.shape[1]) / position_sd


def random_blocks(gd: GroupData, *, n_blocks: int, block: int, rng) -> np.ndarray:
    """Indices (n_blocks, block) of samples drawn at random (no repeats in a block)."""
    return np.stack([rng.choice(len(gd), size=block, replace=False) for _ in range(n_blocks)])
