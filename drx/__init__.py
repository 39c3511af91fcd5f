"""drx: a local, open-source replacement for the AWS DeepRacer console."""

import sys
from typing import Any

__version__ = "0.1.0"


def _register_envs() -> None:
    """Register drx's Gymnasium environments (``drx/DeepRacer-v0``)."""
    try:
        from drx.sim.registration import register_envs
    except ImportError:  # the simulator package is optional while it is being built
        return
    register_envs()


class _RegisterWhenGymnasiumLoads:
    """An import hook: once Gymnasium has been imported, register drx's environments.

    ``import drx`` then ``gymnasium.make("drx/DeepRacer-v0")`` works whichever is imported first, yet
    importing drx does not import Gymnasium (and NumPy), which most CLI commands never use and which
    cost every command about 0.2 s of start-up. (wrapt's ``register_post_import_hook`` does this too,
    but importing wrapt costs 0.09 s of the 0.2.)
    """

    def find_spec(self, name: str, path: Any = None, target: Any = None) -> Any:
        if name != "gymnasium":
            return None
        sys.meta_path.remove(self)  # once; and the other finders locate the real package
        from importlib.util import find_spec

        spec = find_spec(name)
        if spec is not None and spec.loader is not None and hasattr(spec.loader, "exec_module"):
            run = spec.loader.exec_module

            def run_then_register(module: Any) -> None:
                run(module)
                _register_envs()

            spec.loader.exec_module = run_then_register  # type: ignore[method-assign]
        return spec


if "gymnasium" in sys.modules:
    _register_envs()
else:
    sys.meta_path.insert(0, _RegisterWhenGymnasiumLoads())
