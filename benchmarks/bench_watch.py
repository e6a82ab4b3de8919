"""bench: live recognition (``contactlab watch``): latency, CPU share and memory.

Three graphs, each trained on simulated (or synthetic) runs and then fed recorded runs
of the same kind through :func:`contactlab.live.watch.watch` as a live source, in
chunks of ``CHUNK`` input rows released as fast as they are taken:

* ``hf-context`` (7.3.3; y_h) on the simulator's hf-test runs at 1000 Hz;
* ``guarded-move`` (9.1.1; triples of y_h, the constraint and velocity) on guarded-move
  runs at 1000 Hz;
* ``free-contact`` (wrench and position) on synthetic wrist recordings at 500 Hz.

Per graph: the latency from a chunk's arrival to the decision on its samples
(conditioning and the observer; median and 99th percentile), the chunk's own span and
the conditioning's delay (the 7.1 lowpass's DC group delay, or y_h's half block) stated
apart, the CPU share at the source's rate (CPU seconds per second of data; the goal is
<= 0.1, i.e. >= 10x headroom), and for hf-context the resident memory over a long
stream (the test runs looped, ``LONG_S`` seconds of data).
"""

from __future__ import annotations

import resource
import tempfile
import time
from pathlib import Path

import numpy as np

CHUNK = 40          # input rows per step (40 ms at 1000 Hz)
LONG_S = 3600.0     # seconds of data of the memory run: an hour


def _rss_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * resource.getpagesize() / 2**20


class _Replay:
    """Recorded trials as a live source: rows in CHUNK pieces, ``loops`` times over."""

    def __init__(self, archive, fields, *, loops: int = 1, probe=None):
        from contactlab.acquire.base import TrialInfo
        from contactlab.archive import open_archive

        self.name = f"replay:{Path(archive).name}"
        self.fields = tuple(fields)
        self.reconnects = False
        self.rows, self.infos = [], []
        with open_archive(archive) as a:
            for tid in a.trial_ids:
                t = a.trial(tid)
                rows = {"time": np.asarray(t.time)}
                for f in (*fields, "command"):
                    v = getattr(t, f, None)
                    if v is not None:
                        rows[f] = np.asarray(v)
                self.rows.append(rows)
                self.infos.append(TrialInfo(trial_id=tid, rate_hz=float(t.rate_hz)))
        self.loops, self.probe = loops, probe

    def trials(self):
        class _T:
            def __init__(s, rows, info, probe):
                s.rows, s.info, s.probe, s.extra_datasets = rows, info, probe, None

            def chunks(s):
                n = len(s.rows["time"])
                for a in range(0, n, CHUNK):
                    yield {k: v[a:a + CHUNK] for k, v in s.rows.items()}
                if s.probe:
                    s.probe()

            def ground_truth(s):
                return None

            def final_attrs(s):
                return {}

        for loop in range(self.loops):
            for rows, info in zip(self.rows, self.infos):
                yield _T(rows, info, self.probe)


def _measure(archive, graph, models, fields, *, loops=1, probe=None):
    from contactlab.live.conditioner import LiveConditioner
    from contactlab.live.watch import watch
    from contactlab.observer.observer import Observer
    from contactlab.observer.recognize import RecognizeStage, observer_keywords
    from contactlab.signals import factor_for

    stage = RecognizeStage(graph=graph, models=models, write=False)
    src = _Replay(archive, fields, loops=loops, probe=probe)
    rate = src.infos[0].rate_hz
    obs = Observer(stage.graph, stage.built,
                   **observer_keywords(stage.observer_kw, rate / factor_for(rate)))
    cond = LiveConditioner(obs.signals, rate_hz=rate, fields=fields, reduce=stage.models.reduce)
    data_s = loops * sum(len(r["time"]) for r in src.rows) / rate
    cpu0 = time.process_time()
    s = watch(src, stage, emit=lambda obj: None)
    cpu = time.process_time() - cpu0
    return {"graph": stage.graph.name, "rate_hz": rate, "data_s": data_s, "cpu_s": cpu,
            "share": cpu / data_s, "latency": s["latency"], "changes": s["changes"],
            "cond_delay_ms": 1e3 * cond.delay_samples * cond.factor / rate,
            "chunk_ms": 1e3 * CHUNK / rate}


