"""The interactive page in a real browser: headless Chromium (Debian's ``chromium`` and
``chromium-driver``, driven by selenium) opens the file written by ``lgvi view``.

Checked as a person would see it: no error on the browser's console, the 3D view is drawn (the
pixels inside its canvas vary), the time scrubber turns the body (the drawn attitude and the
pixels change), play runs the animation. The screenshots are saved in the test's temporary
folder (``pytest --basetemp=DIR`` keeps them where you can look at them).

Without a browser the test skips, saying how to install one (``make browser`` as root, which
``make test`` runs); in CI (the ``CI`` variable set) a missing browser fails.
"""

from __future__ import annotations

import io

import numpy as np
import pytest

import lgvi
from headless_chromium import browser as chromium
from headless_chromium import until as _until


@pytest.fixture(scope="module")
def browser():
    yield from chromium("plotly", "PIL")


def _frames(driver, n: int = 3) -> None:
    """Wait until the page has drawn ``n`` more animation frames (the WebGL scene draws on them)."""
    driver.execute_script("window.__lgviFrames = 0; (function tick() { window.__lgviFrames += 1; "
                          f"if (window.__lgviFrames < {n + 1}) requestAnimationFrame(tick); }})();")
    _until(lambda: driver.execute_script(f"return window.__lgviFrames >= {n + 1};"))


def _open(driver, path) -> None:
    driver.get(path.resolve().as_uri())
    driver.get_log("browser")  # the log so far belongs to this page; read (and empty) it in _errors
    js = ("var el = document.querySelector('.lgvi-plot'); return !!(el && el._fullLayout && "
          "el.querySelector('.gl-container canvas') && el._transitionData && el._transitionData._frames.length);")
    _until(lambda: driver.execute_script(js))
    _frames(driver)


def _errors(driver) -> list[str]:
    return [e["message"] for e in driver.get_log("browser") if e["level"] == "SEVERE"]


def _canvas(driver, path, selector=".lgvi-plot .gl-container canvas") -> np.ndarray:
    """The screenshot's pixels inside the 3D canvas, (h, w, 3); the whole screenshot saved to ``path``."""
    from PIL import Image

    png = driver.get_screenshot_as_png()
    path.write_bytes(png)
    rect = driver.execute_script(f"var r = document.querySelector('{selector}').getBoundingClientRect();"
                                 "return [r.left, r.top, r.width, r.height];")
    x, y, w, h = (int(round(v)) for v in rect)
    img = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.int16)
    assert w > 200 and h > 200, f"the 3D canvas is {w} x {h} pixels"
    return img[max(y, 0):y + h, max(x, 0):x + w]


def _attitude(driver) -> np.ndarray:
    """The tips of the three body axes as drawn now (traces 1 to 3 of the plot, decoded by plotly.js)."""
    return np.array(driver.execute_script(
        "var d = document.querySelector('.lgvi-plot')._fullData; return [1, 2, 3].map(function (i) { "
        "return [Number(d[i].x[1]), Number(d[i].y[1]), Number(d[i].z[1])]; });"), dtype=np.float64)


@pytest.fixture(scope="module")
def page(tmp_path_factory):
    from lgvi import view

    traj = lgvi.simulate([1.0, 2.0, 3.0], np.eye(3), omega0=[0.3, 1.0, 0.2], h=0.01, steps=4000)
    return view.write_html(traj, tmp_path_factory.mktemp("page") / "view.html", max_frames=60), traj


