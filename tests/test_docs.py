"""The documentation's sources are present and its examples run (``make docs`` builds
the site; these checks need no Sphinx)."""

import runpy
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[1] / "docs"
EXAMPLES = sorted((DOCS / "examples").glob("plot_*.py"))


def test_sources_exist_and_include_the_specification_files():
    for name in ("conf.py", "index.rst", "getting_started.rst", "cli.rst", "api.rst"):
        assert (DOCS / name).is_file(), name
    for page, spec in (("archive.md", "ARCHIVE.md"), ("graphs.md", "GRAPHS.md"),
                       ("models.md", "MODELS.md")):
        text = (DOCS / page).read_text()
        assert f"{{include}} ../datasets_spec/{spec}" in text
        assert (DOCS.parent / "datasets_spec" / spec).is_file()
    assert len(EXAMPLES) >= 4


@pytest.mark.parametrize("script", EXAMPLES, ids=lambda p: p.stem)
def test_example_runs(script, monkeypatch, tmp_path):
    monkeypatch.setenv("MPLBACKEND", "Agg")
    # the recognition example reads real recordings when present: the test uses the
    # synthetic recording it falls back to, so it does not depend on files outside
    monkeypatch.setenv("CONTACTLAB_REAL_DATA", str(tmp_path / "none"))
    monkeypatch.chdir(tmp_path)
    import matplotlib.pyplot as plt

    try:
        runpy.run_path(str(script), run_name="__main__")
    finally:
        plt.close("all")
    assert not any(tmp_path.iterdir()), "examples write no files"
