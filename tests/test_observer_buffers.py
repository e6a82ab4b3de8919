"""The observer's row buffer against a plain reference: rows by global sample number,
appended, extended, widened and trimmed in random order, and the room it takes."""

from __future__ import annotations

import numpy as np

from contactlab.observer.paths import RowBuffer


def test_random_appends_trims_and_widenings_keep_every_live_row():
    rng = np.random.default_rng(7)
    buf = RowBuffer(2, t0=5)
    ref: dict[int, np.ndarray] = {}
    width, t0, t_end = 2, 5, 5
    for _ in range(3000):
        op = rng.integers(4)
        if op == 0:                                        # append a few rows or many
            k = int(rng.choice([1, 3, 50, 700, 4096]))
            rows = rng.standard_normal((k, width))
            buf.append(rows)
            for i in range(k):
                ref[t_end + i] = rows[i].copy()
            t_end += k
        elif op == 1:                                      # zero rows to a new end
            k = int(rng.integers(1, 300))
            buf.extend_to(t_end + k)
            for i in range(k):
                ref[t_end + i] = np.zeros(width)
            t_end += k
        elif op == 2 and rng.random() < 0.05:              # a wider row
            width += int(rng.integers(1, 4))
            buf.widen(width)
            ref = {t: np.r_[v, np.zeros(width - len(v))] for t, v in ref.items()}
        else:                                              # forget the oldest rows
            keep = int(rng.integers(t0, t_end + 1)) if rng.random() < 0.5 else t_end - 3
            keep = max(keep, t0)
            buf.trim(keep)
            for t in range(t0, min(keep, t_end)):
                ref.pop(t, None)
            t0 = min(max(keep, t0), t_end)
        assert (buf.t0, buf.t_end, buf.width) == (t0, t_end, width)
        got = buf.rows(t0, t_end)
        want = np.array([ref[t] for t in range(t0, t_end)]).reshape(t_end - t0, width)
        np.testing.assert_array_equal(got, want)


def test_an_observer_chunk_over_a_few_live_rows_takes_about_its_own_room():
    """4096-sample chunks over at most 5 live rows (the observer's log-likelihood history):
    the storage stays near one chunk, not two, and is not reallocated chunk after chunk."""
    buf = RowBuffer(8)
    t = 0
    storages = []                  # each storage the buffer held (kept alive: distinct ids)
    for _ in range(50):
        buf.extend_to(t + 4096 + 1, zero=False)
        t += 4096
        buf.trim(t - 4)
        if not storages or storages[-1] is not buf.a:
            storages.append(buf.a)
        assert buf.a.shape[0] <= 4096 + 2 * 5 + 1
    assert len(storages) <= 2