def test_page_draws_and_the_scrubber_turns_the_body(browser, page):
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    page, traj = page
    frames = np.unique(np.linspace(0, len(traj.t) - 1, 60).round().astype(int))

    _open(browser, page)
    shots = page.parent
    before = _canvas(browser, shots / "view-start.png")
    assert not _errors(browser), _errors(browser)
    # not blank: a drawn box, axes and grid give many colours and real contrast inside the canvas
    assert before.std() > 15, f"the 3D canvas looks blank (pixel std {before.std():.1f})"
    assert len(np.unique(before.reshape(-1, 3), axis=0)) > 50
    att0 = _attitude(browser)

    # drag the scrubber to about two thirds of its rail, as a person would
    rail = browser.find_element(By.CSS_SELECTOR, ".slider-container .slider-rail-touch-rect")
    width = rail.size["width"]
    ActionChains(browser).move_to_element_with_offset(rail, int(-width / 2 + 5), 0).click_and_hold() \
        .move_by_offset(int(width * 0.66), 0).release().perform()
    active_js = "return document.querySelector('.lgvi-plot').layout.sliders[0].active;"
    cursor_js = "return document.querySelector('.lgvi-plot').layout.shapes[0].x0;"

    def settled() -> bool:   # the slider's frame is drawn: its cursor and a new attitude
        k = browser.execute_script(active_js)
        return (k > 0 and browser.execute_script(cursor_js) == pytest.approx(traj.t[frames[k]])
                and np.abs(_attitude(browser) - att0).max() > 0.1)

    _until(settled)          # however long a busy machine takes; no clock
    _frames(browser)
    active = browser.execute_script(active_js)
    assert 30 <= active <= 50, f"the slider is at step {active} after the drag"
    after = _canvas(browser, shots / "view-scrubbed.png")
    att1 = _attitude(browser)
    # the body axes drawn are those of the trajectory at the slider's time: R_k e_i
    R = traj.R[frames[active]]
    assert np.allclose(att1 / np.linalg.norm(att1, axis=1)[:, None], R.T, atol=1e-3)
    assert np.abs(att1 - att0).max() > 0.1, "the drawn attitude did not change"
    assert np.abs(after - before).max(axis=2).astype(bool).mean() > 0.005, "the 3D view did not change"
    # the cursor of the linked plots moved with it
    assert browser.execute_script(cursor_js) == pytest.approx(traj.t[frames[active]])
    # play runs the animation from there (waited for until a later frame is drawn); pause stops it
    buttons = browser.find_elements(By.CSS_SELECTOR, ".updatemenu-button")
    buttons[0].click()
    _until(lambda: np.abs(_attitude(browser) - att1).max() > 1e-6)
    buttons[1].click()
    _frames(browser)
    moved = browser.execute_script(active_js)
    assert moved > active, f"play did not advance the animation ({active} -> {moved})"
    assert not _errors(browser), _errors(browser)


def test_inline_views_share_one_library(browser, tmp_path, monkeypatch):
    """Two Jupyter displays on one page: the first embeds plotly.js, the second uses it."""
    from lgvi import view

    monkeypatch.setattr(view, "_inline_library_sent", False)
    traj = lgvi.simulate([1.0, 2.0, 3.0], np.eye(3), omega0=[0.3, 1.0, 0.2], h=0.01, steps=500)
    parts = [traj._repr_mimebundle_()["text/html"] for _ in range(2)]
    path = tmp_path / "notebook.html"
    path.write_text("<!DOCTYPE html><html><head><meta charset='utf-8'></head><body>" + "".join(parts)
                    + "</body></html>", encoding="utf-8")
    _open(browser, path)
    drawn = browser.execute_script("return Array.from(document.querySelectorAll('.lgvi-plot')).map("
                                   "function (el) { return !!el._fullLayout; });")
    assert drawn == [True, True]
    assert not _errors(browser), _errors(browser)


def _drawn(driver, trace: int) -> np.ndarray:
    """The points of a trace of the 3D scene as drawn now (decoded by plotly.js), (P, 3)."""
    return np.array(driver.execute_script(
        f"var d = document.querySelector('.lgvi-plot')._fullData[{trace}]; return Array.from(d.x).map("
        "function (x, i) { return [Number(x), Number(d.y[i]), Number(d.z[i])]; });"), dtype=np.float64)


