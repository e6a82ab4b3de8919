"""Packaging: every folder of package data is a listed package (setuptools warns about,
and will stop installing, data folders that are not), so a fresh install is quiet."""

from __future__ import annotations

import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def test_every_folder_with_files_is_a_configured_package():
    conf = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]
    packages = set(conf["packages"])
    missing = []
    for package, folder in conf["package-dir"].items():
        for sub in sorted(p for p in (REPO / folder).rglob("*") if p.is_dir()):
            if sub.name == "__pycache__" or not any(f.is_file() for f in sub.iterdir()):
                continue
            name = ".".join([package, *sub.relative_to(REPO / folder).parts])
            if name not in packages:
                missing.append(name)
    assert missing == []


def test_graph_files_are_package_data():
    conf = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]
    data = conf["package-data"]
    assert "*.toml" in data["contactlab.datasets_spec.graphs"]
    assert list((REPO / "datasets_spec" / "graphs").glob("*.toml"))
