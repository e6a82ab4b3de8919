"""``contactlab report`` draws every trial and every results stage of an archive."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from contactlab.archive import open_archive, write_results
from contactlab.cli import main
from conftest import write_archive


def test_report_has_a_figure_per_trial_and_per_results_stage(tmp_path):
    path = tmp_path / "runs.h5"
    write_archive(path, trials=("t01", "t02"))
    with open_archive(path) as archive:
        n = archive.trial("t01").n_samples
    write_results(path, "t01", "segment", datasets={"boundaries_s": np.array([0.3, 0.9]),
                                                    "statistic": np.linspace(0, 1, n)})
    out = tmp_path / "rep"
    result = CliRunner().invoke(main, ["report", str(path), "--out", str(out), "--json", "-q"])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)
    assert summary["trials"] == ["t01", "t02"]
    assert set(summary["figures"]) == {"trial-t01", "trial-t02", "trial-t01-segment"}
    html = (out / "index.html").read_text()
    for name in summary["figures"]:
        assert f"{name}.png" in html and (out / f"{name}.png").stat().st_size > 5000
    assert (out / "report.pdf").read_bytes().startswith(b"%PDF")


def test_report_rejects_an_unknown_trial_in_one_line(tmp_path):
    path = tmp_path / "runs.h5"
    write_archive(path, trials=("t01",))
    result = CliRunner().invoke(main, ["report", str(path), "--trial", "zz", "--out",
                                       str(tmp_path / "r")])
    assert result.exit_code == 1
    assert result.stderr.strip().count("\n") == 0 and "zz" in result.stderr


def _red_lines(ax):
    import matplotlib.colors as mc
    return [ln for ln in ax.get_lines()
            if mc.to_hex(ln.get_color()) == mc.to_hex("C3") and len(set(ln.get_xdata())) == 1]


def test_segment_figure_draws_boundaries_not_every_statistic_time(tmp_path):
    import matplotlib.pyplot as plt

    from contactlab.report.archive_report import RESULT_PLOTTERS

    path = tmp_path / "runs.h5"
    write_archive(path, trials=("t01",))
    stat_t = np.linspace(0.1, 1.4, 300)     # a per-block time axis: not event times
    write_results(path, "t01", "segment", datasets={
        "boundaries_s": np.array([0.3, 0.9]), "statistic": np.abs(np.sin(stat_t)) + 0.1,
        "statistic_time_s": stat_t}, attrs={"signal": "strain"},
        parameters={"threshold": 200.0})
    with open_archive(path) as archive:
        trial = archive.trial("t01")
        fig = plt.figure()
        caption = RESULT_PLOTTERS["segment"](trial, trial.results("segment"), fig)
    assert [len(_red_lines(ax)) for ax in fig.axes] == [2, 2]
    assert all(ax.get_ylabel() for ax in fig.axes) and fig.axes[-1].get_xlabel() == "time (s)"
    assert fig.axes[0].get_legend() is not None and fig._suptitle.get_text()
    assert "threshold 200" in caption and "boundaries" in caption
    plt.close(fig)


def test_generic_results_keep_a_time_axis_apart_from_event_times(tmp_path):
    import matplotlib.pyplot as plt

    from contactlab.report.archive_report import _plot_results

    path = tmp_path / "runs.h5"
    write_archive(path, trials=("t01",))
    t = np.linspace(0.0, 1.4, 500)
    write_results(path, "t01", "other", datasets={"score": np.cos(t), "score_time_s": t,
                                                  "events_s": np.array([0.5])})
    with open_archive(path) as archive:
        trial = archive.trial("t01")
        fig = plt.figure()
        caption = _plot_results(trial, trial.results("other"), fig)
    (ax,) = fig.axes
    assert ax.get_ylabel() == "score"
    assert len(ax.get_lines()[0].get_xdata()) == 500      # drawn against score_time_s
    vlines = [ln for ln in ax.get_lines() if len(set(ln.get_xdata())) == 1]
    assert len(vlines) == 1 and "events_s" in caption and "score" in caption
    plt.close(fig)


@pytest.mark.parametrize("rate", [250.0, 1000.0])
def test_measurement_caption_lists_only_the_panels_drawn(tmp_path, rate):
    from contactlab.archive import create_archive
    from contactlab.report.archive_report import (_measurement_caption, _measurement_panels,
                                                  _plot_measurements)

    path = tmp_path / "wrench.h5"
    n = 600
    rng = np.random.default_rng(0)
    with create_archive(path, title="wrench only") as archive:
        tr = archive.add_trial("w01", rate_hz=rate, controller="", environment="", seed=0,
                               source="import")
        tr.append(time=np.arange(n) / rate, wrench=rng.normal(size=(n, 6)))
        tr.close()
    with open_archive(path) as archive:
        trial = archive.trial("w01")
        panels = _measurement_panels(trial)
        caption = _measurement_caption(trial, panels)
        fig = _plot_measurements(trial, panels)
    # no y_h at 250 Hz: nothing is left above the 125 Hz lowpass of 7.1
    assert [p[0] for p in panels] == ["force (N)"] + (["y_h (log N)"] if rate > 250 else [])
    assert "force" in caption and "wrench" in caption
    for word in ("position", "velocity", "strains of", "ground-truth"):
        assert word not in caption
    assert all(ax.get_legend() is not None and ax.get_ylabel() for ax in fig.axes)


def test_unlabelled_truth_gets_its_own_tick_in_the_recognition_figure(tmp_path):
    import matplotlib.pyplot as plt

    from contactlab.report.archive_report import RESULT_PLOTTERS

    path = tmp_path / "runs.h5"
    write_archive(path, trials=("t01",))
    k = 200
    truth = np.r_[np.full(50, -1), np.zeros(100, int), np.ones(50, int)]
    prob = np.tile([0.7, 0.3], (k, 1))
    write_results(path, "t01", "recognize", datasets={
        "time_s": np.arange(k) / 250.0, "node_prob": prob, "labels": np.ones(k, int),
        "map_node": np.zeros(k, int), "truth": truth}, attrs={"nodes": "A,B"})
    with open_archive(path) as archive:
        trial = archive.trial("t01")
        fig = plt.figure()
        caption = RESULT_PLOTTERS["recognize"](trial, trial.results("recognize"), fig)
    ticks = [t.get_text() for t in fig.axes[1].get_yticklabels()]
    assert ticks == ["unlabelled", "A", "B"]
    assert "MAP path" in caption and "hindsight" in caption
    assert fig.axes[0].get_legend() is not None and fig.axes[1].get_legend() is not None
    plt.close(fig)


def test_report_gives_recognition_accuracy_beside_chance(tmp_path):
    path = tmp_path / "runs.h5"
    write_archive(path, trials=("t01", "t02"))
    k = 100
    # t01: truth 60 x A then 40 x B, chosen all A -> 60 right; t02: 30 unlabelled,
    # 70 x B, chosen B for the first 35 labelled points -> 35 right
    truths = {"t01": np.r_[np.zeros(60, int), np.ones(40, int)],
              "t02": np.r_[np.full(30, -1), np.ones(70, int)]}
    chosen = {"t01": np.zeros(k, int), "t02": np.r_[np.ones(65, int), np.zeros(35, int)]}
    for tid in truths:
        write_results(path, tid, "recognize", datasets={
            "time_s": np.arange(k) / 250.0, "node_prob": np.full((k, 2), 0.5),
            "labels": chosen[tid], "map_node": chosen[tid], "truth": truths[tid]},
            attrs={"nodes": "A,B"})
    out = tmp_path / "rep"
    result = CliRunner().invoke(main, ["report", str(path), "--out", str(out), "--json"])
    assert result.exit_code == 0, result.output
    r = json.loads(result.stdout)["recognition"]
    assert r["points"] == 170
    assert r["accuracy"] == (60 + 35) / 170
    assert r["confusion"] == [[60, 0], [75, 35]]
    assert r["majority_node"] == "B" and r["chance_majority"] == 110 / 170
    assert r["chance_uniform"] == 0.5
    text = CliRunner().invoke(main, ["report", str(path), "--out", str(out), "--force"]).stdout
    # the line make demo's closing summary picks out
    line = next(ln for ln in text.splitlines() if ln.startswith("recognised: "))
    assert "55.9 % of 170 labelled points" in line and "64.7 % always B" in line
    assert "What was recognised" in (out / "index.html").read_text()


def test_report_names_nodes_with_their_graph_labels(tmp_path):
    # a graph whose node names are the thesis's hypotheses (H0, H1): the summary and the
    # page say what each is
    graph = tmp_path / "g.toml"
    graph.write_text(
        'name = "g"\nedges = ["H0 -> H1", "H1 -> H0"]\n'
        '[models.M0]\nkind = "velocity-fixed"\ntrained = "H0"\nsigma = 0.001\n'
        '[models.M1]\nkind = "velocity-moving"\ntrained = "H1"\nlow = -0.01\n'
        'high = 0.01\nsigma = 0.001\n'
        '[[nodes]]\nname = "H0"\nlabel = "stationary"\nmodels = { v = "M0" }\n'
        'initial = 1.0\n[[nodes]]\nname = "H1"\nlabel = "moving"\nmodels = { v = "M1" }\n')
    path = tmp_path / "runs.h5"
    write_archive(path, trials=("t01",))
    k = 100
    write_results(path, "t01", "recognize", datasets={
        "time_s": np.arange(k) / 250.0, "node_prob": np.full((k, 2), 0.5),
        "labels": np.zeros(k, int), "map_node": np.zeros(k, int),
        "truth": np.r_[np.zeros(70, int), np.ones(30, int)]},
        attrs={"nodes": "H0,H1"}, parameters={"graph": str(graph)})
    out = tmp_path / "rep"
    text = CliRunner().invoke(main, ["report", str(path), "--out", str(out)]).stdout
    line = next(ln for ln in text.splitlines() if ln.startswith("recognised: "))
    assert "always H0 (stationary)" in line
    assert "H1 (moving)" in (out / "index.html").read_text()


def test_report_explains_the_worst_recognised_trial(tmp_path):
    """After ``recognize``, the report reruns ``--explain`` on the trial recognised worst:
    one row per true change with its verdict, the same as ``recognize --explain`` gives;
    without the models file it says how to get the explanation."""
    from contactlab.observer import load_graph, recognize_archive, train_graph
    from contactlab.report.archive_report import report_archive
    from contactlab.synthetic import write_archive as write_synthetic
    from contactlab.synthetic.switching import switching_trials

    train, test = tmp_path / "train.h5", tmp_path / "test.h5"
    write_synthetic(switching_trials(4, seed=21, fresh=True), train)
    write_synthetic(switching_trials(3, seed=22, fresh=True), test)
    graph = load_graph("hf-context-free")
    models = tmp_path / "m.h5"
    train_graph(train, graph).save(models)
    summary = recognize_archive(test, graph=graph, models=models)
    accs = {tid: e["accuracy"] for tid, e in summary["trials"].items()}
    worst = min(accs, key=accs.get)
    assert accs[worst] < 1.0
    out = report_archive(test, out_dir=tmp_path / "rep", quiet=True)
    ex = out["explained"]
    assert ex["trial"] == worst and ex["accuracy"] == pytest.approx(accs[worst])
    r = CliRunner().invoke(main, ["recognize", str(test), "--graph", "hf-context-free",
                                  "--models", str(models), "--explain", worst, "--json", "-q"])
    assert r.exit_code == 0, r.output
    assert [t["verdict"] for t in ex["transitions"]] == \
        [t["verdict"] for t in json.loads(r.stdout)["transitions"]]
    html = (tmp_path / "rep" / "index.html").read_text()
    assert f"Why trial {worst} was recognised worst" in html
    assert html.count("<tr>") >= len(ex["transitions"])
    models.unlink()
    out = report_archive(test, out_dir=tmp_path / "rep2", quiet=True)
    assert "could not be read" in out["explained"]["note"]
    assert "--explain" in (tmp_path / "rep2" / "index.html").read_text()
