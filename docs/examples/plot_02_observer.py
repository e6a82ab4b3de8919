"""
Train and run the observer on arrays
====================================

The observer of chapter 6 tracks which node of a *feature graph* a recording is
in.  Here the bundled ``free-contact`` graph (free space, contact with one
surface, the impact at touch-down; thesis 9.1.1) is trained on one synthetic
wrench-and-position recording and run on another, all from numpy arrays.

``contactlab train REC.h5 --graph free-contact`` does the same from an archive
(:func:`contactlab.train_graph` reads the labelled runs from it, then fits them as
:func:`contactlab.fit_graph` fits arrays), and each model can also be built alone
and fitted to labelled segments in scikit-learn's way, ``Model(...).fit(segments)``
(:meth:`~contactlab.observer.models.ConstraintFeature.fit`,
:meth:`~contactlab.observer.models.MovingVelocity.fit`).
"""

# %%
# Two recordings with known labels
# --------------------------------
# :func:`~contactlab.synthetic.free_contact.free_contact_recording` draws a tool
# held by hand: free motion, touch-down on a plane, sliding and pressing,
# lift-off.  Labels: 1 approach, 2 contact, 3 retreat.
import matplotlib.pyplot as plt
import numpy as np

from contactlab import Observer, build_models, fit_graph, load_graph, observe
from contactlab.signals import compensate_friction, lowpass
from contactlab.synthetic.free_contact import free_contact_recording

FS = 250.0                                 # the observer's rate (7.1): no decimation
train = free_contact_recording(seed=11, fs=FS, cycles=4)
test = free_contact_recording(seed=12, fs=FS, cycles=4)


def streams(rec):
    """The graph's two signals: ``contact-compensated`` (position then force, (n, 6),
    the force's friction along the velocity removed, 8.29) and ``velocity`` (the first
    difference of the position times the rate, (n, 3))."""
    p = rec.position
    v = lowpass(np.diff(p, axis=0, prepend=p[:1]) * rec.fs, fs=rec.fs)
    f = compensate_friction(rec.force, v)
    return {"contact-compensated": np.concatenate([p, f], axis=1), "velocity": v}


# %%
# Fit the models from the arrays
# ------------------------------
# :func:`~contactlab.fit_graph` takes each recording's signals and a label code per
# sample (indices into ``labels``); the recording's labels 1 and 3 are both free
# space.  It cuts the runs of each label and fits every model the graph names,
# returning what ``contactlab train`` writes to a models file.
graph = load_graph("free-contact")
labels = ["free", "contact"]
codes = np.where(train.labels == 2, 1, 0)
fitted = fit_graph(graph, [(streams(train), codes)], fs=FS, labels=labels)
models = build_models(graph, fitted.trained)
contact = fitted.kinematic["constraint"]["contact"]
print("contact: degree", contact.degree, "normal", np.round(contact.normals.ravel(), 3))
print("true surface normal", np.round(test.normal, 3))

# %%
# Run the observer on the test recording
# --------------------------------------
obs = Observer(graph, models, sides=graph.sides or "increase")
result = observe(obs, streams(test))
truth = np.array([graph.index(labels[c]) for c in np.where(test.labels == 2, 1, 0)])
recognised = result.labels                  # node index per sample along the MAP path
print("MAP path:", [(node, round(start / FS, 2)) for node, start in result.map_path][:8], "...")
print(f"share of samples marked correctly: {np.mean(recognised == truth):.3f}")

# %%
fig, (ax0, ax1) = plt.subplots(2, 1, sharex=True, figsize=(8, 5))
t = np.arange(len(test.force)) / FS
ax0.plot(t, test.force @ test.normal, lw=0.7, label="force along the surface normal")
ax0.set_ylabel("normal force (N)")
ax0.legend(loc="upper right")
ax1.step(t, truth, where="post", label="truth")
ax1.step(t, recognised + 0.05, where="post", label="observer (MAP path)")
ax1.set_yticks(range(graph.n_nodes), graph.node_names)
ax1.set_xlabel("time (s)")
ax1.set_ylabel("node")
ax1.legend(loc="upper right")
fig.suptitle("free-contact graph trained from arrays, run on another recording")
fig.tight_layout()
