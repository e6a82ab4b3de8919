"""The ruptures-style Segmenter: the same boundaries as the functions it wraps."""

import numpy as np
import pytest
from ruptures.metrics import precision_recall
from sklearn.base import clone

from contactlab.errors import UsageError
from contactlab.segmentation import segment_glr, segment_level, segment_signal
from contactlab.segmenter import Segmenter
from contactlab.synthetic import piecewise_ar
from contactlab.synthetic.free_contact import free_contact_recording


@pytest.fixture(scope="module")
def wrench():
    return free_contact_recording(seed=1, fs=500.0, cycles=3)


@pytest.fixture(scope="module")
def strains():
    return piecewise_ar(seed=0, duration_s=4.0, channels=4)


def test_level_matches_segment_level_and_ends_with_length(wrench):
    seg = Segmenter(method="level").fit(wrench.force, fs=wrench.fs)
    ref = segment_level(wrench.force, fs=wrench.fs)
    np.testing.assert_array_equal(seg.boundaries_, ref.boundaries)
    np.testing.assert_array_equal(seg.events_, ref.events)
    bkps = seg.predict()
    assert bkps == [*ref.boundaries.tolist(), len(wrench.force)]
    assert all(isinstance(b, int) for b in bkps)
    assert seg.n_samples_ == len(wrench.force) and seg.fs_ == wrench.fs
    np.testing.assert_allclose(seg.boundaries_s_, ref.boundaries / wrench.fs)


def test_level_finds_the_labelled_phases_by_ruptures_metric(wrench):
    contact = (wrench.labels == 2).astype(int)           # contact made and broken
    truth = [*(np.flatnonzero(np.diff(contact)) + 1).tolist(), len(contact)]
    bkps = Segmenter(method="level").fit_predict(wrench.force, fs=wrench.fs)
    p, r = precision_recall(truth, bkps, margin=int(0.1 * wrench.fs))
    assert p >= 0.8 and r >= 0.8


def test_glr_matches_segment_glr(strains):
    seg = Segmenter(method="glr", threshold=8.0, window_s=0.2).fit(strains.y, fs=strains.fs)
    ref = segment_glr(strains.y, fs=strains.fs, threshold=8.0, window_s=0.2)
    np.testing.assert_array_equal(seg.boundaries_, ref.boundaries)
    assert seg.events_.size == 0
    truth = [*strains.boundaries.tolist(), len(strains.y)]
    p, r = precision_recall(truth, seg.predict(), margin=int(0.05 * strains.fs))
    assert r >= 0.8


def test_page_hinkley_matches_segment_signal(strains):
    seg = Segmenter(method="page-hinkley", threshold=50.0, order=2).fit(strains.y, fs=strains.fs)
    ref = segment_signal(strains.y, fs=strains.fs, threshold=50.0, order=2)
    np.testing.assert_array_equal(seg.boundaries_, ref.boundaries)
    assert seg.predict()[-1] == len(strains.y)


def test_constructor_only_stores_and_clones():
    seg = Segmenter(method="nonsense", threshold=-1)      # checked at fit, not here
    assert seg.get_params()["method"] == "nonsense"
    c = clone(Segmenter(method="glr", threshold=4.0))
    assert c.get_params()["threshold"] == 4.0 and not hasattr(c, "boundaries_")
    with pytest.raises(UsageError, match="method must be one of"):
        seg.fit(np.zeros((100, 3)), fs=100.0)


def test_predict_before_fit_and_bad_fs():
    with pytest.raises(UsageError, match="not fitted"):
        Segmenter().predict()
    with pytest.raises(UsageError, match="fs"):
        Segmenter().fit(np.zeros((100, 3)), fs=0)
