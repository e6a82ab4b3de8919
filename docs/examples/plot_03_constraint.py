"""
Estimate a contact constraint
=============================

Chapter 8: from the position and force of a point in contact, decide how many
surfaces constrain it (0 free, 1 plane, 2 edge, 3 corner) and estimate their
normals.  :class:`contactlab.constraints.CartesianConstraint` is the
constraint-form estimator (8.21-8.28); with ``degree=None`` it decides the
degree by the highest log-likelihood (8.2).
"""

# %%
import matplotlib.pyplot as plt
import numpy as np

from contactlab.constraints import CartesianConstraint, angular_error_deg
from contactlab.synthetic import contact_trial

# %%
# One synthetic run per degree, with known normals, friction and noise; the
# estimator knows nothing of them but the instruments' accuracies.
for degree in range(4):
    run = contact_trial(seed=3, degree=degree, duration_s=2.0, fs=1000.0)
    fit = CartesianConstraint().estimate(run.position, run.force)
    err = angular_error_deg(fit.normals_, run.normals) if degree and fit.degree_ == degree \
        else np.nan
    print(f"true degree {degree}: estimated {fit.degree_}, normal error {float(err):.2f} "
          f"deg; log-likelihood of degrees 0-3: {np.round(fit.log_likelihoods_)}")

# %%
# A plane: the force lies along the normal, the motion across it.
run = contact_trial(seed=5, degree=1, duration_s=2.0, fs=1000.0)
fit = CartesianConstraint(degree=1).estimate(run.position, run.force)
n_hat, n = fit.normals_[:, 0], run.normals[:, 0]
n_hat = n_hat * np.sign(n_hat @ n)
print("true normal     ", np.round(n, 3))
print("estimated normal", np.round(n_hat, 3), f"(+/- {fit.angle_sd_deg_:.2f} deg)")

fig, ax = plt.subplots(1, 2, figsize=(8, 3))
p = (run.position - run.position.mean(axis=0)) * 1e3
ax[0].plot(p @ n, lw=0.5, label="along the normal")
ax[0].plot(p @ np.linalg.svd(np.eye(3) - np.outer(n, n))[0][:, 0], lw=0.5,
           label="across it")
ax[0].set_ylabel("position (mm)")
ax[0].legend()
ax[1].plot(run.force @ n, lw=0.5, label="along the normal")
ax[1].plot(np.linalg.norm(run.force - np.outer(run.force @ n, n), axis=1), lw=0.5,
           label="across it (friction)")
ax[1].set_ylabel("force (N)")
ax[1].legend()
for a in ax:
    a.set_xlabel("sample")
fig.tight_layout()
