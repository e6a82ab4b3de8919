"""
Recognise the contact state of a real recording
===============================================

A robot wiping a surface with a tool: a wrist force/torque sensor and the end
effector's position at about 98 Hz, labelled by the recording's author
(approach, in contact and sliding, lift-off).  The ``free-contact`` feature graph
is trained on the first wipes and recognises the contact state of the rest.

The recording is one of the real recordings kept beside the project (``wiping/``
under ``$CONTACTLAB_REAL_DATA``, else ``../shared/data/real`` next to the
repository); they are not part of contactlab.  Where they are absent, this
example runs on a synthetic recording of a hand-held tool
(:func:`~contactlab.synthetic.free_contact.free_contact_recording`) instead.

The same from the command line, on an archive::

    contactlab import wiping.csv --out wiping.h5 --columns "..."
    contactlab train wiping.h5 --graph free-contact --label-map "1=free,2=contact,3=free,4=contact" --out m.h5
    contactlab recognize wiping.h5 --graph free-contact --models m.h5
"""

# %%
import os
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

import contactlab
from contactlab import Observer, build_models, load_graph, observe
from contactlab.observer.kinematics import fit_kinematic_models
from contactlab.signals import compensate_friction, lowpass
from contactlab.synthetic.free_contact import free_contact_recording


def real_data_dir() -> Path | None:
    env = os.environ.get("CONTACTLAB_REAL_DATA")
    root = (Path(env) if env else
            Path(contactlab.__file__).resolve().parents[1] / ".." / "shared" / "data" / "real")
    return root if (root / "wiping").is_dir() else None


def load_recording():
    """``(name, position (n, 3), force (n, 3), node per sample (None: unlabelled), fs)``."""
    root = real_data_dir()
    if root is not None:
        csv = sorted((root / "wiping").glob("*.csv"))[0]
        df = pd.read_csv(csv)
        fs = 1.0 / float(np.median(np.diff(df["t"])))
        nodes = {1: "free", 2: "contact", 3: "free", 4: "contact"}   # 4: still touching
        names = np.array([nodes.get(int(c)) for c in df["label"]], dtype=object)
        return (f"wiping/{csv.name} (real)", df[["x", "y", "z"]].to_numpy(),
                df[["fx", "fy", "fz"]].to_numpy(), names, fs)
    rec = free_contact_recording(seed=7, fs=100.0, cycles=6)
    nodes = {1: "free", 2: "contact", 3: "free"}
    names = np.array([nodes[int(c)] for c in rec.labels], dtype=object)
    return "free_contact_recording(seed=7) (synthetic)", rec.position, rec.force, names, rec.fs


name, position, force, nodes, fs = load_recording()
labelled = np.flatnonzero(nodes != None)  # noqa: E711 (an object array)
position, force, nodes = position[:labelled[-1] + 1], force[:labelled[-1] + 1], \
    nodes[:labelled[-1] + 1]
print(f"{name}: {len(force)} labelled samples at {fs:.1f} Hz")

# %%
# The graph's signals and a split in time
# ---------------------------------------
# ``contact-compensated`` is the position then the force (n, 6) with the force's
# friction along the velocity removed (8.29); ``velocity`` the first difference of
# the position times the rate, through the 7.1 lowpass.
velocity = lowpass(np.diff(position, axis=0, prepend=position[:1]) * fs, fs=fs)
data = {"contact-compensated": np.concatenate(
            [position, compensate_friction(force, velocity)], axis=1),
        "velocity": velocity}
# train on the samples before the middle free phase, test on the rest
free = np.flatnonzero(nodes == "free")
split = int(free[np.searchsorted(free, len(nodes) // 2)])
print(f"train: 0-{split / fs:.1f} s, test: {split / fs:.1f}-{len(nodes) / fs:.1f} s")

# %%
# Train the models from the labelled runs of the first part
# ---------------------------------------------------------
graph = load_graph("free-contact")
change = np.flatnonzero(nodes[1:split] != nodes[:split - 1]) + 1
runs = {}
for a, b in zip([0, *change], [*change, split]):
    for signal, y in data.items():
        runs.setdefault((signal, nodes[a]), []).append(y[a:b])
fitted = fit_kinematic_models(graph, runs)
models = build_models(graph, {f"{kind}:{label}": m for kind, by_label in fitted.items()
                              for label, m in by_label.items()})
print("contact constraint: degree", fitted["constraint"]["contact"].degree)

# %%
# Recognise the second part
# -------------------------
test = {k: v[split:] for k, v in data.items()}
obs = Observer(graph, models, sides=graph.sides or "increase")
result = observe(obs, test)
truth = np.array([graph.index(n) for n in nodes[split:]])
share = np.mean(result.labels == truth)
chance = max(np.mean(truth == k) for k in range(graph.n_nodes))
print(f"share of test samples marked correctly: {share:.3f} (chance: {chance:.3f})")

# %%
# On the synthetic recording the observer marks almost every sample correctly.
# On the real wiping recording the same recipe is a measured finding, not a
# success: after the first touch-down of the test part the MAP path enters the
# transient ``impact`` node and stays there, so the share falls below chance.
# The free-contact graph's models (one constraint frame, a tool moved by hand)
# do not yet describe a stiff robot pressing 20 N along a rim; the plot shows
# where the path and the labels part.

# %%
t = (split + np.arange(len(truth))) / fs
fig, (ax0, ax1) = plt.subplots(2, 1, sharex=True, figsize=(8, 4.5))
ax0.plot(t, force[split:], lw=0.6)
ax0.set_ylabel("force (N)")
ax0.set_title(name)
ax1.step(t, truth, where="post", label="labels")
ax1.step(t, result.labels + 0.05, where="post", label="observer")
ax1.set_yticks(range(graph.n_nodes), graph.node_names)
ax1.set_xlabel("time (s)")
ax1.legend(loc="upper right")
fig.tight_layout()
