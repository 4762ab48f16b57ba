"""Open a report in headless Chromium: did every plot draw, did the console stay clean, how long
did it take to open; optionally a screenshot.

Uses the system's Chromium (Debian's ``chromium`` package) through Playwright's Python driver
(the ``test`` extra); no browser is downloaded.
"""

from __future__ import annotations

import os
import shutil
import time
from dataclasses import dataclass
from pathlib import Path

__all__ = ["Browser", "Rendered", "find_chromium", "render"]


@dataclass(frozen=True)
class Rendered:
    """What a page did in the browser.

    Attributes
    ----------
    seconds : float
        From navigation until every plot on the page had drawn.
    first_seconds : float
        From navigation until the plots on the first screen had drawn (``window.rmReady``;
        the others draw as they are scrolled to).
    console_errors : tuple of str
        Console errors and uncaught exceptions.
    dialogs : tuple of str
        Alerts, confirms or prompts the page opened (a report never should).
    undrawn : tuple of str
        Ids of plots that drew nothing.
    n_plots : int
        Plots on the page.
    """

    seconds: float
    first_seconds: float
    console_errors: tuple
    dialogs: tuple
    undrawn: tuple
    n_plots: int


def find_chromium() -> str | None:
    """Path of the system Chromium (``RMBENCH_CHROMIUM`` overrides), or None."""
    env = os.environ.get("RMBENCH_CHROMIUM")
    if env:
        return env if Path(env).exists() else None
    for name in ("chromium", "chromium-browser"):
        p = shutil.which(name)
        if p:
            return p
    return None


class Browser:
    """One headless Chromium that opens many reports: ``with Browser() as b: b.render(path)``.

    Starting Chromium costs about a second; a page rendered through an open browser gets a fresh
    page (its own console and dialogs) but not a fresh process.
    """

    def __init__(self):
        self._pw = self._browser = None

    def __enter__(self) -> "Browser":
        from playwright.sync_api import sync_playwright

        exe = find_chromium()
        if exe is None:
            raise RuntimeError("no Chromium found (install Debian's chromium package)")
        self._pw = sync_playwright().start()
        try:
            self._browser = self._pw.chromium.launch(executable_path=exe, headless=True, args=["--no-sandbox"])
        except BaseException:
            self._pw.stop()
            raise
        return self

    def __exit__(self, *exc) -> None:
        try:
            if self._browser is not None:
                self._browser.close()
        finally:
            self._pw.stop()
            self._pw = self._browser = None

    def render(self, path, *, screenshot=None, timeout_s: float = 60.0, width: int = 1400) -> Rendered:
        """Open ``path`` in a new page and wait until all its plots drew (see :func:`render`)."""
        if self._browser is None:
            raise RuntimeError("Browser.render outside its with-block")
        errors, dialogs = [], []
        page = self._browser.new_page(viewport={"width": width, "height": 900})
        try:
            page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            page.on("pageerror", lambda e: errors.append(str(e)))

            def on_dialog(d):
                dialogs.append(d.message)
                d.dismiss()

            page.on("dialog", on_dialog)
            t0 = time.perf_counter()
            page.goto(Path(path).resolve().as_uri(), wait_until="load", timeout=timeout_s * 1e3)
            page.wait_for_function("window.rmReady === true", timeout=timeout_s * 1e3)
            first = time.perf_counter() - t0
            page.evaluate("rm.drawAll()")            # the plots further down the page
            seconds = time.perf_counter() - t0
            undrawn = page.evaluate("rm.undrawn()")
            n = page.evaluate("document.querySelectorAll('.js-plotly-plot').length")
            if screenshot is not None:
                jpeg = Path(screenshot).suffix.lower() in (".jpg", ".jpeg")
                page.screenshot(path=str(screenshot), full_page=True, **({"quality": 60} if jpeg else {}))
        finally:
            page.close()
        return Rendered(seconds, first, tuple(errors), tuple(dialogs), tuple(undrawn), int(n))


    def evaluate(self, path, script: str, *, timeout_s: float = 60.0):
        """Open ``path``, wait for its first plots, and return what ``script`` (a JavaScript
        expression; a promise is awaited) evaluates to."""
        if self._browser is None:
            raise RuntimeError("Browser.evaluate outside its with-block")
        page = self._browser.new_page()
        try:
            page.goto(Path(path).resolve().as_uri(), timeout=timeout_s * 1e3)
            page.wait_for_function("window.rmReady === true", timeout=timeout_s * 1e3)
            return page.evaluate(script)
        finally:
            page.close()


def render(path, *, screenshot=None, timeout_s: float = 60.0, width: int = 1400) -> Rendered:
    """Open ``path`` in headless Chromium (started for this page alone) and wait until all its
    plots drew.

    Parameters
    ----------
    path : path-like
        An HTML report.
    screenshot : path-like, optional
        Image of the whole page (PNG, or JPEG when the name ends in .jpg).
    """
    with Browser() as b:
        return b.render(path, screenshot=screenshot, timeout_s=timeout_s, width=width)