def _cli(*args, cwd):
    from click.testing import CliRunner

    from contactlab.cli import main

    r = CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)
    assert r.exit_code == 0, r.output


def _row(m: dict) -> dict:
    lat = m["latency"]
    return {"name": f"watch {m['graph']} ({m['rate_hz']:g} Hz, chunk {CHUNK})",
            "ours_s": m["cpu_s"],
            "notes": (f"{m['data_s']:.0f} s of data; CPU share {100 * m['share']:.2f} % "
                      f"({1 / m['share']:.0f}x headroom); latency arrival->decision median "
                      f"{lat['median_ms']:.2f} ms, p99 {lat['p99_ms']:.2f} ms, max "
                      f"{lat['max_ms']:.1f} ms; chunk span {m['chunk_ms']:.0f} ms; "
                      f"conditioning delay {m['cond_delay_ms']:.1f} ms (apart); "
                      f"{m['changes']} changes"), **{k: m[k] for k in ("share",)},
            "latency": lat}


def run() -> list[dict]:
    import os

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        cwd = os.getcwd()
        os.chdir(d)
        try:
            _cli("acquire", "--spec", "hf-train", "--out", "hf-train.h5", "-q", cwd=d)
            _cli("acquire", "--spec", "hf-test", "--out", "hf-test.h5", "-q", cwd=d)
            _cli("train", "hf-train.h5", "--graph", "hf-context", "--out", "hf.h5", "-q",
                 cwd=d)
            hf_fields = ("strain", "wrench", "position", "velocity")
            rows.append(_row(_measure("hf-test.h5", "hf-context", "hf.h5", hf_fields)))

            _cli("acquire", "--spec", "guarded-move", "--out", "gm-train.h5", "--trials", "6",
                 "--seed", "1", "-q", cwd=d)
            _cli("acquire", "--spec", "guarded-move", "--out", "gm-test.h5", "--trials", "3",
                 "--seed", "2", "-q", cwd=d)
            _cli("train", "gm-train.h5", "--graph", "guarded-move", "--out", "gm.h5", "-q",
                 cwd=d)
            rows.append(_row(_measure("gm-test.h5", "guarded-move", "gm.h5", hf_fields)))

            import pandas as pd

            from contactlab.synthetic.free_contact import free_contact_recording
            for name, seed in (("w-train", 5), ("w-test", 6)):
                rec = free_contact_recording(seed=seed, fs=500.0, cycles=6)
                cols = rec.csv_columns()
                cols["state"] = [("free", "contact", "free")[c - 1] for c in cols["state"]]
                pd.DataFrame(cols).to_csv(d / f"{name}.csv", index=False)
                _cli("import", f"{name}.csv", "--out", f"{name}.h5", "-q", "--columns",
                     "time=t;wrench=fx,fy,fz,tx,ty,tz;position=x,y,z;labels=state", cwd=d)
            _cli("train", "w-train.h5", "--graph", "free-contact", "--out", "fc.h5", "-q",
                 cwd=d)
            rows.append(_row(_measure("w-test.h5", "free-contact", "fc.h5",
                                      ("wrench", "position"))))

            rss = []
            loops = max(1, int(LONG_S / 42.0))        # hf-test: 12 runs of 3.5 s
            m = _measure("hf-test.h5", "hf-context", "hf.h5", hf_fields, loops=loops,
                         probe=lambda: rss.append(_rss_mb()))
            n = len(rss)
            rows.append({"name": f"watch hf-context memory over {m['data_s']:.0f} s of data",
                         "ours_s": m["cpu_s"],
                         "notes": (f"resident memory {rss[n // 10]:.0f} MB after 10 %, "
                                   f"{rss[n // 2]:.0f} MB at half, {rss[-1]:.0f} MB at the "
                                   f"end (growth {rss[-1] - rss[n // 10]:+.1f} MB)")})
        finally:
            os.chdir(cwd)
    return rows


if __name__ == "__main__":
    for r in run():
        print(r["name"], "|", r.get("notes"))
