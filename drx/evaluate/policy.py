"""A trained model's policy as a time-trial driver: the most probable action at every step."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from drx.errors import not_a_file
from drx.vehicle import Vehicle


class ModelPolicy:
    """The policy stored in a checkpoint, driving with its most probable action.

    Discrete cars take the action of highest probability; continuous cars the
    mean of the action distribution (SAC: its deterministic action).

    :param path: the checkpoint ``.zip``, or the ``model.pb`` of an imported DeepRacer model
        (run by OpenVINO, :mod:`drx.interchange.car.openvino_policy`).
    :param vehicle: the car it drives (a checkpoint's policy is rebuilt for it from the weights alone).
    """

    def __init__(self, path: Path, vehicle: Vehicle) -> None:
        from drx.interchange.package.onnx_policy import load_policy

        if not Path(path).is_file():
            raise not_a_file(path, "Checkpoint")
        self.graph: Any = None
        if Path(path).suffix == ".pb":
            from drx.interchange.car.openvino_policy import OpenVINOPolicy

            self.graph = OpenVINOPolicy.from_file(Path(path))
            return
        self.policy = load_policy(Path(path), vehicle)

    def __call__(self, observation: Any) -> Any:
        """The most probable action for one observation."""
        if self.graph is not None:
            return self.graph(observation)
        action, _ = self.policy.predict(observation, deterministic=True)
        return action
