"""Driving Debian's Chromium headless with Playwright's Python package (tests, bench, screenshots).

Owns where the browser is and how it is started: `/usr/bin/chromium` (the `chromium` package;
never `playwright install`, which downloads a browser), software WebGL through SwiftShader, and no
background networking (machines without a network refuse it). `chromium_problem()` says why the
browser cannot be used here, or returns "" when it can.
"""

from __future__ import annotations

import os
import shutil

CHROMIUM_PATH = "/usr/bin/chromium"
CHROMIUM_ARGS = (
    "--headless",
    "--no-sandbox",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--no-first-run",
)


def chromium_path() -> str | None:
    """The Chromium executable: /usr/bin/chromium, else `chromium` on the PATH, else None."""
    if os.path.exists(CHROMIUM_PATH):
        return CHROMIUM_PATH
    return shutil.which("chromium")


def chromium_problem() -> str:
    """Why the browser tests cannot run here ("" if they can)."""
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "the playwright Python package is not installed (pip install -e '.[test]')"
    if chromium_path() is None:
        return "Chromium is not installed (Debian/Ubuntu: apt-get install chromium)"
    return ""


def launch(playwright, **options):
    """A headless Chromium browser from a `sync_playwright()` context."""
    return playwright.chromium.launch(executable_path=chromium_path(), args=list(CHROMIUM_ARGS), **options)
