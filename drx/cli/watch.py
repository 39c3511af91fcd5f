"""``drx watch [MODEL]``: a local web page that shows a job's car driving and its reward graph.

The server and OpenCV load inside the command, so ``drx --help`` stays quick.
"""

from __future__ import annotations

import os
import sys
import webbrowser
from typing import Annotated

import typer

from drx.cli.output import console

DEFAULT_PORT = 8765


def _has_display() -> bool:
    """Whether a browser can open a window here (a text-mode browser would take over the terminal)."""
    if sys.platform in ("darwin", "win32"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def watch(
    model: Annotated[
        str | None,
        typer.Argument(
            help="The model to watch; default: the model of the newest running job (followed as jobs change)."
        ),
    ] = None,
    port: Annotated[
        int | None,
        typer.Option(
            help=f"TCP port on 127.0.0.1; default {DEFAULT_PORT} (any free port when it is taken); "
            "0: any free port."
        ),
    ] = None,
    browser: Annotated[
        bool,
        typer.Option("--browser/--no-browser", help="Open the page in a browser (when there is a display)."),
    ] = True,
) -> None:
    """Watch a job train or race in the browser: the car from above and through its camera,
    live, the reward graph growing per iteration, the job's phase and figures.

    Works for jobs run by any worker on this machine; it reads the registry and the job's files.
    Ctrl-C stops the page.

    Example:

      drx watch m1 --no-browser
    """
    import signal

    from drx.watch.server import make_server, port_free

    chosen = DEFAULT_PORT if port is None else port
    if port is None and not port_free(DEFAULT_PORT):
        chosen = 0  # another `drx watch` has the default port: any free one
    server = make_server(chosen, model)
    url = server.url + (f"?model={model}" if model else "")
    console.print(f"drx watch: {url}  (Ctrl-C to stop)", soft_wrap=True)
    sys.stdout.flush()
    if browser and _has_display():
        webbrowser.open(url)
    elif browser:
        console.print("No display here: open the address above in a browser.", soft_wrap=True)
    # Ctrl-C stops the server even when a parent started it with SIGINT ignored (a shell's
    # background job): Python then installs no KeyboardInterrupt handler of its own.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        server.serve_forever(poll_interval=0.5)
    except KeyboardInterrupt:
        raise typer.Exit(130) from None
    finally:
        server.closing.set()
        server.server_close()
