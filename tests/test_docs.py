"""Every ```python block of README.md and docs/*.md runs; relative links in the docs resolve.

Nothing in the repository refers to a file outside it: a clone standing alone passes.

The blocks of one file run in order in one namespace (a page reads as one session), in a fresh
temporary folder, with matplotlib on the Agg backend and nothing shown.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted([ROOT / "README.md", *(ROOT / "docs").glob("*.md")])
FENCE = re.compile(r"^```python[ \t]*\n(.*?)^```[ \t]*$", re.S | re.M)
LINK = re.compile(r"\]\(([^)#\s]+)(?:#[^)]*)?\)")


def python_blocks(page: Path) -> list[tuple[int, str]]:
    """``(first line number, code)`` of every fenced python block of ``page``."""
    text = page.read_text(encoding="utf-8")
    return [(text.count("\n", 0, m.start()) + 2, m.group(1)) for m in FENCE.finditer(text)]


def test_pages_exist():
    names = {p.name for p in PAGES}
    assert {"README.md", "method.md", "conventions.md", "validation.md", "performance.md"} <= names


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_code_blocks_run(page, tmp_path):
    blocks = python_blocks(page)
    if not blocks:
        pytest.skip(f"{page.name} has no python blocks")
    # one script per page: each block is compiled with its own file name and line numbers, so a
    # failure points at the page and line; a subprocess keeps the test session's state out
    runner = [
        "import matplotlib",
        "matplotlib.use('Agg')",
        "import matplotlib.pyplot as plt",
        "plt.show = lambda *a, **k: None",
        "ns = {'__name__': '__main__'}",
    ]
    for line, code in blocks:
        padded = "\n" * (line - 1) + code
        runner.append(f"exec(compile({padded!r}, {str(page.relative_to(ROOT))!r}, 'exec'), ns)")
    env = dict(os.environ, MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, "-c", "\n".join(runner)], cwd=tmp_path, env=env, capture_output=True,
                          text=True)
    assert proc.returncode == 0, f"a code block of {page.name} failed:\n{proc.stderr[-4000:]}"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_relative_links_resolve(page):
    text = page.read_text(encoding="utf-8")
    for target in LINK.findall(text):
        if "://" in target or target.startswith("mailto:"):
            continue
        path = (page.parent / target).resolve()
        assert path.is_relative_to(ROOT), f"{page.name} links to {target}, outside the repository"
        assert path.exists(), f"{page.name} links to {target}, which does not exist"


#: a relative path climbing out of its folder (``../x``); each is resolved from the file's folder
UP_PATH = re.compile(r"(?<![\w.])((?:\.\./)+[\w.\-/]*)")
#: places outside any clone: a development machine's folders, the paper beside the repository
OUTSIDE = re.compile(r"(?<![\w.])/(?:work|home|Users)/|\bshared/paper\b")
#: files whose ``../`` paths are hostile *inputs* by design, used inside temporary folders only
#: (the untrusted-file tests: a scenario name or manifest entry that tries to climb out)
HOSTILE_INPUTS = {"tests/test_hostile.py"}


def tracked_text_files() -> list[Path]:
    """The repository's text files: ``git ls-files`` in a clone, else every file but build output."""
    if (ROOT / ".git").exists() and shutil.which("git"):
        proc = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True)
        files = [ROOT / name for name in proc.stdout.decode().split("\0") if name]
    else:  # an unpacked source tree
        skip = {".git", ".venv", "__pycache__", ".pytest_cache", ".hypothesis", "build", "dist", "lgvi-demo"}
        files = [p for p in ROOT.rglob("*") if p.is_file() and not skip & set(p.relative_to(ROOT).parts)
                 and not p.name.endswith(".egg-info")]
    out = []
    for path in files:
        data = path.read_bytes() if path.is_file() else b"\0"
        if b"\0" not in data[:8192]:
            out.append(path)
    return out


