"""What an archive holds, as plain data (for ``contactlab info``)."""

from __future__ import annotations

import os

import numpy as np

from contactlab.archive.reader import Trial, open_archive


def summarize(path: str | os.PathLike) -> dict:
    """File attributes and, per trial, duration, samples, rate, channels, labels, results.

    ``channels`` maps each measurement dataset to its width (shape[1], or 1);
    ``labels`` is None or {"names": [...], "counts": {name: samples},
    "unlabelled": samples, "segments": rows or None}.
    """
    with open_archive(path) as archive:
        trials = [summarize_trial(t) for t in archive]
        attrs = archive.attrs
    return {
        "file": str(path),
        "format_version": attrs.get("format_version"),
        "software_version": attrs.get("software_version"),
        "created": attrs.get("created"),
        "title": attrs.get("title", ""),
        "n_trials": len(trials),
        "n_samples": sum(t["n_samples"] for t in trials),
        "duration_s": sum(t["duration_s"] for t in trials),
        "trials": trials,
    }


def summarize_trial(trial: Trial) -> dict:
    """One trial's entry of :func:`summarize`."""
    labels = None
    names = trial.label_names
    if names is not None:
        codes = trial.labels
        counts = {}
        unlabelled = 0
        if codes is not None:
            values, n = np.unique(codes, return_counts=True)
            found = dict(zip(values.tolist(), n.tolist()))
            counts = {name: found.get(i, 0) for i, name in enumerate(names)}
            unlabelled = found.get(-1, 0)
        segments = trial.segments
        labels = {"names": names, "counts": counts, "unlabelled": unlabelled,
                  "segments": None if segments is None else len(segments)}
    return {
        "id": trial.id,
        "duration_s": trial.duration_s,
        "n_samples": trial.n_samples,
        "rate_hz": trial.rate_hz,
        "source": trial.attrs.get("source", ""),
        "controller": trial.attrs.get("controller", ""),
        "environment": trial.attrs.get("environment", ""),
        "channels": trial.channels(),
        "labels": labels,
        "results": trial.result_stages(),
    }
