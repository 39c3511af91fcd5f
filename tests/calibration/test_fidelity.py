"""drx's car against issue 10's fidelity targets, on DeepRacer's own logs (``../shared/deepracer-logs``)."""

from __future__ import annotations

from pathlib import Path

import pytest

from drx.calibration.fidelity import Measurement, checks, held_out, held_out_checks, measure
from drx.calibration.logs import SIMULATOR_OF_SET
from drx.sim.dynamics import CarParams

LOGS = Path(__file__).resolve().parents[2].parent / "shared" / "deepracer-logs"


@pytest.fixture(scope="module")
def measurement() -> Measurement:
    if not LOGS.is_dir():
        pytest.skip(f"{LOGS} is absent: DeepRacer's logs live in ../shared beside the repo")
    return measure(LOGS)


@pytest.fixture(scope="module")
def figures(measurement: Measurement) -> dict[str, list]:
    by_group: dict[str, list] = {}
    for c in checks(measurement):
        by_group.setdefault(c.group, []).append(c)
    return by_group


def test_replay_meets_the_targets_overall_fast_and_when_steering_hard(figures: dict[str, list]) -> None:
    """1 s of open-loop replay from every logged pose: median <= 20 cm, p90 <= 45 cm, heading <= 10 deg,
    over all windows, those commanding >= 2.5 m/s and those steering >= 20 deg (issue 10's three bands)."""
    for group in ("overall", "fast_commands", "hard_steering"):
        assert len(figures[group]) == 3
        missed = [f"{c.name}: {c.value}" for c in figures[group] if not c.ok]
        assert not missed, missed


def test_held_turns_and_speeds_match_the_logs(figures: dict[str, list]) -> None:
    """A command held 7 steps: the radius at +-30 deg within 15 % of the log's at 1 and 2 m/s, the speed
    within 5 % at 1, 2 and 4 m/s."""
    names = " ".join(c.name for c in figures["held"])
    for wanted in (
        "1 m/s within 15%",
        "2 m/s within 15%",
        "speed at 1 m/s",
        "speed at 2 m/s",
        "speed at 4 m/s",
    ):
        assert wanted in names
    missed = [f"{c.name}: {c.value}" for c in figures["held"] if not c.ok]
    assert not missed, missed


def test_braking_matches_the_logs(measurement: Measurement, figures: dict[str, list]) -> None:
    """The deceleration after a >= 3.5 m/s command drops to <= 1 m/s: about 4 m/s^2 in simapp 5's logs
    (the console's 1-2 m/s logs never brake from that fast), drx's car within 10 % of it (with the
    braking cap left at its fitting bound the speed lag braked 14 % harder)."""
    assert list(measurement.braking) == ["drfc-4workers"]
    braking = measurement.braking["drfc-4workers"]
    assert braking.samples >= 20
    assert 3.0 < braking.log_deceleration < 5.0
    assert [c.name.split()[1] for c in figures["braking"]] == ["drfc-4workers"]
    missed = [f"{c.name}: {c.value}" for c in figures["braking"] if not c.ok]
    assert not missed, missed


def test_every_log_is_replayed_with_a_car_that_was_not_fitted_to_it(measurement: Measurement) -> None:
    """Issue 25: each shared log of a simulator with more than one log has a car fitted without it
    (``tools/fit_car_model.py``'s leave-one-log-out fits, kept in ``car_calibration.HELD_OUT``), each
    fitted on another set of logs, and its replay is scored against the held-out
    targets (median <= 15 cm, p90 <= 40 cm, fast median <= 25 cm; reported, not all met: the note and
    docs/DYNAMICS.md give the figures). A loose guard keeps a refit from losing the generalisation the
    wheel speed limit brought (the car fitted before it held out 25-29 cm median on simapp 5's logs)."""
    rows = held_out(measurement)
    by_version: dict[str, list[str]] = {}
    for name in measurement.episodes:
        by_version.setdefault(SIMULATOR_OF_SET[name], []).append(name)
    for row in rows:
        if len(by_version[row.simulator]) < 2:
            continue
        assert row.summary is not None, f"{row.log}: no car fitted without it; refit (tools/fit_car_model.py)"
        assert row.summary["overall"]["position_median_cm"] < 26.0, row
        assert row.summary["overall"]["position_p90_cm"] < 56.0, row
    for version, logs in by_version.items():  # each fitted on a different set of logs
        cars = [CarParams.held_out(version, log) for log in logs]
        assert all(cars) and len({repr(c) for c in cars}) == len(logs), version
    names = [c.name for c in held_out_checks(rows)]
    assert all(n.startswith("held out ") for n in names)
    assert len(names) == 3 * len(rows) - 1  # the console's 1-2 m/s log has no fast windows to score
