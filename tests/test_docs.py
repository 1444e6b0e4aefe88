"""Every ```python block of README.md and docs/*.md runs; relative links in the docs resolve.

The blocks of one file run in order in one namespace (a page reads as one session), in a fresh
temporary folder, with matplotlib on the Agg backend and nothing shown.
"""

from __future__ import annotations

import os
import re
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
                          text=True, timeout=300)
    assert proc.returncode == 0, f"a code block of {page.name} failed:\n{proc.stderr[-4000:]}"


@pytest.mark.parametrize("page", [p for p in PAGES if p.parent.name == "docs"], ids=lambda p: p.name)
def test_relative_links_resolve(page):
    text = page.read_text(encoding="utf-8")
    for target in LINK.findall(text):
        if "://" in target or target.startswith("mailto:"):
            continue
        assert (page.parent / target).exists(), f"{page.name} links to {target}, which does not exist"


def test_make_figures_script(tmp_path):
    """docs/make_figures.py regenerates the validation figures (here in short form, elsewhere)."""
    script = ROOT / "docs" / "make_figures.py"
    env = dict(os.environ, MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, str(script), "--quick", "--out", str(tmp_path)], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    pngs = sorted(tmp_path.glob("*.png"))
    assert pngs, "no figures written"
    for png in pngs:
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert png.stat().st_size < 150_000, f"{png.name} is {png.stat().st_size} bytes (limit 150 KB)"
