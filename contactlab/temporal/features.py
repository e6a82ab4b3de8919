"""Block features of 7.2.2 / A.2.3: per block and channel, an AR(p) fit by the
square-root RLS and its orthogonal parameters.

A block of ``block`` samples of one channel gives ``M = block - p`` regression
rows (the first p samples are the history of the first row: no row reaches
outside its block, so a block inside one labelled run never sees another
label).  The RLS factor of the block, ``L L^T = A^T A`` with ``A`` the (M, q)
regressor matrix (q = p, or p + 1 with a mean), gives

* ``k~ = Q^T Y`` -- the unnormalised reflection coefficients (A.12), with
  ``A = Q L^T`` (Q orthonormal columns);
* ``S^{1/2} = diag(L)`` -- eq. 7.3's ``S`` is the diagonal of the QR factor,
  so ``A = Q S^{1/2} R`` with R unit upper-triangular (A.42);
* the orthogonal parameters (the thesis's LPC coefficients k of 7.3)
  ``k = S^{-1/2} k~ = R theta``
  (:meth:`~contactlab.estimators.rls.SquareRootRLS.orthogonal_coef`);
* the residual energy ``e^2 = Y^T Y - k~^T k~`` and the driving-noise
  variance ``e^2 / (M - q)`` (unbiased: ``e^2 ~ V_nu chi2(M - q)``).

All blocks of all channels run as one batch of the RLS kernel.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from contactlab.estimators import ARModel, SquareRootRLS

__all__ = ["BlockFeatures", "block_features", "min_block"]


def min_block(order: int, mean: bool) -> int:
    """Shortest block that defines the parameters and a noise variance:
    ``p`` history samples plus ``q + 1`` rows."""
    q = int(order) + int(bool(mean))
    return int(order) + q + 1


@dataclass(frozen=True, eq=False)
class BlockFeatures:
    """Features of K blocks of C channels (see the module notes).

    Attributes
    ----------
    orthogonal : (K, C, q) orthogonal parameters k (7.3), thesis order
        ``{mu, a_1, ...}`` when the model has a mean.
    coef : (K, C, q) natural AR parameters theta (A.13).
    reflection : (K, C, q) k~ = Q^T Y.
    scale : (K, C, q) ``S^{1/2} = diag(L)``.
    info_sqrt : (K, C, q, q) L, lower-triangular, ``L L^T = A^T A``.
    residual_energy : (K, C) e^2.
    noise_var : (K, C) ``e^2 / (M - q)``.
    rows : M, regression rows per block.
    """

    orthogonal: np.ndarray
    coef: np.ndarray
    reflection: np.ndarray
    scale: np.ndarray
    info_sqrt: np.ndarray
    residual_energy: np.ndarray
    noise_var: np.ndarray
    rows: int
    order: int
    mean: bool

    @property
    def ml_noise_var(self) -> np.ndarray:
        """(K, C) maximum-likelihood driving-noise variance ``e^2 / M``."""
        return self.residual_energy / self.rows

    @property
    def n_blocks(self) -> int:
        return int(self.orthogonal.shape[0])

    @property
    def channels(self) -> int:
        return int(self.orthogonal.shape[1])

    @property
    def n_params(self) -> int:
        return int(self.orthogonal.shape[2])

    def take(self, index) -> "BlockFeatures":
        """The features of the blocks ``index`` (bool mask or integer indices)."""
        return BlockFeatures(
            orthogonal=self.orthogonal[index], coef=self.coef[index],
            reflection=self.reflection[index], scale=self.scale[index],
            info_sqrt=self.info_sqrt[index], residual_energy=self.residual_energy[index],
            noise_var=self.noise_var[index], rows=self.rows, order=self.order, mean=self.mean)

    @staticmethod
    def concat(parts: list["BlockFeatures"], *, order: int, mean: bool, block: int,
               channels: int) -> "BlockFeatures":
        """Blocks of several signals together (an empty list gives K = 0)."""
        q = order + int(mean)
        if not parts:
            z = np.zeros((0, channels, q))
            return BlockFeatures(z, z.copy(), z.copy(), z.copy(), np.zeros((0, channels, q, q)),
                                 np.zeros((0, channels)), np.zeros((0, channels)),
                                 block - order, order, mean)
        cat = lambda name: np.concatenate([getattr(f, name) for f in parts])  # noqa: E731
        return BlockFeatures(cat("orthogonal"), cat("coef"), cat("reflection"), cat("scale"),
                             cat("info_sqrt"), cat("residual_energy"), cat("noise_var"),
                             parts[0].rows, order, mean)


def block_windows(y: np.ndarray, starts, block: int) -> np.ndarray:
    """(block, K, C) the samples ``y[s:s + block]`` of every start s."""
    starts = np.asarray(starts, dtype=np.int64)
    idx = starts[None, :] + np.arange(block)[:, None]
    return y[idx]


def block_features(y, *, order: int = 2, mean: bool = False, block: int = 100,
                   starts=None) -> BlockFeatures:
    """Features of the blocks of ``y`` (N,) or (N, C) starting at ``starts``.

    ``starts`` (K,) sample indices (default: consecutive blocks from 0, the
    remainder dropped).  Every channel of every block is its own AR(``order``)
    model (with a mean if ``mean``), all fitted in one batched square-root RLS
    run (A.10-A.13).
    """
    a = np.asarray(y, dtype=np.float64)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2:
        raise ValueError(f"y must be (N,) or (N, C) with time first; got {a.shape}")
    order, block = int(order), int(block)
    if block < min_block(order, mean):
        raise ValueError(f"block of {block} samples is shorter than AR({order})"
                         f"{' with a mean' if mean else ''} needs ({min_block(order, mean)})")
    n, C = a.shape
    if starts is None:
        starts = np.arange(0, n - block + 1, block)
    starts = np.asarray(starts, dtype=np.int64)
    if starts.size and (starts.min() < 0 or starts.max() + block > n):
        raise ValueError(f"blocks must lie inside the signal of {n} samples")
    K = starts.size
    model = ARModel(order=order, mean=bool(mean))
    q = model.n_params
    if K == 0:
        return BlockFeatures.concat([], order=order, mean=bool(mean), block=block, channels=C)
    win = block_windows(a, starts, block).reshape(block, K * C)     # batch index = k * C + c
    psi, target = model.design(win)
    rls = SquareRootRLS(variance_warmup=0)
    rls.run(np.ascontiguousarray(psi), np.ascontiguousarray(target))
    M = psi.shape[0]
    L = rls.info_sqrt_.copy()
    with np.errstate(divide="ignore", invalid="ignore"):
        coef = rls.coef()
        ortho = rls.orthogonal_coef()
    e2 = rls.residual_energy_.copy()
    shape = (K, C)
    return BlockFeatures(
        orthogonal=ortho.reshape(*shape, q), coef=coef.reshape(*shape, q),
        reflection=rls.reflection_.copy().reshape(*shape, q),
        scale=np.diagonal(L, axis1=1, axis2=2).copy().reshape(*shape, q),
        info_sqrt=L.reshape(*shape, q, q), residual_energy=e2.reshape(shape),
        noise_var=(e2 / (M - q)).reshape(shape), rows=M, order=order, mean=bool(mean))
