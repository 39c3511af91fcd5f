"""``towers``: PPO's heads on drx's one shared trunk, or on DeepRacer's two separate towers."""

from __future__ import annotations

import pytest
import torch as th

from drx.errors import SettingError
from drx.settings.hyperparameters import Hyperparameters
from drx.train.checkpoint import checkpoint_path, read_meta
from drx.train.policy_weights import load_policy_weights
from drx.train.trainer import Trainer

from .conftest import SpecFactory, compact_car


def _trunks(policy: th.nn.Module) -> tuple[dict[str, th.Tensor], dict[str, th.Tensor]]:
    """The policy tower's and the value tower's camera-network weights."""
    return policy.pi_features_extractor.state_dict(), policy.vf_features_extractor.state_dict()


def test_separate_towers_train_apart_and_load_back(corridor_spec: SpecFactory) -> None:
    spec = corridor_spec(towers="separate")
    Trainer(spec).run()
    last = checkpoint_path(spec.folder, "last")
    assert read_meta(last)["towers"] == "separate"
    policy = load_policy_weights(last, compact_car(), "ppo")
    assert not policy.share_features_extractor
    pi, vf = _trunks(policy)
    # both started from their own random weights and were trained by different losses
    assert any(not th.equal(pi[k], vf[k]) for k in pi)


def test_a_shared_trunk_is_one_module_under_both_heads(corridor_spec: SpecFactory) -> None:
    spec = corridor_spec()
    Trainer(spec).run()
    last = checkpoint_path(spec.folder, "last")
    assert read_meta(last)["towers"] == "shared"
    policy = load_policy_weights(last, compact_car(), "ppo")
    assert policy.share_features_extractor and policy.pi_features_extractor is policy.vf_features_extractor


def test_towers_is_checked_and_ppo_only() -> None:
    with pytest.raises(SettingError, match="towers two is unknown; use shared or separate"):
        Hyperparameters(towers="two")
    with pytest.raises(SettingError, match="towers does not apply to SAC"):
        Hyperparameters.build("sac", {"towers": "separate"})
    assert "towers" not in Hyperparameters(towers="separate").to_deepracer_json()
