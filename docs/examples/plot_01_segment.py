"""
Segment a wrench and a strain signal
====================================

Two segmenters of ``contactlab segment``, on arrays:

* a wrist force sensor's wrench changes its *level* where contact is made and
  broken: :func:`contactlab.segmentation.segment_level`;
* fingertip strains change their *vibration* (texture, sliding, impacts): the
  two-model AR likelihood-ratio test :func:`contactlab.segmentation.segment_glr`.

:class:`contactlab.segmenter.Segmenter` wraps both with the interface of
ruptures (``fit``/``predict``, boundaries as the end of each segment, the last
being the signal's length), so ruptures' metrics score it directly.
"""

# %%
# A wrench: free motion and contact
# ---------------------------------
# :func:`~contactlab.synthetic.free_contact.free_contact_recording` draws a
# hand-held tool that touches down on a plane, slides and presses, and lifts
# off, three times; its labels say when it touched.
import matplotlib.pyplot as plt
import numpy as np
from ruptures.metrics import hausdorff, precision_recall

from contactlab import Segmenter, segment_glr, segment_level
from contactlab.synthetic import piecewise_ar
from contactlab.synthetic.free_contact import free_contact_recording

rec = free_contact_recording(seed=1, fs=500.0, cycles=3)
seg = segment_level(rec.force, fs=rec.fs)
print("boundaries (s):", np.round(seg.boundaries_s, 2))
print("excursions inside a phase (s):", np.round(seg.events_s, 2))

# %%
# The same with the ruptures-style :class:`~contactlab.segmenter.Segmenter`,
# scored against the labelled contacts with ruptures' metrics.
contact = (rec.labels == 2).astype(int)
truth = [*(np.flatnonzero(np.diff(contact)) + 1).tolist(), len(contact)]
bkps = Segmenter(method="level").fit_predict(rec.force, fs=rec.fs)
p, r = precision_recall(truth, bkps, margin=int(0.1 * rec.fs))
print("predict():", bkps)
print(f"precision {p:.2f}, recall {r:.2f} within 0.1 s; "
      f"Hausdorff {hausdorff(truth, bkps) / rec.fs:.3f} s")

# %%
t = rec.times
fig, ax = plt.subplots(figsize=(8, 3))
ax.plot(t, rec.force, lw=0.6)
ax.fill_between(t, *ax.get_ylim(), where=contact > 0, color="0.9", label="contact (truth)")
for b in seg.boundaries_s:
    ax.axvline(b, color="k", ls="--", lw=0.8)
ax.set_xlabel("time (s)")
ax.set_ylabel("force (N)")
ax.set_title("segment_level: dashed lines are the boundaries found")
ax.legend(loc="upper right")
fig.tight_layout()

# %%
# A strain signal: changes of vibration
# -------------------------------------
# :func:`~contactlab.synthetic.piecewise_ar` draws eight channels of piecewise
# AR(2) "strains" at 1000 Hz whose changes alter the variance, the spectrum or
# both; the true boundaries are known.
strains = piecewise_ar(seed=0, duration_s=4.0, channels=8)
glr = segment_glr(strains.y, fs=strains.fs)
print("true (s): ", np.round(strains.boundaries_s, 3))
print("found (s):", np.round(glr.boundaries_s, 3))
truth = [*strains.boundaries.tolist(), len(strains.y)]
found = Segmenter(method="glr").fit_predict(strains.y, fs=strains.fs)
p, r = precision_recall(truth, found, margin=int(0.05 * strains.fs))
print(f"precision {p:.2f}, recall {r:.2f} within 50 ms")

# %%
fig, (ax0, ax1) = plt.subplots(2, 1, sharex=True, figsize=(8, 4))
ax0.plot(strains.times, strains.y[:, 0], lw=0.4)
ax0.set_ylabel("strain, channel 0")
ax1.plot(strains.times, glr.statistic, lw=0.7)
ax1.set_ylabel("GLR statistic / dof")
ax1.set_xlabel("time (s)")
for ax in (ax0, ax1):
    for b in strains.boundaries_s:
        ax.axvline(b, color="g", lw=1.5, alpha=0.5)
    for b in glr.boundaries_s:
        ax.axvline(b, color="k", ls="--", lw=0.8)
ax0.set_title("green: true changes; dashed: found")
fig.tight_layout()
