"""The documentation site (Sphinx, ``docs/conf.py``) builds with warnings as errors.

The build runs one example for the gallery (``LGVI_DOCS_EXAMPLES=kepler``, the fastest; ``make
docs`` runs the fast ones, ``LGVI_DOCS_EXAMPLES=all`` every one), so sphinx-gallery's build-time
figures are exercised within the test's time.
Without the docs tools the test skips (``pip install -e '.[docs]'``); in CI it fails.
"""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TOOLS = ("sphinx", "numpydoc", "furo", "myst_parser", "sphinx_gallery", "matplotlib")
#: the pages that derive or state equations, written as math ($...$, $$...$$): each renders math
#: offline, and none shows a raw dollar sign (an unclosed span, or one Markdown broke, shows it)
MATH_PAGES = ("method", "gyrostat", "gyrostat_rkmk", "orbit", "optimal", "two_spheres", "environment",
              "estimation", "loop", "splitting", "slosh", "conventions", "validation", "basilisk", "mission")
#: what is not prose in a built page: code, literal blocks, math (its TeX source), scripts, tags
NOT_PROSE = re.compile(r"<(pre|code|script|style)\b.*?</\1>|<(span|div) class=\"math\b[^>]*>.*?</\2>|<[^>]+>", re.S)


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    missing = [m for m in TOOLS if importlib.util.find_spec(m) is None]
    if missing:
        why = f"the documentation tools are not installed ({', '.join(missing)}): pip install -e '.[docs]'"
        if os.environ.get("CI"):
            pytest.fail(why)
        pytest.skip(why)
    out = tmp_path_factory.mktemp("site")
    env = dict(os.environ, LGVI_DOCS_EXAMPLES="kepler", MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, "-m", "sphinx", "-b", "html", "-W", "--keep-going", "-q",
                           "-d", str(out / "doctrees"), "docs", str(out / "html")],
                          cwd=ROOT, env=env, capture_output=True, text=True)
    assert proc.returncode == 0, f"sphinx-build -W failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-6000:]}"
    return out / "html"


def _text(path: Path) -> str:
    assert path.exists(), f"{path.name} was not built"
    return path.read_text(encoding="utf-8")


def test_pages_and_navigation(site):
    index = _text(site / "index.html")
    for page in ("getting-started", "api", "gallery/index", "method", "conventions", "validation",
                 "performance", "architecture"):
        assert f'href="{page}.html' in index, f"{page} is not linked from the front page"
        assert (site / f"{page}.html").exists()
    # a Markdown page's own figures and heading anchors came through
    validation = _text(site / "validation.html")
    assert "dzhanibekov_comparison.png" in validation and (site / "_images" / "dzhanibekov_comparison.png").exists()


def test_api_reference_from_the_docstrings(site):
    api = _text(site / "api.html")
    for name in ("lgvi.simulate", "lgvi.Trajectory", "lgvi.RigidBody", "lgvi.so3", "lgvi.torques", "lgvi.view"):
        assert f'href="generated/{name}.html' in api, name
    simulate = _text(site / "generated" / "lgvi.simulate.html")
    assert "Parameters" in simulate and "omega0" in simulate and "ConvergenceError" in simulate
    assert "_modules/lgvi/systems/rigid_body_run.html" in simulate     # a link to its source (viewcode)
    assert (site / "_modules" / "lgvi" / "systems" / "rigid_body_run.html").exists()
    torques = _text(site / "generated" / "lgvi.torques.html")
    assert "UniformGravity" in torques and "GravityGradient" in torques


def test_gallery_pages_with_figures_made_at_build_time(site):
    """sphinx-gallery's pages (docs/_gallery.py): every example has a page with its code, a thumbnail on
    the index, downloads of the script and a notebook; the one run (kepler) shows its figure and what it
    printed; one not run (dzhanibekov) says so and shows the figures kept in docs/figures/."""
    gallery = _text(site / "gallery" / "index.html")
    examples = sorted(p.stem for p in (ROOT / "examples").glob("*.py"))
    for name in examples:
        assert f'href="{name}.html' in gallery, f"{name} is not in the gallery"
        page = _text(site / "gallery" / f"{name}.html")
        assert "def main(" in re.sub(r"<[^>]+>", "", page), f"the code of {name} is not on its page"
        assert f"{name}.py\"" in page and f"{name}.ipynb\"" in page, f"{name}: no download links"
    thumbs = re.findall(r'<img[^>]+src="([^"]+_thumb\.png)"', gallery)
    assert len(thumbs) == len(examples)
    kepler = _text(site / "gallery" / "kepler.html")
    imgs = [s for s in re.findall(r'<img[^>]+src="([^"]+\.png)"', kepler) if "sphx_glr_kepler" in s]
    assert imgs, "the kepler page has no figure"
    for src in imgs:
        png = (site / "gallery" / src).resolve()
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "Stormer-Verlet (lgvi)" in kepler                       # what it printed
    dzhanibekov = _text(site / "gallery" / "dzhanibekov.html")
    assert "LGVI_DOCS_EXAMPLES" in dzhanibekov                        # not run here: says so
    assert 'src="../_images/dzhanibekov_comparison.png"' in dzhanibekov   # and shows the stored figure


