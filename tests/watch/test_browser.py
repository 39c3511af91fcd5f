"""The watch page in a real browser (headless Chromium): it loads, its pictures move, its graph grows."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from drx.watch.server import WatchServer, make_server, serve_in_thread, shutdown
from tests.watch.browser import IMAGE_FINGERPRINT, chromium, missing
from tests.watch.simulated import SimulatedJob

WHY = missing()
pytestmark = pytest.mark.skipif(WHY is not None, reason=f"no browser to test the watch page: {WHY}")


@pytest.fixture
def page(job: SimulatedJob) -> Iterator[tuple[Any, WatchServer]]:
    srv = make_server(0)  # no model given: the page follows the running job
    serve_in_thread(srv)
    driver = chromium()
    driver.set_page_load_timeout(60)
    try:
        yield driver, srv
    finally:
        driver.quit()
        shutdown(srv)


def wait_for(check: Callable[[], Any], seconds: float = 30.0) -> Any:
    deadline = time.monotonic() + seconds
    while True:
        value = check()
        if value:
            return value
        assert time.monotonic() < deadline, "timed out waiting in the browser"
        time.sleep(0.2)


def test_the_page_shows_the_car_driving_and_the_graph_growing(
    page: tuple[Any, WatchServer], job: SimulatedJob, tmp_path: Path
) -> None:
    driver, srv = page
    job.end_iteration()
    job.drive("training")
    driver.get(srv.url)
    js = driver.execute_script
    wait_for(lambda: js("return window.drxWatch.events") >= 1)
    assert driver.find_element("id", "model").text == "wm"
    wait_for(lambda: js("return document.getElementById('phase').textContent") == "sampling episodes")
    assert js("return window.drxWatch.points") == 1

    for view in ("top", "camera"):  # the streams show pictures, and they change as the car drives
        first = wait_for(lambda v=view: js(IMAGE_FINGERPRINT, v))
        wait_for(lambda v=view, f=first: js(IMAGE_FINGERPRINT, v) not in (None, f), seconds=20)

    job.end_iteration()
    wait_for(lambda: js("return window.drxWatch.points") == 2)
    job.end_iteration()
    wait_for(lambda: js("return window.drxWatch.points") == 3)
    legend = driver.find_element("css selector", ".u-legend").text
    assert "Average reward (training)" in legend and "Average % completion (evaluation)" in legend
    figures = driver.find_element("id", "figures").text
    assert "Iteration" in figures and "#1 train" in figures

    shot = tmp_path / "watch.png"
    assert driver.save_screenshot(str(shot)) and shot.stat().st_size > 50_000
