"""ruptures' change-point search with a per-channel autoregressive cost.

ruptures' ``CostAR`` takes a 1-D signal only: given C channels it builds its
lagged regressors from the flattened array, so it is applied here per channel
and the costs summed (:class:`ChannelARCost`, the same per-channel model as
:func:`contactlab.segmentation.segment_signal`).  :class:`FastChannelARCost`
computes the identical cost from prefix sums, so a penalty grid over many
trials runs in seconds.  :func:`peer_boundaries` runs Pelt or Binseg with
either cost at the penalty ``beta sigma^2 log n``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["ChannelARCost", "FastChannelARCost", "noise_variance", "peer_boundaries",
           "MIN_SIZE", "JUMP", "BETA_GRID"]

#: shortest segment the peers may return (samples; 40 ms at 250 Hz)
MIN_SIZE = 10
#: candidate boundaries every JUMP samples (20 ms at 250 Hz)
JUMP = 5
ORDER = 2
#: penalties beta searched for the peers (penalty beta sigma^2 log n), best chosen by F1
BETA_GRID = tuple(float(b) for b in np.logspace(-0.5, 2.5, 13))


def _base_cost():
    from ruptures.base import BaseCost
    return BaseCost


class ChannelARCost(_base_cost()):
    """ruptures' ``CostAR(order)`` applied to each column and summed (multichannel AR)."""

    model = "ar-channels"

    def __init__(self, order: int = ORDER):
        self.order = order
        self.min_size = max(5, order + 1)
        self.signal = None

    def fit(self, signal):
        from ruptures.costs import CostAR
        s = np.asarray(signal, float).reshape(len(signal), -1)
        self.signal = s
        self.costs_ = [CostAR(order=self.order).fit(s[:, [c]].copy()) for c in range(s.shape[1])]
        return self

    def error(self, start, end):
        return sum(c.error(start, end) for c in self.costs_)


class FastChannelARCost(ChannelARCost):
    """The cost of :class:`ChannelARCost` from prefix sums: O(C p^3) per segment.

    Same regressors as ``CostAR`` (lags of the whole signal, first rows padded
    with the edge, intercept); the segment's least-squares residual sum is
    ``y'y - g' S^-1 g`` from prefix sums of ``[X y]' [X y]`` per channel.
    """

    model = "ar-channels-fast"

    def fit(self, signal):
        s = np.asarray(signal, float).reshape(len(signal), -1)
        self.signal = s
        p = self.order
        z = s - s.mean(axis=0)                         # the intercept absorbs the offset
        n, c = z.shape
        # column k of CostAR's regressors: z[k] repeated p times, then z[k : n - p + k]
        lags = np.stack([np.concatenate([np.repeat(z[k:k + 1], p, axis=0), z[k:n - p + k]])
                         for k in range(p)], axis=-1)            # (n, c, p)
        y = z.copy()
        y[:p] = z[p]
        cols = np.concatenate([lags, np.ones((n, c, 1)), y[:, :, None]], axis=-1)   # (n, c, p+2)
        outer = cols[:, :, :, None] * cols[:, :, None, :]
        self.prefix_ = np.concatenate([np.zeros((1, c, p + 2, p + 2)), np.cumsum(outer, axis=0)])
        return self

    def error(self, start, end):
        from ruptures.exceptions import NotEnoughPoints
        if end - start < self.min_size:
            raise NotEnoughPoints
        m = self.prefix_[end] - self.prefix_[start]
        k = self.order + 1
        g = m[:, :k, k]
        beta = np.linalg.solve(m[:, :k, :k], g[:, :, None])[:, :, 0]
        return float(np.sum(m[:, k, k] - np.sum(g * beta, axis=1)))


def noise_variance(y) -> float:
    """Robust noise variance summed over channels: (MAD of first differences / 0.6745)^2 / 2."""
    d = np.diff(np.asarray(y, float).reshape(len(y), -1), axis=0)
    mad = np.median(np.abs(d - np.median(d, axis=0)), axis=0) / 0.6745
    return float(np.sum(mad ** 2) / 2.0)


def peer_boundaries(y, times, *, algo: str, beta: float, fast: bool = True,
                    order: int = ORDER, min_size: int = MIN_SIZE, jump: int = JUMP
                    ) -> np.ndarray:
    """Boundaries (s) of ruptures ``algo`` ("Pelt"/"Binseg") at penalty beta sigma^2 log n."""
    import ruptures as rpt
    cost = FastChannelARCost(order) if fast else ChannelARCost(order)
    cls = {"Pelt": rpt.Pelt, "Binseg": rpt.Binseg}[algo]
    det = cls(custom_cost=cost, min_size=min_size, jump=jump).fit(y)
    pen = beta * noise_variance(y) * np.log(len(y))
    return np.asarray(times)[np.asarray(det.predict(pen=pen)[:-1], int)]
