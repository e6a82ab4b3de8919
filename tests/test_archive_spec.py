"""The schema file is loadable package data, well formed, and matches ARCHIVE.md."""

from __future__ import annotations

import re
from importlib.resources import files

import jsonschema
import pytest

from contactlab.archive import spec
from contactlab.archive.validate import ATTRIBUTE_CHECKS, CHECKS


def _nodes(node, path=""):
    yield path or "/", node
    for name, child in node.get("members", {}).items():
        yield from _nodes(child, f"{path}/{name}")
    if "each" in node:
        yield from _nodes(node["each"], f"{path}/{node['each']['name']}")


NODES = list(_nodes(spec.schema()["root"]))


def test_schema_and_document_ship_as_package_data():
    package = files("contactlab.datasets_spec")
    assert package.joinpath("archive.schema.json").is_file()
    assert package.joinpath("ARCHIVE.md").is_file()


@pytest.mark.parametrize("path, node", NODES, ids=[p for p, _ in NODES])
def test_every_node_is_well_formed(path, node):
    assert node["kind"] in ("group", "dataset")
    if node["kind"] == "dataset":
        assert node["dtype"] in spec.DTYPE_KINDS
        assert all(isinstance(d, int) or re.fullmatch(r"[a-z]", d) for d in node["shape"])
        assert set(node.get("checks", [])) <= set(CHECKS)
    for name, attr in node.get("attributes", {}).items():
        jsonschema.Draft202012Validator.check_schema(attr.get("schema", {}))
        assert set(attr.get("checks", [])) <= set(ATTRIBUTE_CHECKS)
        if "default" in attr:
            assert not list(jsonschema.Draft202012Validator(attr["schema"]).iter_errors(
                attr["default"])), f"{path}@{name}: default violates its own schema"


def test_every_named_check_is_described_and_implemented():
    assert set(spec.schema()["checks"]) == set(CHECKS) | set(ATTRIBUTE_CHECKS)


def test_archive_md_documents_every_dataset_and_attribute():
    text = files("contactlab.datasets_spec").joinpath("ARCHIVE.md").read_text("utf-8")
    for path, node in NODES:
        name = path.rsplit("/", 1)[-1]
        if name and not name.startswith("<"):
            assert f"`{name}`" in text or f"{name}/" in text, path
        for attr in node.get("attributes", {}):
            assert f"`{attr}`" in text, f"{path} attribute {attr}"
    assert f"format {spec.FORMAT_VERSION}" in text
