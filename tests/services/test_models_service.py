"""Model services: what the CLI cannot show directly (checkpoints, jobs, snapshots)."""

from __future__ import annotations

import pytest

from drx.errors import DrxError, SettingError
from drx.registry import Checkpoint, Job, session_scope
from drx.services import garage, models


def test_clone_records_the_parents_best_checkpoint() -> None:
    parent = models.create_model("parent")
    assert models.clone_model("parent", "early").parent_checkpoint_id is None
    with session_scope() as s:
        s.add(Checkpoint(model_id=parent.id, iteration=1, path="1.zip", is_best=True))
        s.add(Checkpoint(model_id=parent.id, iteration=2, path="2.zip", is_best=False))
    with session_scope() as s:
        best = s.query(Checkpoint).filter_by(iteration=1).one()
    clone = models.clone_model("parent", "late")
    assert (clone.parent_id, clone.parent_name, clone.parent_checkpoint_id) == (parent.id, "parent", best.id)


def test_model_keeps_its_car_snapshot_when_the_car_changes() -> None:
    garage.add_vehicle(garage.vehicle_from_options("zoom", max_speed=2))
    models.create_model("m", car="zoom")
    garage.remove_vehicle("zoom")
    garage.add_vehicle(garage.vehicle_from_options("zoom", max_speed=4))
    assert models.get_model("m").vehicle().max_speed == 2


def test_network_override_updates_snapshot_and_hyperparameters() -> None:
    m = models.create_model("m", network="deep")
    assert m.vehicle().network == "deep" and m.hyperparameters["network"] == "deep"


def test_rm_refuses_while_a_job_is_active_and_removes_artifacts() -> None:
    m = models.create_model("busy")
    with session_scope() as s:
        s.add(Job(model_id=m.id, kind="train", status="running"))
    with pytest.raises(DrxError, match="queued or running job"):
        models.remove_model("busy")
    with session_scope() as s:
        s.query(Job).update({"status": "succeeded"})
    folder = models.model_artifacts_dir("busy")
    folder.mkdir(parents=True)
    (folder / "model.zip").write_bytes(b"x")
    models.remove_model("busy")
    assert not folder.exists()
    with session_scope() as s:
        assert s.query(Job).count() == 0


def test_clone_with_another_car_of_the_same_size() -> None:
    models.create_model("p")
    garage.add_vehicle(garage.vehicle_from_options("ten", max_steering=20, max_speed=2))
    assert models.clone_model("p", "c", car="ten").vehicle().max_speed == 2
    garage.add_vehicle(garage.vehicle_from_options("deep10", network="deep"))
    with pytest.raises(DrxError, match="network"):
        models.clone_model("p", "d", car="deep10")


def test_set_status() -> None:
    m = models.create_model("m")
    with session_scope() as s:
        models.set_status(s, m.id, "training")
    assert models.get_model("m").status == "training"
    with pytest.raises(ValueError, match="draft"), session_scope() as s:
        models.set_status(s, m.id, "flying")


def test_the_registry_hands_out_typed_settings_and_stores_the_same_json() -> None:
    m = models.create_model(
        "typed",
        hyperparameters={"learning_rate": 1e-4, "episodes_per_iteration": 5},
        stop_conditions={"max_minutes": 5, "max_steps": None},
        rollout_workers=2,
        domain_randomization=True,
    )
    # the stored JSON keeps its keys (no migration): hyperparameters with network, four stop keys
    assert set(m.hyperparameters) == {
        "algorithm", "batch_size", "num_epochs", "learning_rate", "entropy", "discount_factor",
        "loss_type", "episodes_per_iteration", "sac_alpha", "lr_schedule", "towers", "network",
    }  # fmt: skip
    assert m.stop_conditions == {
        "max_minutes": 5,
        "max_steps": None,
        "max_episodes": None,
        "target_iterations": None,
    }
    hp = m.hyperparameter_settings()
    assert (hp.algorithm, hp.learning_rate, hp.episodes_per_iteration) == ("ppo", 1e-4, 5)
    assert m.stop_settings().to_dict() == m.stop_conditions
    # a training job's overrides win where given (empty values do not)
    stop = m.stop_settings({"max_steps": 100, "max_minutes": None, "target_iterations": 0, "other": 1})
    assert (stop.max_minutes, stop.max_steps, stop.target_iterations) == (5, 100, None)
    rollout = m.rollout_settings()
    assert (rollout.rollout_workers, rollout.domain_randomization) == (2, True)
    assert m.race_config().race_type == "time-trial"
    clone = models.clone_model("typed", "typed-clone", stop_conditions={"max_episodes": 9})
    assert clone.stop_settings().to_dict() == {**m.stop_conditions, "max_episodes": 9}
    assert clone.hyperparameter_settings() == hp and clone.rollout_settings() == rollout


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"rollout_workers": 65}, "rollout_workers"),
        ({"stop_conditions": {"max_minutes": 0}}, "max_minutes"),
        ({"hyperparameters": {"sac_alpha": 0.1}}, "sac_alpha"),
        ({"algorithm": "dqn"}, "algorithm"),
    ],
)
def test_bad_settings_name_the_field_and_store_nothing(kwargs: dict, field: str) -> None:
    with pytest.raises(SettingError) as info:
        models.create_model("bad", **kwargs)
    assert info.value.field == field and str(info.value).startswith(field)
    assert models.list_models() == []


@pytest.mark.parametrize("check_reward", [False, True])
def test_create_and_clone_resolve_their_track_once(
    monkeypatch: pytest.MonkeyPatch, check_reward: bool
) -> None:
    """A track typed by its display name is resolved once and loaded at most once (to check the
    reward), and the model stores its route id."""
    from drx.services import tracks
    from drx.sim import track as sim_track

    resolved: list[str] = []
    loaded: list[str] = []
    real_resolve, real_load = tracks.resolve, sim_track.load_track
    monkeypatch.setattr(  # resolve(name, entries, direction): the direction picks a two-way track's route
        tracks,
        "resolve",
        lambda name, entries, direction=None: resolved.append(name) or real_resolve(name, entries, direction),
    )
    monkeypatch.setattr(sim_track, "load_track", lambda p: loaded.append(str(p)) or real_load(p))
    m = models.create_model("m", track="A to Z Speedway (clockwise)", check_reward=check_reward)
    assert m.track_name == "reInvent2019_wide_cw"
    assert resolved == ["A to Z Speedway (clockwise)"] and len(loaded) == int(check_reward)
    resolved.clear()
    loaded.clear()
    clone = models.clone_model(
        "m", "c", track="Smile Speedway", reward="follow_center_line", check_reward=check_reward
    )
    assert clone.track_name == "reInvent2019_track"
    assert resolved == ["Smile Speedway"] and len(loaded) == int(check_reward)
