"""Headless Chromium through Selenium for the watch page's tests (and its screenshot).

Debian's ``chromium`` and ``chromium-driver`` packages (``tools/test_deps.sh`` installs them) are
driven with their own matching chromedriver, so Selenium never downloads a browser.
"""

from __future__ import annotations

import shutil
from typing import Any

BROWSERS = ("chromium", "chromium-browser", "google-chrome")


def missing() -> str | None:
    """Why no browser can be driven here, or ``None`` when one can."""
    try:
        import selenium  # noqa: F401
    except ImportError:
        return "selenium is not installed (pip install -e '.[dev]')"
    if not any(shutil.which(b) for b in BROWSERS):
        return "no Chromium here (tools/test_deps.sh installs Debian's chromium and chromium-driver)"
    if not shutil.which("chromedriver"):
        return "no chromedriver here (tools/test_deps.sh installs Debian's chromium-driver)"
    return None


def chromium(width: int = 1440, height: int = 1000) -> Any:
    """A headless Chromium WebDriver with a window of ``width`` x ``height`` CSS pixels."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    opts.binary_location = next(p for b in BROWSERS if (p := shutil.which(b)))
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--disable-gpu",
                f"--window-size={width},{height}", "--hide-scrollbars"):  # fmt: skip
        opts.add_argument(arg)
    return webdriver.Chrome(service=Service(shutil.which("chromedriver")), options=opts)


# A fingerprint of what an <img> shows now (drawn into a canvas: same origin, so readable).
IMAGE_FINGERPRINT = """
const img = document.getElementById(arguments[0]);
if (!img || !img.naturalWidth) return null;
const c = document.createElement("canvas");
c.width = img.naturalWidth; c.height = img.naturalHeight;
const g = c.getContext("2d");
g.drawImage(img, 0, 0);
const d = g.getImageData(0, 0, c.width, c.height).data;
let h = 0;
for (let i = 0; i < d.length; i += 7) h = (h * 31 + d[i]) % 1000000007;
return h;
"""
