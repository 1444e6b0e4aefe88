"""Headless Chromium for the tests that look at a page as a person would (``test_view_browser.py``,
``test_docs_site.py``): Debian's ``chromium`` and ``chromium-driver``, driven by selenium.

``browser(*modules)`` is the body of a module-scoped fixture: it yields a driver, or skips saying
how to install what is missing (``make browser`` as root, which ``make test`` runs); in CI (the
``CI`` variable set) a missing browser fails. ``until(condition)`` polls without a clock: a busy
machine draws slowly, and pytest's own limits, or CI's, end a page that never draws.
"""

from __future__ import annotations

import importlib
import os
import shutil
import tempfile
import time
from collections.abc import Callable, Iterator

import pytest

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
DRIVER = shutil.which("chromedriver")
FLAGS = ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--enable-unsafe-swiftshader",  # WebGL in software (plotly's 3D scene) without a GPU
         "--window-size=1400,1000", "--force-device-scale-factor=1")


def missing(*modules: str) -> str | None:
    """Why the browser tests cannot run here (a Python package or the browser is missing), or None."""
    for name in ("selenium", *modules):
        try:
            importlib.import_module(name)
        except ImportError as exc:
            return f"{exc.name} is not installed (pip install -e '.[test,plot]')"
    if CHROMIUM is None or DRIVER is None:
        return ("headless Chromium is not installed: run `make browser` as root (Debian: apt-get install "
                "chromium chromium-driver)")
    return None


def browser(*modules: str) -> Iterator:
    """A headless Chromium driver with its console log kept, in a profile of its own (removed after)."""
    why = missing(*modules)
    if why is not None:
        if os.environ.get("CI"):
            pytest.fail(f"the browser test must run in CI: {why}")
        pytest.skip(why)
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    profile = tempfile.mkdtemp(prefix="lgvi-chromium-")
    for flag in FLAGS + (f"--user-data-dir={profile}",):
        opts.add_argument(flag)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(options=opts, service=Service(DRIVER))
    yield driver
    driver.quit()
    shutil.rmtree(profile, ignore_errors=True)


def until(condition: Callable[[], object]) -> None:
    """Poll ``condition()`` until it holds: no clock (see the module's docstring)."""
    while not condition():
        time.sleep(0.05)
