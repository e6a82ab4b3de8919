"""How well the recognised path's models fit the measurements: the check behind the
"the data fit none of the models" warning of ``contactlab recognize``.

The observer always returns a most probable path, even when every model of the
graph is wrong for the data (a recording noisier than the one the models were
trained on, a force sensor that was not zeroed, another sensor's units): the
path is then the least bad explanation, and its labels mean little.  Under a
model that fits, the chi-square statistic of an instance's innovation (6.11)
has the innovation's dimension as its mean, so its mean per degree of freedom
is near 1 along the final MAP path.  :func:`path_fit` re-scores the path the
way the observer scored it -- each segment by fresh instances of its node's
models from the segment's start (6.4) -- and returns that mean per model and
over all of them.

The misfit is judged by a robust form of the same level: per model, the median of its
chi-square values over the chi-square distribution's median for the innovation's
dimension (``chdtri(d, 1/2)``): 1 when the model fits, ``k^2`` when the noise is ``k``
times the trained one, like the mean, but blind to a minority of wild samples.  A real
recording has them -- the HIRO snap-fit trials' position jumps by 5 cm in one sample when
the controller switches state, a velocity of 11 m/s whose one chi-square of 10^6 puts the
mean per degree of freedom at 50-280 on trials the models recognise to 99 %.
``overall`` is the models' robust levels weighted by their degrees of freedom; the mean
stays in ``by_model_mean``.

:data:`MISFIT` is the level above which ``recognize`` warns.  Measured with the mean
before the robust level replaced it: 0.47-0.53 on free-contact recordings
(:mod:`contactlab.synthetic.free_contact`) the models were trained for, 0.95-1.09 on the
switching suite (:mod:`contactlab.synthetic.switching`), 2.8-7.3 on the simulated guarded
move (its still-finger velocity model meets a finger that slides), 279 on a free-contact
recording with 5x the trained force noise and a 0.2 N offset.  With the robust level:
0.47 on a synthetic free-contact recording, 0.4-1.2 on the 13 real HIRO snap-fit trials
recognised with free-contact models trained on 14 others (the mean: 38-279, every trial
warned; the worst model 0.8-4.9 with free-contact's friction-compensated constraint
models, 5-8 without), 22 for the contact model on the second half of the wiping
recording trained on its first (80 % recognised), 12.7 for the impact model on the
5x-noise recording (59 % recognised, overall 3.0).  So a path warns when one of its
models' level passes :data:`MISFIT`.  A noise k times
the trained one alone gives k^2 on that model (tests/test_observer_fit.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["PathFit", "path_fit", "MISFIT"]

#: robust chi-square level per degree of freedom of any one model along the MAP path
#: above which the data are said to fit none of the models (module notes): the segments
#: that model explains are not explained, even where the others fit
MISFIT = 8.0


@dataclass(frozen=True)
class PathFit:
    """Mean chi-square per degree of freedom of the MAP path's innovations.

    overall : over every model on the path: their robust levels (module notes) weighted
        by samples x dimension.
    by_model : model name -> its robust level over the segments whose node uses it.
    worst : the model with the largest robust level (None for an empty path).
    samples : samples scored.
    by_model_mean : model name -> its mean chi-square per degree of freedom.
    """

    overall: float
    by_model: dict
    worst: str | None
    samples: int
    by_model_mean: dict | None = None

    @property
    def misfit(self) -> bool:
        # the overall level is a weighted mean of the models': at most the worst one's
        worst = self.by_model.get(self.worst, np.nan) if self.worst else np.nan
        return bool(np.isfinite(worst) and worst > MISFIT)

    def to_dict(self) -> dict:
        return {"chi2_per_dof": _num(self.overall), "worst_model": self.worst,
                "by_model": {k: _num(v) for k, v in self.by_model.items()},
                "by_model_mean": {k: _num(v) for k, v in (self.by_model_mean or {}).items()},
                "misfit": self.misfit}


def _num(x: float):
    return float(x) if np.isfinite(x) else None


def _chi(stat) -> np.ndarray:
    """The first instance's chi-square per sample from a model's ``run`` statistics."""
    chi = np.asarray(stat, np.float64)
    chi = chi[..., 0] if chi.ndim == 3 else chi
    return chi[:, 0]


def path_fit(graph, models: dict, data: dict, map_path, n: int | None = None) -> PathFit:
    """Score ``map_path`` (``[(node name, start sample), ...]``) on ``data`` (signal ->
    ``(n, C)`` array, the conditioned streams the observer read) with fresh instances of
    each segment's node models (``models``: name -> model object).  Linear in the data."""
    arrays = {s: np.asarray(a, np.float64).reshape(len(a), -1) for s, a in data.items()}
    if n is None:
        n = min((len(a) for a in arrays.values()), default=0)
    nodes = {nd.name: nd for nd in graph.nodes}
    tot: dict[str, float] = {}
    dof: dict[str, float] = {}
    values: dict[str, list] = {}
    dims: dict[str, int] = {}
    scored = 0
    whole: dict = {}            # a stateless model's chi-square over all samples, run once
    bounds = [s for _, s in map_path[1:]] + [n]
    for (name, a), b in zip(map_path, bounds):
        a, b = int(a), int(min(b, n))
        if b <= a:
            continue
        scored += b - a
        for mname in nodes[name].model_names:
            m = models[mname]
            x = arrays[m.signal]
            lag = int(m.lag)
            a0 = max(a, lag)                      # the observer's first prediction needs lag
            if b <= a0:
                continue
            starts = np.array([a0])
            state = m.init_state(starts, x.shape[1])
            if isinstance(state, dict) and not state:   # stateless: every instance alike
                if mname not in whole:             # chi2: the chi-square alone, if cheaper
                    whole[mname] = (m.chi2(x[lag:n]) if hasattr(m, "chi2") else
                                    _chi(m.run(state, x[:n], t0=lag, starts=starts)[1]))
                chi = whole[mname][a0 - lag:b - lag]
            else:
                chi = _chi(m.run(state, x[a0 - lag:b], t0=a0, starts=starts)[1])
            ok = np.isfinite(chi)
            tot[mname] = tot.get(mname, 0.0) + float(chi[ok].sum())
            dof[mname] = dof.get(mname, 0.0) + float(ok.sum()) * m.dim(x.shape[1])
            values.setdefault(mname, []).append(chi[ok])
            dims[mname] = m.dim(x.shape[1])
    from scipy.special import chdtri

    mean = {k: tot[k] / dof[k] for k in tot if dof[k] > 0}
    by_model = {k: float(np.median(np.concatenate(values[k]))) / float(chdtri(dims[k], 0.5))
                for k in mean}
    total_dof = sum(dof[k] for k in by_model)
    overall = (sum(by_model[k] * dof[k] for k in by_model) / total_dof if total_dof > 0
               else float("nan"))
    worst = max(by_model, key=by_model.get) if by_model else None
    return PathFit(overall, by_model, worst, scored, mean)
