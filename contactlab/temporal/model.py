"""Trained temporal models: one :class:`TemporalModel` per class, a
:class:`ModelSet` per signal (what ``contactlab train`` writes).

File format (HDF5, documented in ``datasets_spec/MODELS.md``)::

    /                      attrs format="contactlab-models", format_version="1.0",
                                 signal, fs, labels (in order), channels,
                                 provenance (JSON)
    /models/<i>/           attrs label, order, mean, n_blocks, block
        theta_mean         (C, q) float64
        theta_cov          (C, q, q) float64
        structure_sqrt     (C, q, q) float64
        noise_var          (C,) float64
        level_sd           (C,) float64   (format 1.1; optional: absent reads as 0)
        level_mean         (C,) float64   (format 1.2; optional: absent reads as 0)
        level_cov          (C, q) float64 (format 1.2; optional: absent reads as 0)

Groups are numbered (labels are free text); ``labels`` gives their order.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from contactlab.errors import DataError
from contactlab.estimators import ARModel, OrthogonalKalman
from contactlab.temporal.features import BlockFeatures

__all__ = ["TemporalModel", "ModelSet", "fit_class", "FORMAT", "FORMAT_VERSION"]

FORMAT = "contactlab-models"
FORMAT_VERSION = "1.2"
_LEVEL = ("level_sd", "level_mean", "level_cov")
_ARRAYS = ("theta_mean", "theta_cov", "structure_sqrt", "noise_var")


@dataclass(frozen=True, eq=False)
class TemporalModel:
    """One class (node) of one conditioned signal: per channel, the prior of the
    orthogonal parameters and the driving-noise variance (A.2.3, 7.2.2).

    Attributes
    ----------
    label : the class name.
    order, mean : AR(order) with a constant regressor if ``mean`` (q = order + mean
        parameters, thesis order ``{mu, a_1, ...}``).
    theta_mean : (C, q) prior mean of the orthogonal parameters k (7.3).
    theta_cov : (C, q, q) their prior covariance (sample covariance over blocks).
    structure_sqrt : (C, q, q) lower-triangular information factor L of all
        training rows pooled (``L L^T = sum_blocks A^T A``); its normalised
        shape ``R = D^{-1/2} L^T`` (A.42) is the structure of
        ``kalman(structure="fixed")``.
    noise_var : (C,) driving-noise variance V_nu (mean over blocks of the
        unbiased per-block estimate).
    n_blocks : training blocks; block : training block length (samples).
    level_sd : (C,) spread of the log amplitude over the training blocks
        (:mod:`contactlab.temporal.level`); zeros give 7.4-7.5 exactly.
    level_mean : (C,) mean log amplitude of the drive, relative to ``noise_var``.
    level_cov : (C, q) covariance of the log amplitude with the orthogonal
        parameters (the drive moving with the spectrum, :mod:`.level`).
    """

    label: str
    order: int
    mean: bool
    theta_mean: np.ndarray
    theta_cov: np.ndarray
    structure_sqrt: np.ndarray
    noise_var: np.ndarray
    n_blocks: int
    block: int
    level_sd: np.ndarray | None = None
    level_mean: np.ndarray | None = None
    level_cov: np.ndarray | None = None

    def __post_init__(self):
        for name, shape in (("level_sd", np.shape(self.noise_var)),
                            ("level_mean", np.shape(self.noise_var)),
                            ("level_cov", np.shape(self.theta_mean))):
            if getattr(self, name) is None:
                object.__setattr__(self, name, np.zeros(shape))

    @property
    def channels(self) -> int:
        return int(self.theta_mean.shape[0])

    @property
    def n_params(self) -> int:
        return int(self.theta_mean.shape[1])

    @property
    def ar_model(self) -> ARModel:
        return ARModel(order=self.order, mean=self.mean)

    def regressors(self, y) -> np.ndarray:
        """(M, C, q) regressor rows of ``y`` (N, C) (``ARModel(order, mean).regressors``)."""
        return self.ar_model.regressors(y)

    def kalman(self, *, structure: str = "fixed") -> OrthogonalKalman:
        """A square-root Kalman filter on orthogonal regressors (A.40-A.42) with
        this class's prior, one filter per channel (batch C, scalar measurements).

        ``"fixed"``: the training structure (the exact Kalman filter of the
        reparametrised model).  ``"track"``: the structure starts from the
        training factor scaled to one block's weight (``L / sqrt(n_blocks)``)
        and is updated on-line.
        """
        L = self.structure_sqrt
        if structure == "track":
            L = L / np.sqrt(max(self.n_blocks, 1))
        return OrthogonalKalman(theta0=self.theta_mean,
                                theta_sqrt0=np.linalg.cholesky(self.theta_cov),
                                noise_sqrt=np.sqrt(self.noise_var)[:, None, None],
                                structure=structure, structure_sqrt0=L)

    def same_as(self, other: "TemporalModel") -> bool:
        """True when every field is identical (arrays bit for bit)."""
        return (self.label == other.label and self.order == other.order
                and self.mean == other.mean and self.n_blocks == other.n_blocks
                and self.block == other.block
                and all(np.array_equal(getattr(self, a), getattr(other, a))
                        for a in _ARRAYS + _LEVEL))


def fit_class(label: str, features: BlockFeatures, *, block: int) -> TemporalModel:
    """Fit one class from its blocks' features.

    Raises ValueError when there are no blocks or too few for the covariance
    (K <= q) or the covariance is singular; callers turn it into a DataError.
    """
    K, C, q = features.orthogonal.shape
    if K == 0:
        raise ValueError(f"class {label!r} has no training blocks: none of its labelled runs "
                         f"is {block} conditioned samples long (a shorter --block, or more "
                         "runs)")
    if K <= q:
        raise ValueError(f"class {label!r} has {K} training block{'s' * (K != 1)}; the "
                         f"covariance of {q} parameters needs at least {q + 1} (a shorter "
                         "--block, or more runs)")
    x = features.orthogonal
    if not np.isfinite(x).all() or not np.isfinite(features.noise_var).all():
        raise ValueError(f"class {label!r}: some blocks have a singular AR fit "
                         "(a constant channel?)")
    mean = x.mean(axis=0)
    d = x - mean
    cov = np.einsum("kci,kcj->cij", d, d) / (K - 1)
    try:
        np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:
        raise ValueError(f"class {label!r}: the covariance of the orthogonal parameters "
                         "is singular (identical blocks or a constant channel)") from None
    info = np.einsum("kcij,kclj->cil", features.info_sqrt, features.info_sqrt)
    structure = np.linalg.cholesky(info)
    from contactlab.temporal.level import level_model
    u0, tau, c = level_model(features)
    return TemporalModel(label=str(label), order=features.order, mean=features.mean,
                         theta_mean=mean, theta_cov=cov, structure_sqrt=structure,
                         noise_var=features.noise_var.mean(axis=0), n_blocks=int(K),
                         block=int(block), level_sd=tau, level_mean=u0, level_cov=c)


@dataclass
class ModelSet:
    """The class models of one conditioned signal (``contactlab train``'s output).

    models : by label, in label order.  signal : "strain" | "wrench" | "hf".
    fs : the conditioned signal's sample rate (Hz).  provenance : archive path
    and sha256, trial ids, label source, block, order, mean, created (UTC
    ISO), contactlab version, command line.  channels : indices of the
    signal's channels the models use (None: all).
    """

    models: dict[str, TemporalModel]
    signal: str
    fs: float
    provenance: dict = field(default_factory=dict)
    channels: list[int] | None = None

    @property
    def labels(self) -> list[str]:
        return list(self.models)

    @property
    def order(self) -> int:
        return next(iter(self.models.values())).order

    @property
    def mean(self) -> bool:
        return next(iter(self.models.values())).mean

    @property
    def block(self) -> int:
        return next(iter(self.models.values())).block

    def same_as(self, other: "ModelSet") -> bool:
        """True when both hold identical models, signal, rate, channels and provenance."""
        return (self.labels == other.labels and self.signal == other.signal
                and self.fs == other.fs and self.provenance == other.provenance
                and self.channels == other.channels
                and all(m.same_as(other.models[k]) for k, m in self.models.items()))

    # -- file ---------------------------------------------------------------------------
    def save(self, path: str | os.PathLike, *, force: bool = False) -> None:
        """Write the models to ``path`` atomically (refuses to overwrite unless ``force``)."""
        from contactlab.fileio import atomic_path

        if not self.models:
            raise ValueError("a ModelSet needs at least one model")
        text = h5py.string_dtype("utf-8")
        with atomic_path(path, force=force) as tmp:
            with h5py.File(tmp, "w") as h5:
                h5.attrs["format"] = FORMAT
                h5.attrs["format_version"] = FORMAT_VERSION
                h5.attrs["signal"] = self.signal
                h5.attrs["fs"] = float(self.fs)
                h5.attrs.create("labels", np.array(self.labels, dtype=object), dtype=text)
                h5.attrs["channels"] = json.dumps(self.channels)
                h5.attrs["provenance"] = json.dumps(self.provenance, sort_keys=True)
                group = h5.create_group("models")
                for i, m in enumerate(self.models.values()):
                    g = group.create_group(str(i))
                    g.attrs["label"] = m.label
                    g.attrs["order"] = int(m.order)
                    g.attrs["mean"] = bool(m.mean)
                    g.attrs["n_blocks"] = int(m.n_blocks)
                    g.attrs["block"] = int(m.block)
                    for name in _ARRAYS + _LEVEL:
                        g.create_dataset(name, data=np.asarray(getattr(m, name), np.float64))

    @classmethod
    def load(cls, path: str | os.PathLike) -> "ModelSet":
        """Read a models file; DataError naming the file and field on bad input."""
        from contactlab.archive.reader import open_h5, unreadable_as_data_error

        path = Path(path)
        h5 = open_h5(path)
        try:
            with unreadable_as_data_error(path, "/"):
                return cls._read(h5, path)
        except (TypeError, ValueError, OverflowError) as exc:  # an attribute of the wrong type
            raise DataError(f"malformed models file ({exc})", file=str(path)) from None
        finally:
            h5.close()

    @classmethod
    def _read(cls, h5: h5py.File, path: Path) -> "ModelSet":
        def err(msg, fld):
            return DataError(msg, file=str(path), field=fld)

        def attr(obj, name, where):
            if name not in obj.attrs:
                raise err(f"missing attribute {name!r}", where)
            v = obj.attrs[name]
            return v.decode() if isinstance(v, bytes) else v

        fmt = h5.attrs.get("format")
        fmt = fmt.decode() if isinstance(fmt, bytes) else fmt
        if fmt != FORMAT:
            raise err(f"not a contactlab models file (format is {fmt!r}, expected {FORMAT!r})",
                      "/format")
        version = str(attr(h5, "format_version", "/"))
        if version.split(".")[0] != FORMAT_VERSION.split(".")[0]:
            raise err(f"unsupported format_version {version!r} (this contactlab reads 1.x)",
                      "/format_version")
        from contactlab.signals import SIGNALS

        signal = str(attr(h5, "signal", "/"))
        if signal not in SIGNALS:
            raise err(f"unknown signal {signal!r} (known: {', '.join(SIGNALS)})", "/signal")
        fs = attr(h5, "fs", "/")
        if isinstance(fs, (bool, np.bool_)) or not isinstance(fs, (int, float, np.number)) \
                or not (np.isfinite(fs) and fs > 0):
            raise err(f"must be a sample rate > 0 Hz; got {getattr(fs, 'item', lambda: fs)()!r}",
                      "/fs")
        fs = float(fs)
        labels = [s.decode() if isinstance(s, bytes) else str(s)
                  for s in np.atleast_1d(attr(h5, "labels", "/"))]
        try:
            provenance = json.loads(attr(h5, "provenance", "/"))
            channels = json.loads(attr(h5, "channels", "/"))
        except (TypeError, ValueError):
            raise err("provenance/channels are not valid JSON", "/provenance") from None
        group = h5.get("models")
        if not labels and isinstance(h5.get("constraints"), h5py.Group):
            raise err("holds no temporal models: it was trained with --graph for a graph's "
                      "constraint and velocity models only (train without --graph for "
                      "'label')", "/models")
        if not isinstance(group, h5py.Group) or len(group) != len(labels) or not labels:
            raise err(f"expected {len(labels)} model groups (one per label)", "/models")
        models: dict[str, TemporalModel] = {}
        shape = None
        for i, label in enumerate(labels):
            where = f"/models/{i}"
            g = group.get(str(i))
            if not isinstance(g, h5py.Group):
                raise err("missing group", where)
            if str(attr(g, "label", where)) != label:
                raise err(f"label {attr(g, 'label', where)!r} does not match /labels[{i}] "
                          f"{label!r}", f"{where}/label")
            arrays = {}
            for name in _ARRAYS:
                ds = g.get(name)
                if not isinstance(ds, h5py.Dataset):
                    raise err("missing dataset", f"{where}/{name}")
                if ds.dtype.kind not in "fiu":
                    raise err(f"dtype {ds.dtype}, expected float", f"{where}/{name}")
                arrays[name] = np.asarray(ds[()], dtype=np.float64)
            order, mean = int(attr(g, "order", where)), bool(attr(g, "mean", where))
            C = arrays["noise_var"].shape[0] if arrays["noise_var"].ndim == 1 else -1
            q = order + int(mean)
            want = {"theta_mean": (C, q), "theta_cov": (C, q, q), "structure_sqrt": (C, q, q),
                    "noise_var": (C,)}
            for name, sh in want.items():
                if C < 1 or arrays[name].shape != sh:
                    raise err(f"shape {arrays[name].shape}, expected {sh} (C channels, q={q} "
                              "parameters)", f"{where}/{name}")
                if not np.isfinite(arrays[name]).all():
                    raise err("has NaN or infinite values", f"{where}/{name}")
            if np.any(arrays["noise_var"] <= 0):
                raise err("noise variances must be > 0", f"{where}/noise_var")
            for name, sh, low in (("level_sd", (C,), 0.0), ("level_mean", (C,), -np.inf),
                                  ("level_cov", (C, q), -np.inf)):
                ds = g.get(name)
                if isinstance(ds, h5py.Dataset):
                    if ds.dtype.kind not in "fiu":
                        raise err(f"dtype {ds.dtype}, expected float", f"{where}/{name}")
                    arrays[name] = np.asarray(ds[()], dtype=np.float64)
                    if arrays[name].shape != sh or not (np.isfinite(arrays[name]).all()
                                                        and (arrays[name] >= low).all()):
                        raise err(f"expected {sh} finite values"
                                  + (" >= 0" if low == 0 else ""), f"{where}/{name}")
            if shape is not None and (C, order, mean) != shape:
                raise err("models of one file must share channels, order and mean", where)
            shape = (C, order, mean)
            models[label] = TemporalModel(label=label, order=order, mean=mean,
                                          n_blocks=int(attr(g, "n_blocks", where)),
                                          block=int(attr(g, "block", where)), **arrays)
        return cls(models=models, signal=signal, fs=fs, provenance=provenance,
                   channels=channels)
