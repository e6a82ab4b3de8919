"""``contactlab`` exports its main classes lazily: every listed name resolves, and a
bare ``import contactlab`` loads no subpackage."""

import importlib
import subprocess
import sys

import pytest

import contactlab


@pytest.mark.parametrize("name", contactlab.__all__)
def test_every_exported_name_resolves(name):
    value = getattr(contactlab, name)
    assert value is not None
    module = importlib.import_module(contactlab._EXPORTS[name])
    assert getattr(module, name) is value


@pytest.mark.parametrize("name", contactlab._SUBMODULES)
def test_every_listed_subpackage_imports_and_is_documented(name):
    assert getattr(contactlab, name).__name__ == f"contactlab.{name}"
    assert f":mod:`contactlab.{name}`" in contactlab.__doc__


def test_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no_such_name"):
        contactlab.no_such_name  # noqa: B018


def test_import_is_lazy():
    """``import contactlab`` loads none of the subpackages (only the stdlib-only module
    that points numba's cache at the source's folder) and neither numpy nor numba."""
    code = ("import sys, contactlab; "
            "print(sorted(m for m in sys.modules if m.startswith('contactlab.')"
            " or m in ('numpy', 'numba')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == "['contactlab.kernel_cache']"
