"""The ph-demo and ph-roc experiments write their pages and sensible numbers."""

from __future__ import annotations

import json
import time

from contactlab.experiments import get, ph_demo, ph_roc


def test_ph_demo_writes_page_and_results(tmp_path):
    summary = get("ph-demo").run(out_dir=tmp_path, seed=1, quiet=True)
    for name in ("index.html", "report.pdf", "results.json", "fig-6-4.png", "fig-6-6.png"):
        assert (tmp_path / name).stat().st_size > 500, name
    data = json.loads((tmp_path / "results.json").read_text())
    assert data == json.loads(json.dumps(summary))
    change = data["change_tick"]
    assert change == 126 and data["thesis"]["detection_tick"] == 149
    assert data["detection_tick"] > change and data["lowpass_detection_tick"] > change
    assert data["change_estimate_tick"] < data["detection_tick"]
    assert data["demo_df_at_detection"] > 15.0 and data["demo_x_at_lowpass_detection"] > 0.5
    dist = data["distribution"]
    assert dist["ph_delay"]["n"] == ph_demo.N_SEEDS
    # Page-Hinkley is faster on average, and its change estimate is centred on the change
    assert dist["ph_delay"]["mean"] < dist["lowpass_delay"]["mean"]
    assert abs(dist["ph_onset_error"]["q50"]) <= 1
    assert 0 < dist["ph_delay"]["thesis_percentile"] < 100
    assert "0.50" in (tmp_path / "index.html").read_text()


def test_ph_roc_light_setting_is_fast_and_complete(tmp_path):
    t0 = time.perf_counter()
    summary = ph_roc.run(out_dir=tmp_path, seed=2, quiet=True, setting="light")
    assert time.perf_counter() - t0 < 20  # includes plotting and the PDF
    for name in ("index.html", "report.pdf", "results.json", "fig-6-3.png", "fig-6-5.png"):
        assert (tmp_path / name).exists(), name
    op = summary["ph_operating_point"]
    assert abs(op["wald_tD"] - 28) < 1e-3 and abs(op["wald_tF"] / 6.538e6 - 1) < 1e-3
    assert abs(op["mc_tD"] - op["siegmund_tD"]) < 2.0  # 300 runs: s.e. ~0.5
    ph_rows = [r for r in summary["mc"]["ph"] if r["tF"] is not None and r["n_alarms"] >= 50]
    assert len(ph_rows) >= 8
    for r in ph_rows:
        if r["T2"] >= 2:
            assert 0.6 < r["tF"] / r["siegmund_tF"] < 1.6, r
    json.loads((tmp_path / "results.json").read_text())  # strict JSON (no NaN/inf)
