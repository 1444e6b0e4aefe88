"""Sphinx configuration of lgvi's documentation site (``make docs``; deps: ``pip install -e '.[docs]'``).

The Markdown pages of this folder are the site's pages (MyST); ``api.rst`` is the API reference,
generated from the docstrings (autosummary, numpydoc); ``gallery/`` is written at build time from
``examples/*.py``: a page per example with its description, its code, what it prints and the
figures it makes, each example run in its short form (``--quick``) inside this process.

``LGVI_DOCS_EXAMPLES`` chooses the examples run at build time: ``all`` (the default), ``none``,
or a comma-separated list of names; the others' pages show their code without figures.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import runpy
import shutil
import sys
import time
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
GALLERY = DOCS / "gallery"
EXAMPLE_ORDER = ("dzhanibekov", "heavy_top", "pendulum3d", "gravity_gradient", "slew_pd", "uncertainty", "kepler")


def _examples() -> list[Path]:
    found = {p.stem: p for p in sorted((ROOT / "examples").glob("*.py"))}
    return [found[n] for n in EXAMPLE_ORDER if n in found] + [p for n, p in found.items() if n not in EXAMPLE_ORDER]


def _selected(names: list[str]) -> set[str]:
    choice = os.environ.get("LGVI_DOCS_EXAMPLES", "all").strip()
    if choice == "all":
        return set(names)
    if choice in ("", "none"):
        return set()
    chosen = {c.strip() for c in choice.split(",") if c.strip()}
    unknown = chosen - set(names)
    if unknown:
        raise ValueError(f"LGVI_DOCS_EXAMPLES: unknown example(s) {sorted(unknown)}; examples: {names}")
    return chosen


def _run(script: Path, out: Path) -> str:
    """Run ``script --quick --out OUT`` in this process; returns what it printed."""
    import matplotlib

    matplotlib.use("Agg")
    ns = runpy.run_path(str(script), run_name="lgvi_docs_example")
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        ns["main"](["--quick", "--out", str(out)])
    import matplotlib.pyplot as plt

    plt.close("all")
    return buf.getvalue()


def _standard(name: str, fig: Path) -> int:
    """Sort key: the example's own figures first, then lgvi.plot's standard set (conservation first)."""
    stem = fig.stem.removeprefix(f"{name}_")
    standard = ("conservation", "polhode", "rates", "attitude", "iterations")
    return 1 + standard.index(stem) if stem in standard else 0


def _docstring(script: Path) -> tuple[str, str]:
    """The example's title (first docstring line) and the rest of its docstring."""
    import ast

    doc = ast.get_docstring(ast.parse(script.read_text(encoding="utf-8"))) or script.stem
    first, _, rest = doc.partition("\n")
    return first.strip().rstrip("."), rest.strip()


def _write_gallery(app) -> None:
    if GALLERY.exists():
        shutil.rmtree(GALLERY)
    (GALLERY / "figures").mkdir(parents=True)
    scripts = _examples()
    run = _selected([s.stem for s in scripts])
    entries = []
    for script in scripts:
        name = script.stem
        title, rest = _docstring(script)
        figs: list[Path] = []
        printed = ""
        if name in run:
            out = GALLERY / "figures" / name
            t0 = time.perf_counter()
            printed = _run(script, out)
            figs = sorted(out.glob("*.png"), key=lambda f: (_standard(name, f), f.name))
            print(f"lgvi gallery: {name} ran in {time.perf_counter() - t0:.1f} s, {len(figs)} figures")
        # the docstring as the script shows it (plain text, not markup)
        lines = [f"# {title}", "", "```text", rest, "```", "",
                 f"Run it: `python examples/{name}.py [--quick] [--out DIR]`.", ""]
        if figs:
            lines += ["## Figures", "", "Made when this page was built, by the short run (`--quick`).", ""]
            for fig in figs:
                rel = fig.relative_to(GALLERY).as_posix()
                lines += [f"```{{figure}} {rel}", f":alt: {fig.stem}", ":width: 90%", "", f"`{fig.name}`", "```", ""]
        elif name not in run:
            lines += ["```{note}", "This build did not run the example (`LGVI_DOCS_EXAMPLES`); `make docs` runs them all.",
                      "```", ""]
        if printed.strip():
            lines += ["## What it prints", "", "```text", printed.rstrip(), "```", ""]
        code = os.path.relpath(script, GALLERY)
        lines += ["## The code", "", f"```{{literalinclude}} {code}", ":language: python", "```", ""]
        (GALLERY / f"{name}.md").write_text("\n".join(lines), encoding="utf-8")
        entries.append((name, title, figs[0].relative_to(GALLERY).as_posix() if figs else None))
    index = ["# Gallery of the examples", "",
             "Each example of `examples/` on its own page: what it shows, the figures it makes (made when "
             "these pages were built), what it prints and its code.", "",
             "```{toctree}", ":maxdepth: 1", ":hidden:", ""] + [n for n, _, _ in entries] + ["```", ""]
    for name, title, thumb in entries:  # a paragraph each (headings would repeat the toctree)
        index += [f"**[{title}]({name}.md)**", ""]
        if thumb:
            index += [f"```{{image}} {thumb}", ":width: 45%", f":alt: {name}", f":target: {name}.html", "```", ""]
    (GALLERY / "index.md").write_text("\n".join(index), encoding="utf-8")


def setup(app):
    app.connect("builder-inited", _write_gallery)
    return {"parallel_read_safe": True}