def test_math_renders_offline(site):
    """MathJax ships with the site (sphinx-mathjax-offline): pages load it from _static, never a CDN,
    and the method page's equations are math, not code."""
    method = _text(site / "method.html")
    assert "_static/mathjax/tex-chtml.js" in method
    assert (site / "_static" / "mathjax" / "tex-chtml.js").exists()
    for page in site.rglob("*.html"):
        text = page.read_text(encoding="utf-8")
        assert "cdn.jsdelivr.net" not in text and "cdnjs" not in text, f"{page.name} loads from a CDN"
    assert 'class="math' in method and r"\operatorname{tr}" in method
    # the paper column of the method's tables is math, not code
    assert r"\widehat{h \Pi_k} = F_k J_d - J_d F_k^T" in method and "hat(h" not in method


def test_numpy_and_scipy_links_without_network(site):
    """Intersphinx to NumPy and SciPy through the inventories kept in docs/_inventories (the build
    above had no network): parameter types and named objects link to the projects' pages."""
    simulate = _text(site / "generated" / "lgvi.simulate.html")
    assert 'href="https://numpy.org/doc/stable/glossary.html#term-array_like"' in simulate
    assert ('href="https://docs.scipy.org/doc/scipy/reference/generated/scipy.spatial.transform.Rotation.html'
            '#scipy.spatial.transform.Rotation"') in simulate


def test_equations_are_math_on_the_model_pages(site):
    """The equations of these pages are math (MyST's $...$ and $$ blocks), not code: every page has
    math, and no dollar sign is left in its prose (an unclosed span, or one that Markdown broke, a
    line of it read as a list item, shows its dollars as text)."""
    for page in MATH_PAGES:
        text = _text(site / f"{page}.html")
        assert text.count('class="math') >= 3, page
        prose = NOT_PROSE.sub(" ", text)
        assert "$" not in prose, f"{page}: a raw $ in the text: ...{prose[max(prose.find('$') - 80, 0):prose.find('$') + 80]}..."


@pytest.fixture(scope="module")
def browser():
    from headless_chromium import browser as chromium

    yield from chromium()


def test_math_renders_in_a_browser_offline(site, browser):
    """In headless Chromium, MathJax (shipped in _static) typesets every math element of the
    equation pages: as many rendered ``mjx-container`` as math elements, no TeX error (MathJax's
    ``merror``, or an undefined macro, which it draws in red instead of failing), no raw
    dollar sign in the text a reader sees, and nothing loaded from outside the site (the browser
    has no network here, and needs none)."""
    from headless_chromium import until

    for page in MATH_PAGES:
        browser.get((site / f"{page}.html").resolve().as_uri())
        browser.execute_script("window.__mathDone = false; (function wait() { if (window.MathJax && MathJax.startup "
                               "&& MathJax.startup.promise) { MathJax.startup.promise.then(function () "
                               "{ window.__mathDone = true; }); } else { setTimeout(wait, 50); } })();")
        until(lambda: browser.execute_script("return window.__mathDone;"))
        found = browser.execute_script(
            "var a = document.querySelector('article'), seen = a.cloneNode(true);"
            "seen.querySelectorAll('pre, code, mjx-container, script').forEach(function (e) { e.remove(); });"
            "return {math: a.querySelectorAll('.math').length, typeset: a.querySelectorAll('.math mjx-container').length,"
            " errors: Array.from(a.querySelectorAll('mjx-merror, mjx-assistive-mml mtext[mathcolor=\"red\"]'))"
            "   .map(function (e) { return e.getAttribute('data-mjx-error') || e.textContent; }),"
            " text: seen.innerText,"
            " outside: performance.getEntriesByType('resource').map(function (r) { return r.name; })"
            "   .filter(function (u) { return !u.startsWith('file:'); })};")
        assert found["math"] >= 3 and found["typeset"] == found["math"], (page, found["math"], found["typeset"])
        assert not found["errors"], f"{page}: MathJax errors {found['errors'][:5]}"
        raw = [line for line in found["text"].splitlines() if "$" in line]
        assert not raw, f"{page}: raw $ in the rendered text: {raw[:3]}"
        assert not found["outside"], f"{page} loads from outside the site: {found['outside'][:3]}"
