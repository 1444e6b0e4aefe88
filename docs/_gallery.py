"""The docs' gallery of ``examples/*.py`` by sphinx-gallery: which examples run, their call, their figures.

``docs/conf.py`` names the callables below by their qualified names (``"_gallery.reset_argv"``;
sphinx-gallery imports them), so the configuration stays picklable for Sphinx's environment.

- **Which examples run** at build time: ``LGVI_DOCS_EXAMPLES`` is ``fast`` (the default: the
  examples of ``FAST``, seconds each once their kernels are cached), ``all``, ``none`` or a
  comma-separated list of names. The others' pages show their code and, where one is kept, the
  figure stored in ``docs/figures/`` (``STORED``), with a note that says so.
- **The call**: sphinx-gallery runs the script as ``__main__`` in ``examples/``; ``reset_argv``
  gives it ``--quick --out DIR`` (its short form, figures into a folder of its own).
- **The figures**: the examples draw with ``matplotlib.figure.Figure`` and write PNGs into
  ``--out`` (no pyplot window), so ``written_figures`` (the image scraper) takes the PNGs the
  script wrote, its own figures first, then ``lgvi.plot``'s standard set.
"""

from __future__ import annotations

import os
import re
import shutil
import tempfile
from pathlib import Path

DOCS = Path(__file__).resolve().parent
EXAMPLES = DOCS.parent / "examples"
GALLERY = DOCS / "gallery"

# the gallery's order: the free body first, then torques, control, orbits, the compiled loop
ORDER = ("dzhanibekov", "heavy_top", "pendulum3d", "gravity_gradient", "slew_pd", "optimal_slew", "kepler",
         "orbit_attitude", "binary_asteroid", "uncertainty", "wheel_slew", "bdot_detumble", "nadir_dumping",
         "momentum_budget", "momentum_day", "estimation_budget", "cubesat_mission")
# run by default (`make docs`): their short runs take seconds once the kernels are cached
FAST = ("dzhanibekov", "heavy_top", "pendulum3d", "gravity_gradient", "slew_pd", "optimal_slew", "kepler",
        "orbit_attitude")
# figures kept in docs/figures/ (docs/make_figures.py), shown on the page of an example not run
STORED = {
    "dzhanibekov": ("dzhanibekov_comparison.png", "dzhanibekov_polhode.png"),
    "heavy_top": ("heavy_top_axis.png",),
    "pendulum3d": ("pendulum3d_comparison.png",),
    "gravity_gradient": ("gravity_gradient_pitch.png",),
    "slew_pd": ("slew_pd_error.png",),
    "optimal_slew": ("optimal_slew.png",),
    "cubesat_mission": ("cubesat_mission.png",),
    # the short run's first figure (python docs/make_figures.py --gallery)
    **{name: (f"gallery_{name}.png",) for name in ("orbit_attitude", "binary_asteroid", "uncertainty", "wheel_slew",
                                                     "bdot_detumble", "nadir_dumping", "momentum_budget",
                                                     "momentum_day", "estimation_budget")},
}
STANDARD = ("conservation", "polhode", "rates", "attitude", "iterations")   # lgvi.plot's set, in this order


def examples() -> list[str]:
    """The example scripts' names, in the gallery's order."""
    found = sorted(p.stem for p in EXAMPLES.glob("*.py"))
    return [n for n in ORDER if n in found] + [n for n in found if n not in ORDER]


def selected(choice: str | None = None) -> list[str]:
    """The examples run at build time, from ``LGVI_DOCS_EXAMPLES`` (or ``choice``)."""
    names = examples()
    choice = (os.environ.get("LGVI_DOCS_EXAMPLES", "fast") if choice is None else choice).strip()
    if choice == "all":
        return names
    if choice == "fast":
        return [n for n in names if n in FAST]
    if choice in ("", "none"):
        return []
    chosen = [c.strip() for c in choice.split(",") if c.strip()]
    unknown = sorted(set(chosen) - set(names))
    if unknown:
        raise ValueError(f"LGVI_DOCS_EXAMPLES={choice!r}: unknown example(s) {unknown}; the rule: 'fast' "
                         f"(the default), 'all', 'none' or a comma-separated list of {names}")
    return [n for n in names if n in chosen]


def filename_pattern(run: list[str]) -> str:
    """sphinx-gallery's ``filename_pattern``: the scripts it executes (a pattern matching none for [])."""
    if not run:
        return r"^$"
    return "(" + "|".join(re.escape(f"{os.sep}{n}.py") for n in run) + r")$"


