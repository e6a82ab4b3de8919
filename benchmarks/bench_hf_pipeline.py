"""bench: the demo's pipeline on seeds it was not developed on, beside the supervised HMM.

For each of seeds 11-15, the 7.3 runs are simulated (``hf-train`` and ``hf-test``, the
demo's data) and recognised as ``make demo`` does, with default flags: the thesis's
context-free models (``hf-context-free``), our Gaussian hypotheses (``hf-gaussian``:
trained levels, a change priced and the start taken from the training labels) and the
same with the edges and their probabilities learned from the training labels (``graph
learn --models-from hf-gaussian``).  Peer: the supervised Gaussian HMM on the same y_h
points (:func:`contactlab.peers.hmm.point_accuracy`: emissions and transitions from the
same labels, Viterbi).  Points marked correctly; time of our training and recognition of
``hf-gaussian`` against the HMM's fit and decoding.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

SEEDS = (11, 12, 13, 14, 15)
STATES = ["H0", "H1", "H2", "H3"]


def _accuracy(train, test, graph) -> tuple[float, float]:
    from contactlab.observer.recognize import recognize_archive
    from contactlab.observer.training import train_graph

    t0 = time.perf_counter()
    s = recognize_archive(test, graph=graph, models=train_graph(train, graph), write=False)
    return float(s["accuracy"]), time.perf_counter() - t0


def seed_row(seed: int, d: Path) -> dict:
    from contactlab.acquire.simulated import record_spec
    from contactlab.observer.graph_learn import learn_from_labels
    from contactlab.observer.graph_toml import write_graph
    from contactlab.peers.hmm import point_accuracy

    train = record_spec("hf-train", d / f"train-{seed}.h5", seed=seed)
    test = record_spec("hf-test", d / f"test-{seed}.h5", seed=seed)
    thesis, _ = _accuracy(train, test, "hf-context-free")
    gauss, secs = _accuracy(train, test, "hf-gaussian")
    doc, _ = learn_from_labels([train], {s: s for s in STATES}, base="hf-gaussian",
                               name="hf-learned")
    learned, _ = _accuracy(train, test, write_graph(doc, d / f"learned-{seed}.toml"))
    t0 = time.perf_counter()
    hmm = point_accuracy(train, test, STATES)
    hmm_s = time.perf_counter() - t0
    ahead = "ahead of" if gauss >= hmm else "behind"
    return {"name": f"demo pipeline, seed {seed}: hf-gaussian train + recognize",
            "ours_s": secs, "peer": "hmmlearn GaussianHMM (supervised)", "peer_s": hmm_s,
            "ratio": hmm_s / secs,
            "notes": f"points marked correctly: hf-gaussian {100 * gauss:.1f} % ({ahead} the "
                     f"HMM), edges learned from the labels {100 * learned:.1f} %, the thesis's "
                     f"models {100 * thesis:.1f} %; HMM {100 * hmm:.1f} %"}


def run() -> list[dict]:
    with tempfile.TemporaryDirectory() as tmp:
        return [seed_row(seed, Path(tmp)) for seed in SEEDS]
