"""Sphinx configuration of lgvi's documentation site (``make docs``; deps: ``pip install -e '.[docs]'``).

The Markdown pages of this folder are the site's pages (MyST); ``api.rst`` is the API reference,
generated from the docstrings (autosummary, numpydoc); ``gallery/`` is written at build time from
``examples/*.py`` by sphinx-gallery: a page per example with its description, its code, what it
prints and the figures it makes, each example run in its short form (``--quick``) inside this
process (``docs/_gallery.py``).

``LGVI_DOCS_EXAMPLES`` chooses the examples run at build time: ``fast`` (the default), ``all``,
``none`` or a comma-separated list of names; the others' pages show their code and the figure kept
in ``docs/figures/`` where there is one.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT / "src"))

import lgvi  # noqa: E402

project = "lgvi"
author = "lgvi developers"
copyright = "lgvi developers"
version = release = lgvi.__version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.intersphinx",   # links to NumPy's and SciPy's pages, through the inventories in _inventories/
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",      # source links: every documented object links to its highlighted source
    "sphinx-mathjax-offline",   # MathJax 3 from the package into _static/mathjax: math renders offline, no CDN
    "numpydoc",
    "sphinx_gallery.gen_gallery",   # the gallery of examples/ (docs/_gallery.py)
]
# math in the pages: ```{math} blocks, $...$ and $$...$$ (MyST's dollarmath), amsmath environments
myst_enable_extensions = ["dollarmath", "amsmath"]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "_templates", "README.md"]
templates_path = ["_templates"]

html_theme = "furo"
html_title = f"lgvi {release}"
html_static_path: list[str] = []

myst_heading_anchors = 4
# the pages link the repository's files (examples, sources) as on GitHub; those are not pages
suppress_warnings = ["myst.xref_missing"]

autosummary_generate = True
autodoc_typehints = "none"            # the numpydoc sections give the types
autodoc_member_order = "bysource"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
# the parameter types link to their pages: lgvi's own names, and NumPy's and SciPy's through
# intersphinx; only the words below are linked (shapes and prose in a type line stay text; a name
# given in full is written as a role, since numpydoc leaves an alias to itself unlinked)
numpydoc_xref_param_type = True
numpydoc_xref_ignore = "all"
numpydoc_xref_aliases = {
    "array_like": ":term:`numpy:array_like`",
    "ndarray": "numpy.ndarray",
    "numpy.ndarray": ":class:`numpy.ndarray`",
    "Generator": "numpy.random.Generator",
    "numpy.random.Generator": ":class:`numpy.random.Generator`",
    "Rotation": "scipy.spatial.transform.Rotation",
    "scipy.spatial.transform.Rotation": ":class:`scipy.spatial.transform.Rotation`",
    "RigidBody": "lgvi.RigidBody",
    "Trajectory": "lgvi.Trajectory",
    # numpydoc's defaults send these to labels and glossary terms of Python's documentation, whose
    # inventory is not kept here: as classes they stay plain text, and no warning fails the build
    "bool": ":class:`python:bool`",
    "boolean": ":class:`python:bool`",
    "iterable": ":class:`python:collections.abc.Iterable`",
    "sequence": ":class:`python:collections.abc.Sequence`",
    "generator": ":class:`python:collections.abc.Generator`",
    "scalar": ":class:`numpy.generic`",
}
# NumPy's and SciPy's inventories are kept in the repository (docs/make_inventories.py writes them),
# so the -W build needs no network; the links go to the projects' sites
intersphinx_mapping = {
    "numpy": ("https://numpy.org/doc/stable/", str(DOCS / "_inventories" / "numpy.inv")),
    "scipy": ("https://docs.scipy.org/doc/scipy/", str(DOCS / "_inventories" / "scipy.inv")),
}
# autosummary writes a stub per public name into generated/ but never removes one whose name has
# gone: start from an empty folder, so a stale stub cannot fail the -W build.
shutil.rmtree(DOCS / "generated", ignore_errors=True)

# ------------------------------------------------------------------------------------ the gallery
# sphinx-gallery writes gallery/ from examples/*.py: a page per example (its docstring, its code,
# what it prints, the figures it wrote, downloads of the script and a notebook) and a thumbnail
# index. The choices (which examples run, their call, the figure scraper) live in docs/_gallery.py.
sys.path.insert(0, str(DOCS))
import _gallery  # noqa: E402

sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "examples"),
    "gallery_dirs": str(_gallery.GALLERY),
    "filename_pattern": _gallery.filename_pattern(_gallery.selected()),
    "within_subsection_order": "_gallery.ExampleOrder",
    "reset_argv": "_gallery.reset_argv",
    "image_scrapers": ("_gallery.written_figures",),
    "reset_modules": ("matplotlib",),
    "abort_on_example_error": True,      # an example that fails fails the build
    "doc_module": ("lgvi",),             # names in the code link to the API reference
    "backreferences_dir": None,
    "download_all_examples": False,
    "show_signature": False,
    "min_reported_time": 1e9,            # no timings on the pages (they vary with the machine)
    "capture_repr": (),
    "remove_config_comments": True,
}
# what sphinx-gallery writes beside the pages (downloads, caches) and its timing pages (not part of the site)
exclude_patterns += ["gallery/*.ipynb", "gallery/*.py", "gallery/*.zip", "gallery/*.md5", "gallery/*.codeobj.json",
                     "gallery/sg_execution_times.rst", "sg_execution_times.rst",
                     "gallery/*.md"]   # pages of the hand-built gallery earlier versions wrote to the same ignored folder


def setup(app):
    app.connect("builder-inited", _gallery.stored_thumbnails, priority=400)   # before sphinx-gallery (500)
    app.connect("builder-inited", _gallery.stored_figures, priority=600)      # after it
    app.connect("build-finished", _gallery.cleanup)
    return {"parallel_read_safe": True}
