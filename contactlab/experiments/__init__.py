"""The thesis experiments, by the names ``contactlab reproduce`` takes.

Each implemented experiment is a module with a function
``run(*, out_dir: Path, seed: int, quiet: bool) -> dict`` that writes its
figures, tables and page (``index.html`` + ``report.pdf``) into ``out_dir`` and
returns a JSON-able summary. The registry lists every experiment of the
thesis (chapters 6-9); those the package cannot run yet are listed as not
reproduced yet.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Experiment:
    """One thesis experiment: its name, what it reproduces, the part of the toolkit it
    exercises, and the module that runs it (None: not reproduced yet)."""

    name: str
    title: str
    thesis: str
    part: str
    module: str | None = None

    @property
    def implemented(self) -> bool:
        return self.module is not None

    @property
    def status(self) -> str:
        return "implemented" if self.implemented else "not reproduced yet"

    def runner(self) -> Callable[..., dict]:
        """The experiment's ``run`` function (imported on demand)."""
        if self.module is None:
            raise LookupError(f"{self.name} is not reproduced yet")
        return importlib.import_module(self.module).run

    def run(self, *, out_dir: Path, seed: int, quiet: bool = False) -> dict:
        out_dir = Path(out_dir)
        out_dir.mkdir(parents=True, exist_ok=True)
        return self.runner()(out_dir=out_dir, seed=seed, quiet=quiet)


_F = "Foundation"
_S = "Simulator and acquire"
_T = "Temporal features"
_C = "Constraint estimation"
_O = "Feature graphs and observer"
_K = "Tasks"

EXPERIMENTS: dict[str, Experiment] = {e.name: e for e in [
    Experiment("ph-demo", "Page-Hinkley on a change in mean", "6.3.1, figs 6.4, 6.6", _F,
               "contactlab.experiments.ph_demo"),
    Experiment("ph-roc", "ROC of Page-Hinkley and lowpass+threshold", "6.3.1, figs 6.3, 6.5", _F,
               "contactlab.experiments.ph_roc"),
    Experiment("datasets", "One typical simulated trial per dataset spec",
               "7.2, 7.3, 8.1.1.2, 9.1; figs 7.5, 9.1", _S, "contactlab.experiments.datasets"),
    Experiment("impact-spectrogram", "Spectrogram of an impact", "7.1, fig 7.1", _T,
               "contactlab.experiments.impact_spectrogram"),
    Experiment("ar-fit", "AR(4) fit of a texture strain", "7.1, fig 7.2", _T,
               "contactlab.experiments.ar_fit"),
    Experiment("impact-envelope", "Log-energy envelope of an impact", "7.1, fig 7.3", _T,
               "contactlab.experiments.impact_envelope"),
    Experiment("stroke-segmentation", "AR segmentation of a stroke", "7.2.1, figs 7.5, 7.7", _T,
               "contactlab.experiments.stroke_segmentation"),
    Experiment("texture-labelling", "Labelling two-texture samples", "7.2.2, fig 7.8", _T,
               "contactlab.experiments.texture_labelling"),
    Experiment("hf-models", "High-frequency models", "7.3, fig 7.9", _T,
               "contactlab.experiments.hf_models"),
    Experiment("hf-recognition", "High-frequency recognition", "7.3.1-7.3.3, fig 7.10", _O,
               "contactlab.experiments.hf_recognition"),
    Experiment("cartesian-estimation", "Cartesian constraint estimation",
               "8.1.1.2, tables 8.1-8.5, figs 8.1-8.2", _C,
               "contactlab.experiments.cartesian_estimation"),
    Experiment("polygon-estimation", "Planar polygon estimation", "8.1.3.5, figs 8.4-8.5", _C,
               "contactlab.experiments.polygon_estimation"),
    Experiment("constraint-degree", "Degree of constraint", "8.2", _C,
               "contactlab.experiments.constraint_degree"),
    Experiment("constraint-direction", "Direction of constraint", "8.3, fig 8.6", _C,
               "contactlab.experiments.constraint_direction"),
    Experiment("apparatus", "The thesis's signal facts on the simulator",
               "3.3, 4.3, 7.2-7.3, 8.1.1.2, 9.1-9.2", _S, "contactlab.experiments.apparatus"),
    Experiment("guarded-move", "Guarded move onto a surface", "9.1.1, fig 9.1", _K,
               "contactlab.experiments.guarded_move"),
    Experiment("guarded-move-multi", "Guarded move into a corner", "9.1.2, figs 9.2-9.3", _K,
               "contactlab.experiments.guarded_move_multi"),
    Experiment("guarded-move-actions", "Action-dependent guarded moves", "9.1.3, figs 9.4-9.5", _K,
               "contactlab.experiments.guarded_move_actions"),
    Experiment("maze", "The gear-shift maze", "9.2, figs 9.6-9.8", _K, "contactlab.experiments.maze"),
]}


def get(name: str) -> Experiment:
    """The experiment called ``name``; KeyError lists the known names."""
    try:
        return EXPERIMENTS[name]
    except KeyError:
        raise KeyError(f"unknown experiment {name!r}; known: {', '.join(EXPERIMENTS)}") from None