def test_chain_and_slosh_pages_draw_and_the_scrubber_moves_the_links(browser, tmp_path):
    """The pages of the two systems that declare theirs (System.view): drawn without an error, the
    chain's links drawn where the trajectory has them at the scrubber's frame, the slosh hub's
    pendulums from their pivots to their masses."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    from lgvi import view

    chain = lgvi.simulate_chain([1.0, 0.5, 0.5], [1.0, 1.0, 1.0], [[1, 0, 0], [0, 1, 0], [0, 0, -1]],
                                [[0, 1, 0], [0, 0, 2], [1, 0, 0]], h=1e-3, steps=3000, save_every=10)
    page = view.write_html(chain, tmp_path / "chain.html", max_frames=40)
    frames = np.unique(np.linspace(0, len(chain.t) - 1, 40).round().astype(int))
    _open(browser, page)
    before = _canvas(browser, tmp_path / "chain-start.png")
    assert not _errors(browser), _errors(browser)
    assert before.std() > 15 and len(np.unique(before.reshape(-1, 3), axis=0)) > 50
    assert np.allclose(_drawn(browser, 0)[1:], chain.positions[0], atol=1e-4)
    rail = browser.find_element(By.CSS_SELECTOR, ".slider-container .slider-rail-touch-rect")
    width = rail.size["width"]
    ActionChains(browser).move_to_element_with_offset(rail, int(-width / 2 + 5), 0).click_and_hold() \
        .move_by_offset(int(width * 0.5), 0).release().perform()
    active_js = "return document.querySelector('.lgvi-plot').layout.sliders[0].active;"

    def settled() -> bool:
        k = browser.execute_script(active_js)
        return k > 0 and np.allclose(_drawn(browser, 0)[1:], chain.positions[frames[k]], atol=1e-4)

    _until(settled)
    _frames(browser)
    after = _canvas(browser, tmp_path / "chain-scrubbed.png")
    assert np.abs(after - before).max(axis=2).astype(bool).mean() > 0.002, "the 3D view did not change"
    assert not _errors(browser), _errors(browser)

    sl = lgvi.simulate_slosh([900.0, 800.0, 600.0], 1500.0, [[0.5, 0.1, 0.2], [-0.3, 0.4, -0.1]], [0.3, 0.4],
                             [40.0, 60.0], np.eye(3), [[0.0, 0.0, -1.0], [0.6, 0.0, -0.8]],
                             [[0.5, 0.2, 0.0], [0.0, 1.0, 0.0]], omega0=[0.3, -0.2, 0.5], h=0.01, steps=600,
                             save_every=5)
    _open(browser, view.write_html(sl, tmp_path / "slosh.html", max_frames=30))
    shot = _canvas(browser, tmp_path / "slosh-start.png")
    assert not _errors(browser), _errors(browser)
    assert shot.std() > 15
    names = browser.execute_script("return document.querySelector('.lgvi-plot')._fullData.map("
                                   "function (d) { return d.name; });")
    for i in range(2):
        seg = _drawn(browser, names.index(f"pendulum {i + 1}: {sl.masses[i]:g} kg, {sl.lengths[i]:g} m"))
        assert np.allclose(seg, [sl.pivots[i], sl.pivots[i] + sl.lengths[i] * sl.q[0, i]], atol=1e-4)


def test_loop_page_draws_the_orbit_and_moves_the_spacecraft(browser, tmp_path):
    """A run of the compiled loop (tests/view_cases.py): the orbit's 3D view is drawn below the
    body's, and a frame shown moves the spacecraft along the track to the position recorded then;
    the strip names the modes."""
    from view_cases import orbit_run

    from lgvi import view

    traj = orbit_run()
    path = view.write_html(traj, tmp_path / "loop.html", max_frames=40)
    _open(browser, path)
    browser.execute_script("document.querySelector('#scene2').scrollIntoView();")    # below the first screen
    _frames(browser)
    orbit = _canvas(browser, tmp_path / "loop-start.png", "#scene2 canvas")
    assert not _errors(browser), _errors(browser)
    assert orbit.std() > 15 and len(np.unique(orbit.reshape(-1, 3), axis=0)) > 50, "the orbit view looks blank"
    craft_js = ("var el = document.querySelector('.lgvi-plot'); var d = el._fullData.filter(function (t) { "
                "return t.name === 'the spacecraft'; })[0]; return [Number(d.x[0]), Number(d.y[0]), Number(d.z[0])];")
    start = np.array(browser.execute_script(craft_js))
    r = traj.signals["r_N"] / view.EARTH_RADIUS
    assert np.allclose(start, r[0], atol=1e-4)
    browser.execute_script("Plotly.animate(document.querySelector('.lgvi-plot'), ['25'], {mode: 'immediate', "
                           "frame: {duration: 0, redraw: true}, transition: {duration: 0}});")
    k = np.unique(np.linspace(0, len(traj.t) - 1, 40).round().astype(int))[25]
    want = r[int(np.searchsorted(traj.signal_t, traj.t[k], side="right") - 1)]
    _until(lambda: np.allclose(browser.execute_script(craft_js), want, atol=1e-4))
    _frames(browser)
    moved = _canvas(browser, tmp_path / "loop-frame25.png", "#scene2 canvas")
    assert np.abs(moved - orbit).max(axis=2).astype(bool).mean() > 0.001, "the orbit view did not change"
    strip = browser.execute_script("return Array.from(document.querySelectorAll('.lgvi-plot .annotation-text'))"
                                   ".map(function (a) { return a.textContent; });")
    assert "coast" in strip and "nadir" in strip
    # the body view traces the axis tip over the last orbit only (the run spans more than one)
    path_js = ("var d = document.querySelector('.lgvi-plot')._fullData.filter(function (t) { "
               "return t.name.indexOf('path of the') === 0; })[0]; "
               "return [d.name, Number(d.x[0]), Number(d.y[0]), Number(d.z[0]), d.x.length];")
    name, *first, n = browser.execute_script(path_js)
    k0 = int(np.searchsorted(traj.t, traj.t[-1] - 2 * np.pi * np.sqrt(6878137.0 ** 3 / 3.986004418e14)))
    moments, V, _ = view._principal(traj.inertia)
    assert name.endswith(f"the last orbit (from t = {traj.t[k0]:.6g} s)") and n == len(traj.t) - k0
    assert np.allclose(np.array(first) / np.linalg.norm(first), traj.R[k0] @ V[:, view.traced_axis(moments)],
                       atol=1e-4)
    assert not _errors(browser), _errors(browser)
