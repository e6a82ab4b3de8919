"""Trained temporal models of chapter 7: AR features of blocks, per-class priors,
likelihood labelling (7.2.2, eqs 7.3-7.5, A.2.3).

- :mod:`.features`   block features: square-root RLS AR(p) per block and
  channel -> orthogonal parameters and driving-noise variance (A.2.3)
- :mod:`.blocks`     labelled runs of a trial's conditioned signal and the
  blocks cut from them (never across a label change)
- :mod:`.model`      :class:`TemporalModel` (one class), :class:`ModelSet`
  (what ``contactlab train`` writes; HDF5 format in datasets_spec/MODELS.md)
- :mod:`.likelihood` the marginal likelihood of a block under a class (7.4-7.5)
- :mod:`.train`      :func:`train_temporal` (from an archive), :func:`fit_temporal` (arrays)
- :mod:`.label`      :func:`label_archive` (``contactlab label``), leave-one-out
- :mod:`.energy`     the log-energy normal-fit predicted error (7.2.2, fig 7.8)
"""

from contactlab.temporal.energy import normal_confusion_1d, normal_error_1d
from contactlab.temporal.features import BlockFeatures, block_features
from contactlab.temporal.label import label_archive
from contactlab.temporal.likelihood import block_loglik
from contactlab.temporal.model import ModelSet, TemporalModel
from contactlab.temporal.train import (LabelledBlocks, collect_blocks, fit_models, fit_temporal,
                                      train_temporal)

__all__ = ["TemporalModel", "ModelSet", "train_temporal", "fit_temporal", "label_archive",
           "BlockFeatures", "block_features", "block_loglik", "LabelledBlocks",
           "collect_blocks", "fit_models", "normal_confusion_1d", "normal_error_1d"]
