"""Sphinx configuration of the contactlab documentation (``make docs``).

``make docs`` copies this folder to ``docs/_build/src`` and builds it there, so
every generated file (API stubs, the rendered gallery) lands under
``docs/_build`` and the tracked sources are never modified.
"""

import os

import contactlab

os.environ.setdefault("MPLBACKEND", "Agg")

project = "contactlab"
author = "the contactlab authors"
copyright = "contactlab authors; after B. S. Eberman, MIT AI-TR 1543 (1995)"
release = contactlab.__version__
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
    "sphinx_click",
    "sphinx_gallery.gen_gallery",
    "myst_parser",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "examples", "Thumbs.db", ".DS_Store"]
templates_path = ["_templates"]

html_theme = "alabaster"
html_title = f"contactlab {release}"
html_theme_options = {"description": "Statistical contact sensing (after Eberman 1995)",
                      "fixed_sidebar": True}

# -- API reference: autodoc + autosummary, numpydoc docstrings -----------------------
autosummary_generate = True
autosummary_imported_members = False
autodoc_default_options = {"members": True, "show-inheritance": False}
autodoc_typehints = "none"            # the numpydoc sections say the types
numpydoc_show_class_members = False   # autosummary lists the members
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_validation_checks = set()    # formatting errors still fail the build (-W)

# -- Markdown (the specification files under datasets_spec/ are included as is) ----
myst_heading_anchors = 3
# the specification files link to their neighbours (e.g. archive.schema.json), which
# are package data, not pages of this site
suppress_warnings = ["myst.xref_missing"]

# -- the gallery: notebook-style examples that run on every build -------------------
sphinx_gallery_conf = {
    "examples_dirs": "examples",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "abort_on_example_error": True,
    "download_all_examples": False,
    "within_subsection_order": "FileNameSortKey",
    "write_computation_times": False,
    "min_reported_time": 1,
}


def _skip_member(app, what, name, obj, skip, options):
    """Leave out scikit-learn's metadata-routing setters (``set_fit_request``), which
    :class:`~contactlab.segmenter.Segmenter` inherits from ``BaseEstimator``."""
    if name.startswith("set_") and name.endswith("_request"):
        return True
    return None


def setup(app):
    app.connect("autodoc-skip-member", _skip_member)
