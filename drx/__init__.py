"""drx: a local, open-source replacement for the AWS DeepRacer console."""

__version__ = "0.1.0"


def _register_envs() -> None:
    """Register drx's Gymnasium environments (``drx/DeepRacer-v0``)."""
    try:
        from drx.sim.registration import register_envs
    except ImportError:  # the simulator package is optional while it is being built
        return
    register_envs()


_register_envs()
