"""Which DeepRacer simulator's car a model trains and races on, and whether training varies it.

DeepRacer's simulator changed its car between versions (``docs/DYNAMICS.md``, "Simulator 6"):
version 5 (ROS 1, Gazebo 11 with ODE) is what the console ran until it closed; version 6 (ROS 2,
Gazebo Harmonic with DART, servo-held steering lagging about 0.16 s, a 15 % heavier car) is what
DeepRacer on AWS and deepracer-for-cloud 6.x race on since 2026. drx has a car for each
(:meth:`drx.sim.dynamics.CarParams.for_simulator`). A new model trains on version 6's, the venues';
a model from before the setting keeps version 5's, the car it trained on (migration 0009s).
``car_randomization`` draws a new car for every training episode between the two
(:mod:`drx.sim.car_randomization`), so that a model holds on either.
"""

from __future__ import annotations

from dataclasses import dataclass

from drx.errors import SettingError

SIMULATORS = ("5", "6")  # the versions a model can train on (4 is a fitted car for old logs only)
DEFAULT_SIMULATOR = "6"  # new models: the car DeepRacer on AWS and deepracer-for-cloud race on
LEGACY_SIMULATOR = "5"  # models from before the setting trained on it
SIMULATOR_HELP = "5 (the console's, ODE) or 6 (DeepRacer on AWS and deepracer-for-cloud since 2026, DART)"


def check_simulator(value: object, field: str = "simulator") -> str:
    """``value`` as drx stores a simulator version (``"5"`` or ``"6"``; ``5.0`` and ``"6.0"`` too).

    :raises SettingError: any other version.
    """
    text = str(value).strip()
    if text.endswith(".0"):
        text = text[:-2]
    if text not in SIMULATORS:
        raise SettingError(
            "{field} {value!r} is not a DeepRacer simulator drx has a car for; use {allowed}.",
            field,
            value=value,
            allowed=SIMULATOR_HELP,
        )
    return text


@dataclass(frozen=True)
class CarSettings:
    """A model's car settings (the ``simulator`` and ``car_randomization`` columns).

    :param simulator: the DeepRacer simulator whose car it trains and races on (:data:`SIMULATORS`).
    :param car_randomization: every training episode draws a car between versions 5 and 6
        (:mod:`drx.sim.car_randomization`); evaluations drive ``simulator``'s car.
    :raises SettingError: an unknown simulator.
    """

    simulator: str = DEFAULT_SIMULATOR
    car_randomization: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "simulator", check_simulator(self.simulator))
        object.__setattr__(self, "car_randomization", bool(self.car_randomization))


SIMULATOR_NAMES = {
    "5": "DeepRacer simulator 5 (the console, deepracer-for-cloud 5.x)",
    "6": "DeepRacer simulator 6 (DeepRacer on AWS, deepracer-for-cloud 6.x)",
}


def simulator_label(settings: CarSettings) -> str:
    """How ``drx model show``, the dashboard and ``drx info`` name the car: the simulator, and the
    randomization when on."""
    label = SIMULATOR_NAMES[settings.simulator]
    if settings.car_randomization:
        label += "; training draws a car between 5's and 6's"
    return label


def simulator_of_metadata(version: object) -> tuple[str, str | None]:
    """The car a model from DeepRacer's ``model_metadata.json`` trains and races on in drx, from its
    ``version`` (``"6"``, ``"5.0"``, the JSON number ``5``...), and a sentence when drx drives another
    version's car than the one named (``None`` when it drives that one): a version 6 model gets
    simulator 6's car, 5 gets 5's; anything older, newer or unreadable gets 5's, the nearest car drx
    fitted to DeepRacer's own logs."""
    if version is None or str(version).strip() == "":
        return LEGACY_SIMULATOR, None
    text = str(version).strip().lstrip("vV")
    try:
        major = str(int(float(text)))
    except ValueError:
        major = ""
    if major in SIMULATORS:
        return major, None
    return LEGACY_SIMULATOR, (
        f"Its model_metadata.json names simulator version {version}; drx has cars for "
        f"{' and '.join(SIMULATORS)} only, so it drives version {LEGACY_SIMULATOR}'s."
    )
