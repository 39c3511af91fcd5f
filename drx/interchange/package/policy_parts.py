"""The torch modules of a trained policy, named by the part they play.

Both exporters (:mod:`drx.interchange.package.onnx_policy` for ONNX and OpenVINO,
:mod:`drx.interchange.car.car_graph` for the car's TensorFlow graph) write a policy layer by
layer; this module says once which modules those layers are: the feature extractor
(drx's networks in :mod:`drx.train.networks`, or SB3's NatureCNN), the latent layers
and the head that gives the action, for SB3's PPO (actor-critic) and SAC policies.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from torch import nn

from drx.errors import DrxError


@dataclass(frozen=True)
class Extractor:
    """A feature extractor's parts.

    Either ``camera`` and ``lidar`` (a lidar car: the camera's extractor, then the
    lidar's layers, concatenated), or ``cnn`` then ``head`` (a camera-only extractor).
    """

    name: str
    cnn: nn.Module | None = None
    head: nn.Module | None = None
    camera: Extractor | None = None
    lidar: nn.Module | None = None


@dataclass(frozen=True)
class PolicyParts:
    """What an exporter writes, in order: ``extractor``, ``latent``, ``head``.

    ``algorithm`` is ``"sac"`` (the head gives the actor's mean, squashed by tanh)
    or ``"ppo"`` (the head gives the logits, or the Gaussian's mean when continuous).
    """

    algorithm: str
    extractor: Extractor
    latent: nn.Module
    head: nn.Module
    sde: bool = False


def _child(owner: Any, name: str) -> nn.Module:
    module = getattr(owner, name)
    if not isinstance(module, nn.Module):
        raise DrxError(f"The policy's {name} is not a torch module ({type(module).__name__}).")
    return module


def extractor_parts(extractor: nn.Module, with_lidar: bool) -> Extractor:
    """The parts of a drx or SB3 feature extractor.

    :param with_lidar: the car has a lidar, so a camera+lidar extractor is split in two.
    :raises DrxError: an extractor the exporters cannot write.
    """
    name = type(extractor).__name__
    if hasattr(extractor, "camera") and hasattr(extractor, "lidar") and with_lidar:
        camera = extractor_parts(_child(extractor, "camera"), with_lidar=False)
        return Extractor(name, camera=camera, lidar=_child(extractor, "lidar"))
    if hasattr(extractor, "cnn") and hasattr(extractor, "head"):
        return Extractor(name, cnn=_child(extractor, "cnn"), head=_child(extractor, "head"))
    # SB3's NatureCNN: convolutions, then one linear layer.
    if hasattr(extractor, "cnn") and hasattr(extractor, "linear"):
        return Extractor(name, cnn=_child(extractor, "cnn"), head=_child(extractor, "linear"))
    raise DrxError(
        f"Cannot export the feature extractor {name}; drx exports its own networks and SB3's NatureCNN."
    )


def policy_parts(policy: nn.Module, with_lidar: bool) -> PolicyParts:
    """The parts of an SB3 PPO (actor-critic) or SAC policy, as an exporter writes them."""
    if hasattr(policy, "actor"):  # SAC
        actor = _child(policy, "actor")
        return PolicyParts(
            "sac",
            extractor_parts(_child(actor, "features_extractor"), with_lidar),
            latent=_child(actor, "latent_pi"),
            head=_child(actor, "mu"),
            sde=bool(getattr(actor, "use_sde", False)),
        )
    shared = bool(getattr(policy, "share_features_extractor", True))
    extractor = _child(policy, "features_extractor" if shared else "pi_features_extractor")
    return PolicyParts(
        "ppo",
        extractor_parts(extractor, with_lidar),
        latent=_child(_child(policy, "mlp_extractor"), "policy_net"),
        head=_child(policy, "action_net"),
    )
