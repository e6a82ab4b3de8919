"""The polygon-estimation experiment (figs 8.4-8.5) in its light setting."""

from __future__ import annotations

import json

from contactlab.experiments import get, polygon_estimation


def test_polygon_estimation_light_run(tmp_path):
    assert get("polygon-estimation").implemented
    summary = polygon_estimation.run(out_dir=tmp_path, seed=3, quiet=True, setting="light")
    for name in ("index.html", "report.pdf", "results.json", "fig-8-4.png", "fig-8-5.png"):
        assert (tmp_path / name).stat().st_size > 500, name
    data = json.loads((tmp_path / "results.json").read_text())
    assert data["undetermined"] == 0 and data["not_converged"] == 0
    cells = {(c["kind"], c["length"], c["ratio"]): c for c in data["cells"]}
    for kind in polygon_estimation.KINDS:
        for L in (1, 64):
            noisy, clean = cells[(kind, L, 0.1)], cells[(kind, L, 0.001)]
            # 100x less noise: errors must fall clearly (3 draws: medians scatter a lot)
            assert clean["angle_deg_median"] < 0.5 * noisy["angle_deg_median"]
            assert clean["rel_position_median"] < 0.5 * noisy["rel_position_median"]
        assert data["iterations"][kind]["max"] <= 20
    assert "Where ours differ and why" in (tmp_path / "index.html").read_text()
    assert summary["thesis_accurate_product"] == {"B": 100, "A": 100, "BB": 1000}
