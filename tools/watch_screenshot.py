"""A still picture of ``drx watch`` during a real training job (for the docs).

Trains a small model (compact network, 5 episodes per iteration) in a private data home with
``drx train`` in another process, serves the watch page here, and once a few iterations have
ended and the car is sampling episodes, saves headless Chromium's picture of the whole page.

    python tools/watch_screenshot.py docs/watch.png --track kidney --iterations 6

Needs Debian's chromium and chromium-driver (``tools/test_deps.sh``) and selenium.
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, help="the PNG to write")
    parser.add_argument("--track", default="kidney", help="a built-in track")
    parser.add_argument("--iterations", type=int, default=6, help="iterations to wait for")
    parser.add_argument("--width", type=int, default=1440, help="browser window width [px]")
    args = parser.parse_args()

    home = Path(tempfile.mkdtemp(prefix="drx-watch-shot-"))
    os.environ["DRX_HOME"] = str(home)
    sys.path.insert(0, str(ROOT))
    drx = [sys.executable, "-m", "drx.cli.main"]
    env = {**os.environ, "PYTHONPATH": str(ROOT), "DRX_TORCH_THREADS": "1"}
    subprocess.run(
        [*drx, "model", "create", "kidney-runner", "--track", args.track, "--network", "compact",
         "--episodes-per-iteration", "5", "--max-minutes", "15"],
        check=True, env=env, stdout=subprocess.DEVNULL,
    )  # fmt: skip
    trainer = subprocess.Popen(
        [*drx, "train", "kidney-runner", "--seed", "3"], env=env,
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        # Ctrl-C must reach it even when this script runs in the background (which ignores SIGINT)
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )  # fmt: skip

    from drx.watch.server import make_server, serve_in_thread, shutdown
    from drx.watch.state import SAMPLING, snapshot
    from tests.watch.browser import chromium

    server = make_server(0)
    serve_in_thread(server)
    driver = chromium(args.width, 1000)
    try:
        deadline = time.monotonic() + 900
        while time.monotonic() < deadline:
            snap = snapshot("kidney-runner")
            done = len(snap["graph"]["iteration"])
            driving = snap["phase"] == SAMPLING and (snap["pose"] or {}).get("steps", 0) > 40
            if done >= args.iterations and driving:
                break
            time.sleep(0.5)
        driver.get(server.url)
        time.sleep(2.0)  # the first events and pictures
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline:  # a moment when the car is some way into a training episode
            s = driver.execute_script("return window.drxWatch.state")
            if s and s["phase"] == SAMPLING and (s.get("pose") or {}).get("steps", 0) > 60:
                break
            time.sleep(0.1)
        height = driver.execute_script("return document.documentElement.scrollHeight")
        driver.execute_cdp_cmd(  # the whole page in one picture
            "Emulation.setDeviceMetricsOverride",
            {"width": args.width, "height": height, "deviceScaleFactor": 1, "mobile": False},
        )
        time.sleep(1.5)
        args.out.parent.mkdir(parents=True, exist_ok=True)
        driver.save_screenshot(str(args.out))
        print(f"wrote {args.out} ({args.width} x {height}); phase {snapshot('kidney-runner')['phase']}")
    finally:
        driver.quit()
        shutdown(server)
        trainer.send_signal(signal.SIGINT)  # Ctrl-C: the job stops (SIGTERM would hand it back to the queue)
        trainer.wait(timeout=120)


if __name__ == "__main__":
    main()