class ExampleOrder:
    """sphinx-gallery's ``within_subsection_order``: the order of ``ORDER``, then by name."""

    def __init__(self, src_dir: str) -> None:
        self.src_dir = src_dir

    def __call__(self, filename: str) -> tuple[int, str]:
        stem = Path(filename).stem
        return (ORDER.index(stem) if stem in ORDER else len(ORDER), stem)

    def __repr__(self) -> str:   # sphinx-gallery keys its cache on this
        return f"<ExampleOrder {ORDER}>"


_OUT = Path(tempfile.gettempdir()) / f"lgvi-docs-gallery-{os.getpid()}"


def out_dir(src_file: str) -> Path:
    """The folder the example writes its figures into (``--out``), emptied before it runs."""
    return _OUT / Path(src_file).stem


def reset_argv(gallery_conf: dict, script_vars: dict) -> list[str]:
    """The example's arguments: its short form, its figures into a folder of its own."""
    out = out_dir(script_vars["src_file"])
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir(parents=True)
    return ["--quick", "--out", str(out)]


def _figure_order(name: str, fig: Path) -> tuple[int, str]:
    stem = fig.stem.removeprefix(f"{name}_")
    return (1 + STANDARD.index(stem) if stem in STANDARD else 0, fig.name)


def written_figures(block, block_vars: dict, gallery_conf: dict) -> str:
    """The image scraper: the PNGs the example wrote into its ``--out`` folder since the last block."""
    from sphinx_gallery.scrapers import figure_rst

    name = Path(block_vars["src_file"]).stem
    out = out_dir(block_vars["src_file"])
    seen = block_vars.setdefault("lgvi_figures_seen", set())
    new = sorted((p for p in out.rglob("*.png") if p not in seen), key=lambda p: _figure_order(name, p))
    paths = []
    for png, dest in zip(new, block_vars["image_path_iterator"]):
        shutil.copyfile(png, dest)
        seen.add(png)
        paths.append(dest)
    return figure_rst(paths, gallery_conf["src_dir"])


def _stored_note(name: str) -> str:
    figs = STORED.get(name, ())
    lines = ["", ".. rubric:: Figures", "",
             ".. note::", "",
             f"   This build of the pages did not run ``{name}.py`` (``LGVI_DOCS_EXAMPLES``: ``make docs`` runs "
             "the fast examples, ``LGVI_DOCS_EXAMPLES=all make docs`` every one).",
             ("   The figures below are those kept in ``docs/figures/`` (``python docs/make_figures.py``)."
              if figs else f"   Run ``python examples/{name}.py --out DIR`` to see its figures."), ""]
    for fig in figs:
        lines += [f".. figure:: /figures/{fig}", f"   :alt: {Path(fig).stem}", "   :width: 90%", ""]
    return "\n".join(lines) + "\n"


def stored_thumbnails(app) -> None:
    """Before sphinx-gallery (``builder-inited``): the stored figure as the thumbnail of an example not run.

    sphinx-gallery takes an example's thumbnail from its first image, ``images/sphx_glr_NAME_001.png``;
    for an example it does not execute that file is the stored figure, copied here.
    """
    run = set(selected())
    images = GALLERY / "images"
    for name in examples():
        first = images / f"sphx_glr_{name}_001.png"
        if name in run:
            continue
        for old in images.glob(f"sphx_glr_{name}_*.png"):   # a previous build's run of it
            old.unlink()
        for old in (images / "thumb").glob(f"sphx_glr_{name}_thumb.*"):
            old.unlink()
        # the checksum sphinx-gallery keeps of a script it ran: with it, it would take the page and
        # thumbnail just removed as current (a missing thumbnail fails the build); without, it writes
        # the page of a script not run
        (GALLERY / f"{name}.py.md5").unlink(missing_ok=True)
        if STORED.get(name):
            images.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(DOCS / "figures" / STORED[name][0], first)


def stored_figures(app) -> None:
    """After sphinx-gallery (``builder-inited``): the page of an example not run shows its stored figures."""
    run = set(selected())
    for name in examples():
        page = GALLERY / f"{name}.rst"
        if name in run or not page.exists():
            continue
        text = page.read_text(encoding="utf-8")
        anchor = "\n.. GENERATED FROM PYTHON SOURCE LINES"   # the code's start, after the docstring
        if anchor not in text or ".. rubric:: Figures" in text:
            continue
        page.chmod(0o644)   # sphinx-gallery writes its pages read-only
        page.write_text(text.replace(anchor, _stored_note(name) + anchor, 1), encoding="utf-8")


def cleanup(app, exception) -> None:
    """After the build: the examples' figure folders (their PNGs were copied into the gallery)."""
    shutil.rmtree(_OUT, ignore_errors=True)