def test_nothing_refers_outside_the_repository():
    """No tracked file (source, test, doc, example, benchmark, Makefile, CI) names a path outside the
    repository: a relative path climbing above the root, or a folder of a development machine."""
    files = tracked_text_files()
    assert any(p.name == "Makefile" for p in files) and any(p.suffix == ".py" for p in files)
    found = []
    for path in files:
        for n, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
            where = f"{path.relative_to(ROOT)}:{n}"
            for target in UP_PATH.findall(line):
                if str(path.relative_to(ROOT)) in HOSTILE_INPUTS:
                    break
                if not (path.parent / target).resolve().is_relative_to(ROOT):
                    found.append(f"{where}: {target}")
            found += [f"{where}: {m.group(0)}" for m in OUTSIDE.finditer(line)]
    assert not found, "paths outside the repository:\n" + "\n".join(found)


def test_make_figures_script(tmp_path):
    """docs/make_figures.py regenerates the validation figures (here in short form, elsewhere)."""
    script = ROOT / "docs" / "make_figures.py"
    env = dict(os.environ, MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, str(script), "--quick", "--out", str(tmp_path)], cwd=tmp_path, env=env,
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    pngs = sorted(tmp_path.glob("*.png"))
    assert pngs, "no figures written"
    for png in pngs:
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert png.stat().st_size < 150_000, f"{png.name} is {png.stat().st_size} bytes (limit 150 KB)"


def test_quick_start_is_the_two_commands():
    """The README's Quick start (right after what lgvi is and how to install it) is exactly two
    commands, each doing its own set-up: one runs the default scenario, one the tests (CI's
    `.ci/run` is the second)."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    sections = re.findall(r"^## (.+)$", readme, flags=re.M)
    assert sections[:2] == ["Install", "Quick start"], sections
    rest = readme.partition("\n## Quick start\n")[2]
    block = re.search(r"```bash\n(.*?)```", rest, flags=re.S)
    assert block and rest.index("```bash") < rest.find("\n## "), "Quick start has no bash block"
    commands = [line.split("#")[0].strip() for line in block.group(1).splitlines() if line.split("#")[0].strip()]
    assert commands == ["make demo", "make test"]
    assert "make test" in (ROOT / ".ci" / "run").read_text(encoding="utf-8")


def test_readme_is_a_page_for_users():
    """Short; installable as shown; no dates, machine loads or history (CHANGELOG.md has those);
    no relative links to pages, which break where the README is shown off the repository (PyPI):
    documents are named as plain paths, and the two figures (the opening one, the showcase's) are
    the only relative targets."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(readme.splitlines()) <= 150
    assert "pip install lgvi" in readme and "CITATION.cff" in readme and "LICENSE" in readme
    assert not re.search(r"\b20\d\d-\d\d-\d\d\b|\bload \d|\bUTC\b|\bsession\b", readme)
    targets = [t for t in LINK.findall(readme) if "://" not in t]
    assert targets == ["docs/figures/dzhanibekov_comparison.png", "docs/figures/cubesat_mission.png"], targets
    for path in re.findall(r"\b((?:docs|examples)/[\w./-]*\w|[A-Z]+\.(?:md|cff)|LICENSE)\b", readme):
        if not path.startswith("docs/_build") and "NAME" not in path:    # made by `make docs`; a pattern
            assert (ROOT / path).exists(), f"the README names {path}, which does not exist"


def test_gallery_figures_kept_for_the_examples_not_run():
    """The docs' gallery (docs/_gallery.py) shows an example it does not run with figures kept in
    docs/figures/: each exists, is a small PNG, and the slow examples' ones are those that
    ``docs/make_figures.py --gallery`` writes; the examples run by default are real example names."""
    sys.path.insert(0, str(ROOT / "docs"))
    try:
        import _gallery
        import make_figures
    finally:
        sys.path.remove(str(ROOT / "docs"))
    names = _gallery.examples()
    assert set(_gallery.FAST) <= set(names) and set(_gallery.STORED) <= set(names)
    for figs in _gallery.STORED.values():
        for fig in figs:
            png = ROOT / "docs" / "figures" / fig
            assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", fig
            assert png.stat().st_size < 150_000, f"{fig} is {png.stat().st_size} bytes (limit 150 KB)"
    kept = {n for n, figs in _gallery.STORED.items() if figs[0].startswith("gallery_")}
    assert kept == set(make_figures.GALLERY_KEPT)
    assert _gallery.selected("fast") == [n for n in names if n in _gallery.FAST]
    with pytest.raises(ValueError, match="unknown example"):
        _gallery.selected("nope")
