"""Square-root Kalman update per channel-step: our numba batch path vs filterpy.

The workload is the thesis's labelling filter on strains: AR(2) on 8 channels,
one scalar measurement per channel and step, 20,000 steps.  Ours runs all
channels in one :meth:`SquareRootKalman.filter` call (per-sample recursion in
numba); the peer is ``filterpy.kalman.KalmanFilter``, one filter per channel,
``predict()`` + ``update(z, H=psi)`` per step.  filterpy costs tens of
microseconds per step in Python, so it runs a tenth of the steps and its time
is scaled up linearly (the per-step cost is constant: no state grows).
"""

from __future__ import annotations

import time

import numpy as np
from benchmarks.timing import best_time

CHANNELS = 8
STEPS = 20_000
PEER_STEPS = 2_000          # filterpy runs these and is extrapolated to STEPS
STREAM_STEPS = 2_000        # our per-step update() path, extrapolated likewise


def _data(seed: int = 0):
    rng = np.random.default_rng(seed)
    a1, a2 = 1.3, -0.7
    y = np.zeros((STEPS + 2, CHANNELS))
    e = 0.5 * rng.normal(size=y.shape)
    for t in range(2, STEPS + 2):
        y[t] = a1 * y[t - 1] + a2 * y[t - 2] + e[t]
    psi = np.ascontiguousarray(np.stack([y[1:-1], y[:-2]], axis=-1))   # (N, B, 2)
    return psi, np.ascontiguousarray(y[2:])




def _filterpy_run(psi, y, steps):
    from filterpy.kalman import KalmanFilter

    for b in range(psi.shape[1]):
        kf = KalmanFilter(dim_x=2, dim_z=1)
        kf.x = np.zeros((2, 1))
        kf.P = np.eye(2)
        kf.F = np.eye(2)
        kf.Q = np.zeros((2, 2))
        kf.R = np.array([[0.25]])
        for n in range(steps):
            kf.predict()
            kf.update(y[n, b], H=psi[n, b][None, :])


def run() -> list[dict]:
    from contactlab.estimators import SquareRootKalman, SquareRootRLS

    psi, y = _data()
    args = dict(theta0=np.zeros(2), theta_sqrt0=1.0, noise_sqrt=0.5)

    t0 = time.perf_counter()
    SquareRootKalman(**args).run(psi[:10], y[:10])
    SquareRootRLS().run(psi[:10], y[:10])
    warm = time.perf_counter() - t0
    warm_note = f"numba warm-up {warm:.2f} s (compile or cache load), excluded"

    ours = best_time(lambda: SquareRootKalman(**args).run(psi, y))

    def stream():
        kf = SquareRootKalman(**args)
        for n in range(STREAM_STEPS):
            kf.update(psi[n], y[n])
    ours_stream = best_time(stream) * STEPS / STREAM_STEPS

    peer = best_time(lambda: _filterpy_run(psi, y, PEER_STEPS)) * STEPS / PEER_STEPS
    rls = best_time(lambda: SquareRootRLS().run(psi, y))

    per = CHANNELS * STEPS
    return [
        dict(name=f"sqrt-Kalman AR(2) {CHANNELS}ch x {STEPS} batch", ours_s=ours,
             peer="filterpy KalmanFilter", peer_s=peer, ratio=peer / ours,
             notes=(f"{ours / per * 1e9:.0f} ns vs {peer / per * 1e6:.1f} us per channel-step; "
                    f"filterpy ran {PEER_STEPS} steps x {CHANNELS} filters, scaled x"
                    f"{STEPS // PEER_STEPS}; {warm_note}; best of 3")),
        dict(name=f"sqrt-Kalman AR(2) {CHANNELS}ch x {STEPS} update()", ours_s=ours_stream,
             peer="filterpy KalmanFilter", peer_s=peer, ratio=peer / ours_stream,
             notes=(f"streaming path: one Python update() per step for all {CHANNELS} channels; "
                    f"ran {STREAM_STEPS} steps, scaled x{STEPS // STREAM_STEPS}; best of 3")),
        dict(name=f"sqrt-RLS AR(2) {CHANNELS}ch x {STEPS} batch", ours_s=rls,
             peer=None, peer_s=None, ratio=None,
             notes=(f"{rls / per * 1e9:.0f} ns per channel-step incl. a priori and a posteriori "
                    "errors of every order, A.16/A.17; no peer")),
    ]


if __name__ == "__main__":
    for row in run():
        print(row)
