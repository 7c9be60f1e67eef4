"""Sphinx configuration of the widesky documentation site.

Build (offline, warnings as errors)::

    python -m sphinx -W --keep-going -b html docs docs/_build/html

The Markdown pages in ``docs/`` are read by myst-parser. The site is ordered by what a reader needs (the
Diataxis split): the toctrees of ``index.md`` list the tutorials, how-to guides, explanation, validation and
benchmarks, reference, and the development notes (``docs/dev/``, last) explicitly, so a new page must be placed
in one of them: a page no toctree names makes Sphinx warn, which fails the build (warnings are errors). The
gallery examples in ``docs/examples/`` run during the build (sphinx-gallery) on the embedded dataset.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

HERE = Path(__file__).resolve().parent
try:                                   # the installed widesky (its C core built) ...
    import widesky.skymodel._core  # noqa: F401
except ImportError:                    # ... else the checkout's packages (an in-place build)
    sys.path.insert(0, str(HERE.parent))
os.environ.setdefault("OMP_NUM_THREADS", "1")

project = "widesky"
author = "widesky developers"
copyright = "widesky developers, Apache-2.0"
try:
    from importlib.metadata import version as _version
    release = _version("widesky")
except Exception:  # noqa: BLE001  (a checkout without an installed distribution)
    release = "0.1.0"
version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store", "examples/GALLERY_HEADER.rst", "**/README.md"]
# The figures folder holds images the pages embed, example-data the inputs of the README's commands: not page sources.
exclude_patterns += ["figures", "example-data"]
# generated/ holds Markdown fragments that pages include ({include}; benchmarks/docs_pvsim_figures.py writes them).
exclude_patterns += ["generated"]

# --- Markdown (myst-parser) ------------------------------------------------------------------------
myst_enable_extensions = ["dollarmath", "amsmath", "deflist", "colon_fence", "attrs_inline"]
myst_heading_anchors = 3

# --- API reference (autodoc + numpydoc-style docstrings through napoleon) ---------------------------
autodoc_default_options = {"members": True, "show-inheritance": False}
autodoc_member_order = "bysource"
autodoc_typehints = "none"
napoleon_numpy_docstring = True
napoleon_google_docstring = False
napoleon_use_rtype = False
napoleon_preprocess_types = False
# Docstring types such as "mesh or path or list of them" are plain words, not cross-references; "path" would
# otherwise resolve ambiguously to the ``path`` attributes of two classes. Missing targets never warn (the build
# is not nitpicky), so this silences only ambiguous matches in the Python domain.
suppress_warnings = ["ref.python"]

# --- Gallery (sphinx-gallery): examples run during the build ----------------------------------------
sphinx_gallery_conf = {
    "examples_dirs": ["examples"],
    "gallery_dirs": ["gallery"],
    "filename_pattern": r"/plot_",
    "abort_on_example_error": True,
    "download_all_examples": False,
    "remove_config_comments": True,
    "show_memory": False,
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib",),
    "within_subsection_order": "FileNameSortKey",
    # no generated sg_execution_times page in docs/: no toctree lists it, so the build would warn
    "write_computation_times": False,
}

# --- HTML (pydata-sphinx-theme, offline: no analytics, no external fonts or icons) -----------------
html_theme = "pydata_sphinx_theme"
html_title = "widesky"
html_static_path = ["_static"]
html_css_files = ["widesky.css"]
html_theme_options = {
    "navigation_depth": 2,
    "show_toc_level": 2,
    "navbar_align": "left",
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
    "secondary_sidebar_items": ["page-toc"],
    "use_edit_page_button": False,
}
html_show_sourcelink = False
