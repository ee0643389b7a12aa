"""A headless Chromium driven by selenium, for the tests of the player in a real browser.

Debian's `chromium` and `chromium-driver` packages (.ci/run installs them); without them, or
without selenium, the tests that need a browser are skipped, saying why. Nothing is installed
here, and selenium is never left to fetch a driver: both executables are given by path.
Chromium runs with no background networking (the page needs none, and a closed network refuses
Chromium's own connections) in a fresh profile.
"""
from __future__ import annotations

import base64
import io
import shutil

import numpy as np
import pytest

BROWSERS = ("chromium", "chromium-browser")
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--disable-dev-shm-usage", "--force-device-scale-factor=1", "--window-size=1000,800")
WAIT_SECONDS = 30       # the longest a page may take to draw a frame: an upper bound, not a sleep


def start_chromium(profile) -> object:
    """A new headless Chromium session, or pytest.skip with the reason."""
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        pytest.skip("selenium is not installed (pip install -e '.[test]')")
    executable = next((shutil.which(name) for name in BROWSERS if shutil.which(name)), None)
    driver = shutil.which("chromedriver")
    if executable is None or driver is None:
        pytest.skip("no Chromium and chromedriver on the PATH (Debian: apt-get install chromium chromium-driver)")
    options = webdriver.ChromeOptions()
    options.binary_location = executable
    for flag in FLAGS:
        options.add_argument(flag)
    options.add_argument(f"--user-data-dir={profile}")
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    session = webdriver.Chrome(service=Service(driver), options=options)
    session.set_script_timeout(WAIT_SECONDS)
    return session


class Player:
    """A page of lagdsl's player open in the browser, paused, and what it draws."""

    def __init__(self, session, path):
        self.session = session
        session.get(path.resolve().as_uri())        # returns after the load event: frame 0 is drawn
        session.execute_script("window.lagdslPlayer.pause();")

    def errors(self) -> list[str]:
        return [entry["message"] for entry in self.session.get_log("browser") if entry["level"] == "SEVERE"]

    def show(self, frame: int) -> None:
        """Draw `frame`, waiting for the player's event that says it is drawn."""
        drawn = self.session.execute_async_script("""
            const done = arguments[arguments.length - 1];
            document.addEventListener("lagdsl:frame", event => done(event.detail.frame), {once: true});
            window.lagdslPlayer.setFrame(arguments[0]);""", frame)
        assert drawn == frame

    def after(self, action) -> int:
        """Run `action` (a user's input), then wait for the frame it makes the player draw."""
        self.session.execute_script("""
            window.drawnFrames = [];
            document.addEventListener("lagdsl:frame", event => window.drawnFrames.push(event.detail.frame));""")
        action()
        return self.session.execute_async_script("""
            const done = arguments[arguments.length - 1];
            if (window.drawnFrames.length) { done(window.drawnFrames.at(-1)); return; }
            document.addEventListener("lagdsl:frame", event => done(event.detail.frame), {once: true});""")

    def picture(self) -> np.ndarray:
        """The canvas as it is drawn: (height, width, RGB) in canvas pixels."""
        from PIL import Image
        encoded = self.session.execute_script(
            "return document.getElementById('lagdsl-canvas').toDataURL('image/png').split(',')[1];")
        return np.asarray(Image.open(io.BytesIO(base64.b64decode(encoded))).convert("RGB")).astype(int)

    def pixel_of(self, point) -> np.ndarray:
        return np.array(self.session.execute_script("return window.lagdslPlayer.pixelOf(arguments[0]);", point))

    def element(self, name: str):
        return self.session.find_element("id", name)


def coloured(picture: np.ndarray, color: str, tolerance: int = 40) -> np.ndarray:
    """The mask of the pixels within `tolerance` of a colour '#rrggbb' in each channel."""
    target = np.array([int(color[i:i + 2], 16) for i in (1, 3, 5)])
    return np.all(np.abs(picture - target) <= tolerance, axis=2)


def centroid(mask: np.ndarray) -> np.ndarray:
    """(x, y) in pixels of the mask's centre (pixel centres at + 0.5)."""
    rows, columns = np.nonzero(mask)
    assert len(rows), "no pixel of the colour"
    return np.array([columns.mean() + 0.5, rows.mean() + 0.5])
