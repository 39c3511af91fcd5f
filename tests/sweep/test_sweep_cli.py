"""``drx sweep create|extend|show|list`` without training: trials, their models and jobs, bad input."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest
from sqlalchemy import inspect

from drx.queue import lifecycle
from drx.registry.engine import get_engine
from drx.services.models import get_model
from drx.sweep.service import sweep_names
from tests.cli.helpers import fails_unchanged, invoke, ok, ok_json

from .conftest import MakeModel

CREATE = ("sweep", "create", "s", "--from", "base", "--trials", "3")
PARAMS = ("--param", "lr=1e-5:1e-3:log", "--param", "batch-size=64,128,256", "--param", "loss=huber,mse")


def test_create_queues_one_cloned_model_and_job_per_trial(make_source: MakeModel) -> None:
    make_source(max_episodes=10)
    data = ok_json(*CREATE, *PARAMS, "--max-minutes-per-trial", "5")
    assert data["direction"] == "maximize" and data["metric"] == "progress"
    trials = data["trials"]
    assert [t["number"] for t in trials] == [0, 1, 2]
    assert len({t["model"] for t in trials}) == 3 and len({t["job"] for t in trials}) == 3
    for t in trials:
        assert t["state"] == "queued" and t["value"] is None
        model = get_model(t["model"])
        hp = model.hyperparameters
        assert hp["learning_rate"] == pytest.approx(t["params"]["lr"])
        assert 1e-5 <= hp["learning_rate"] <= 1e-3
        assert hp["batch_size"] == t["params"]["batch-size"] in (64, 128, 256)
        assert hp["loss_type"] == t["params"]["loss"]
        assert hp["episodes_per_iteration"] == 5  # the rest comes from the source
        assert model.stop_conditions["max_minutes"] == 5 and model.stop_conditions["max_episodes"] == 10
        assert model.parent_name == "base" and model.parent_id is None  # untrained source: from scratch
        job = lifecycle.get_job(t["job"])
        assert job.status == "queued" and job.options == {"sweep": {"study": "s", "trial": t["number"]}}
    assert sweep_names() == ["s"]


def test_show_json_ranks_trials_and_writes_the_png(make_source: MakeModel, tmp_path: Path) -> None:
    make_source()
    ok(*CREATE, "--param", "lr=1e-5:1e-3:log", "--metric", "best-lap")
    png = tmp_path / "s.png"
    data = ok_json("sweep", "show", "s", "--out", png)
    assert data["direction"] == "minimize" and data["best"] is None and data["png"] == str(png)
    assert [sorted(t) for t in data["trials"]][0] == sorted(
        ["number", "state", "model", "params", "value", "iterations", "job", "job_status"]
    )
    assert png.stat().st_size > 10_000 and png.read_bytes()[:4] == b"\x89PNG"
    table = ok("sweep", "show", "s").stdout
    assert "s-0" in table and "queued" in table
    listed = ok_json("sweep", "list")
    assert listed == [
        {"sweep": "s", "source": "base", "metric": "best-lap", "trials": 3, "complete": 0, "pruned": 0}
    ]


def test_extend_adds_distinct_trials(make_source: MakeModel) -> None:
    make_source()
    ok(*CREATE, *PARAMS)
    added = ok_json("sweep", "extend", "s", "--trials", "2")["added"]
    assert added == [{"number": 3, "model": "s-3"}, {"number": 4, "model": "s-4"}]
    trials = ok_json("sweep", "show", "s")["trials"]
    assert sorted(t["model"] for t in trials) == [f"s-{n}" for n in range(5)]
    assert len({t["job"] for t in trials}) == 5


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (("--param", "lr=1e-9:1e-3:log"), ("lr=1e-9:1e-3:log", "outside DeepRacer's range")),
        (("--param", "batch-size=64,100"), ("batch-size=64,100", "outside DeepRacer's range")),
        (("--param", "lr=fast"), ("'fast'", "not a number")),
        (("--param", "lr"), ("malformed",)),
        (("--param", "sac-alpha=0.1:0.2"), ("does not apply to PPO",)),
        (("--param", "lr=1e-5:1e-3", "--metric", "laps"), ("--metric laps", "best-lap")),
        (("--param", "lr=1e-5:1e-3", "--pruner", "hyperband"), ("--pruner hyperband",)),
        (("--param", "lr=1e-5:1e-3", "--max-minutes-per-trial", "0"), ("--max-minutes-per-trial 0",)),
        (("--param", "lr=1e-5:1e-3", "--seed", "-1"), ("--seed -1", "0 to 4294967295")),
    ],
)
def test_bad_input_is_one_sentence_and_stores_nothing(
    make_source: MakeModel, args: tuple[str, ...], words: tuple[str, ...]
) -> None:
    make_source()
    fails_unchanged(*CREATE, *args, contains=words)
    assert "studies" not in inspect(get_engine()).get_table_names()  # not even Optuna's tables


def test_bad_counts_names_and_sources(make_source: MakeModel) -> None:
    make_source()
    fails_unchanged("sweep", "create", "s", "--from", "base", "--trials", "0", *PARAMS, contains="--trials 0")
    fails_unchanged("sweep", "create", "s", "--from", "nope", "--trials", "2", *PARAMS, contains="nope")
    fails_unchanged(
        "sweep",
        "create",
        "bad name",
        "--from",
        "base",
        "--trials",
        "2",
        *PARAMS,
        contains=("Sweep name 'bad name'", "NAME-0"),
    )
    make_source("s-1")  # trial 1's model name is taken: nothing is created
    fails_unchanged(*CREATE, *PARAMS, contains=("'s-1' exists",))
    assert sweep_names() == []
    ok("sweep", "create", "t", "--from", "base", "--trials", "1", *PARAMS)
    fails_unchanged(
        "sweep", "create", "t", "--from", "base", "--trials", "1", *PARAMS, contains="drx sweep extend t"
    )
    fails_unchanged("sweep", "extend", "t", "--trials", "0", contains="--trials 0")
    fails_unchanged("sweep", "extend", "nope", "--trials", "1", contains="No sweep 'nope'")
    fails_unchanged("sweep", "show", "nope", contains="No sweep 'nope'")


def test_missing_param_is_a_usage_error(make_source: MakeModel) -> None:
    make_source()
    assert invoke(*CREATE).exit_code == 2


def test_cli_start_up_loads_no_optuna() -> None:
    code = "import sys, drx.cli.main; print(json.dumps([m for m in ('optuna', 'torch') if m in sys.modules]))"
    out = subprocess.run(
        [sys.executable, "-c", f"import json; {code}"], capture_output=True, text=True, check=True
    ).stdout
    assert json.loads(out) == []


def test_best_lap_without_laps_is_infinite_but_json_says_null() -> None:
    from drx.cli.sweep import _json_row
    from drx.sweep.service import TrialRow

    row = TrialRow(0, "complete", "s-0", {"lr": 1e-4}, math.inf, 2, 1, "succeeded")
    assert _json_row(row)["value"] is None and _json_row(row)["no_complete_lap"] is True


def test_a_seed_repeats_the_draws(make_source: MakeModel) -> None:
    make_source()
    first = ok_json("sweep", "create", "a", "--from", "base", "--trials", "3", *PARAMS, "--seed", "7")[
        "trials"
    ]
    second = ok_json("sweep", "create", "b", "--from", "base", "--trials", "3", *PARAMS, "--seed", "7")[
        "trials"
    ]
    assert [t["params"] for t in first] == [t["params"] for t in second]
    assert len({t["params"]["lr"] for t in first}) == 3
