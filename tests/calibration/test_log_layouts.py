"""One reader for every layout of DeepRacer's step traces (drx.calibration.logs) and the metadata
beside them (drx.calibration.log_metadata: simulator version, action space): every shared log, each layout
as a small inline log, and ``drx sim replay`` on the console's 2025 runs and the 2023 september-pro
logs."""

from __future__ import annotations

import csv
import functools
import io
import json
import re
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from drx.calibration.log_metadata import (
    LogActionSpace,
    action_space_of_log,
    action_spaces_of_logs,
    sagemaker_log_of,
    simulator_of_log,
)
from drx.calibration.logs import (
    BASE_COLUMNS,
    ROW_LAYOUTS,
    TRACE_PREFIX,
    read_trace,
    read_trace_file,
)
from drx.calibration.replay import windows
from drx.cli.main import app
from drx.errors import DrxError
from drx.sim.episode_status import EpisodeStatus
from tests.calibration._logs import SHARED_LOGS, need

CONSOLE_2025 = SHARED_LOGS / "console-2025-10-continuous"
SEPTEMBER_PRO = SHARED_LOGS / "drfc-2023-09-september-pro"
# SOURCE.txt of console-2025-10-continuous: each run's continuous ranges (steering deg, speed m/s).
RUNS_2025 = {
    "deepModel-clone": ((-30.0, 30.0), (1.3, 4.0)),
    "vitor": ((-20.0, 30.0), (1.3, 4.0)),
    "deepModel-clone3-clone": ((-15.0, 30.0), (1.3, 3.5)),
    "reinvencementModel": ((-30.0, 30.0), (1.0, 4.0)),
}
TOLERANCE = 0.006  # [m/s], [deg]: the logs print steering and speed to 2 decimals
_NOT_TRACES = {".json", ".py", ".yaml", ".md"}


def _trace_files() -> list[Path]:
    """Every trace file under the shared logs, found anew each run (a log added later is covered):
    robomaker logs (``.log``, or saved as ``.txt``), sim-trace CSVs, and any other file whose lines
    are ``SIM_TRACE_LOG`` steps or whose first line is a sim-trace header."""
    if not SHARED_LOGS.is_dir():
        return []
    out = []
    for path in sorted(SHARED_LOGS.rglob("*")):
        if not path.is_file() or path.suffix in _NOT_TRACES or "sagemaker" in path.name:
            continue
        named = ("robomaker" in path.name and path.suffix in (".log", ".txt")) or path.name.endswith(
            "-iteration.csv"
        )
        if named or _holds_trace(path):
            out.append(path)
    return out


def _holds_trace(path: Path) -> bool:
    with path.open("rb") as f:
        head = f.read(1 << 20)
    return TRACE_PREFIX.encode() in head or b"episode_status" in head.split(b"\n", 1)[0]


def _expected_rows(path: Path) -> int:
    """Rows counted the plain way: lines holding ``SIM_TRACE_LOG:``, else a CSV's non-empty lines
    after its header."""
    lines = path.read_text(encoding="utf-8", errors="replace").split("\n")
    steps = sum(TRACE_PREFIX in line for line in lines)
    return steps if steps else sum(bool(line.strip()) for line in lines) - 1


TRACE_FILES = _trace_files()
_read = functools.cache(read_trace_file)  # each shared log read once for the tests below


@pytest.mark.parametrize(
    "path", TRACE_FILES or [None], ids=[str(p.relative_to(SHARED_LOGS)) for p in TRACE_FILES] or ["absent"]
)
def test_every_shared_log_reads_whole(path: Path | None) -> None:
    """Every row of every shared log reads (none malformed, none dropped), with sane values: finite
    poses, commands and clock, steps rising within each episode, DeepRacer's status words, in-progress
    driving, and (where the log's metadata names the action space) commands the space holds."""
    if path is None:
        need(SHARED_LOGS)
        pytest.fail(f"no trace files under {SHARED_LOGS}")
    trace = _read(path)
    assert trace.malformed == (), trace.malformed_note()
    assert trace.rows == _expected_rows(Path(trace.path)) == sum(len(e) for e in trace.episodes)
    assert set(trace.field_counts) <= (
        set(ROW_LAYOUTS) if trace.layout == "robomaker" else {len(trace.columns)}
    )
    words = {s.value for s in EpisodeStatus}
    driving = 0
    for ep in trace.episodes:
        for values in (ep.x, ep.y, ep.yaw, ep.steer, ep.throttle, ep.tstamp, ep.steps):
            assert np.all(np.isfinite(values)) and len(values) == len(ep)
        assert np.all(np.diff(ep.steps) > 0), f"episode {ep.episode}: steps {ep.steps[:5]}..."
        assert set(ep.status) <= words
        driving += int(ep.driving.sum())
    assert driving > 0
    space = action_space_of_log(trace.path)
    if space is not None:
        throttle = np.concatenate([e.throttle for e in trace.episodes])
        steer = np.concatenate([e.steer for e in trace.episodes])
        assert all(space.allows_speed(float(v)) for v in throttle), space.describe()
        if space.kind == "continuous":
            assert np.all((steer >= space.steering[0] - TOLERANCE) & (steer <= space.steering[1] + TOLERANCE))
        else:
            actions = np.array(space.actions)
            near = (np.abs(steer[:, None] - actions[None, :, 0]) <= TOLERANCE) & (
                np.abs(throttle[:, None] - actions[None, :, 1]) <= TOLERANCE
            )
            assert near.any(axis=1).all(), "a logged command that is none of the actions"


def test_the_shared_logs_hold_every_layout_drx_expects() -> None:
    """The walk above covers what the README lists: 17 and 18 fields a line (no shared log has 16 or 19:
    the inline tests below cover those), CSVs, the 2025 console's ``.txt`` log, each 2025 run's action
    space, and the metadata of most of the logs."""
    need(SHARED_LOGS)
    traces = {p: _read(p) for p in TRACE_FILES}
    counts = {n for t in traces.values() if t.layout == "robomaker" for n in t.field_counts}
    assert {17, 18} <= counts
    assert any(p.suffix == ".txt" for p in traces) and any(t.layout == "csv" for t in traces.values())
    for run, (steering, speed) in RUNS_2025.items():
        (log,) = [p for p in traces if p.parent.name == run]
        assert traces[log].field_counts == {18: traces[log].rows}
        space = action_space_of_log(log)
        assert space is not None and (space.kind, space.steering, space.speed) == (
            "continuous",
            steering,
            speed,
        )
    known = [s for s in action_spaces_of_logs(list(traces)) if s is not None]
    assert len(known) >= 40


# --- each layout, inline -----------------------------------------------------------------------


def _rows(
    fields: int, action: str, statuses: tuple[str, ...] = ("prepare", "in_progress", "in_progress")
) -> str:
    """``SIM_TRACE_LOG`` lines of one episode with ``fields`` fields (16-19) and ``action`` as written."""
    extra = ["0.00", "0", "1761939000.1234"][: fields - 16]
    lines = []
    for i, status in enumerate(statuses):
        row = [
            "3", str(i + 1), f"{1.0 + 0.1 * i:.4f}", "2.0000", "90.0000", "-20.00", "3.62", action,
            "1.0000", "False", "True", f"{0.5 * i:.4f}", "1", "17.71", f"{6.2 + i / 15:.3f}", status, *extra,
        ]  # fmt: skip
        lines.append(TRACE_PREFIX + ",".join(row))
    return "\n".join(
        ["start-up noise, with commas, and [brackets]", *lines, "ERROR - Going directly off track"]
    )


@pytest.mark.parametrize("fields", [16, 17, 18, 19])
@pytest.mark.parametrize("action", ["7", "[-20.0, 3.6195427934404245]", "[-20.0 3.6195427934404245]"])
def test_a_robomaker_line_is_named_by_its_count_of_fields(tmp_path: Path, fields: int, action: str) -> None:
    log = tmp_path / "robomaker.log"
    log.write_text(_rows(fields, action))
    trace = read_trace_file(log)
    assert (trace.layout, trace.rows, trace.malformed, trace.field_counts) == (
        "robomaker",
        3,
        (),
        {fields: 3},
    )
    assert trace.columns == ROW_LAYOUTS[fields] and trace.columns[:16] == BASE_COLUMNS
    (ep,) = trace.episodes
    assert ep.episode == 3 and ep.steps.tolist() == [1.0, 2.0, 3.0]
    assert ep.steer.tolist() == [-20.0] * 3 and ep.throttle.tolist() == [3.62] * 3
    assert ep.x.tolist() == pytest.approx([1.0, 1.1, 1.2]) and ep.progress.tolist() == [0.0, 0.5, 1.0]
    assert ep.tstamp.tolist() == pytest.approx([6.2, 6.2 + 1 / 15, 6.2 + 2 / 15], abs=1e-3)
    assert ep.yaw[0] == pytest.approx(np.pi / 2) and ep.status == ("prepare", "in_progress", "in_progress")


def test_every_status_row_is_kept_with_its_status(tmp_path: Path) -> None:
    statuses = ("prepare", "in_progress", "pause", "pause", "in_progress", "crashed", "immobilized", "park")
    log = tmp_path / "robomaker.log"
    log.write_text(_rows(18, "[-20.0 3.62]", statuses))
    (ep,) = read_trace(log)
    assert ep.status == statuses
    assert ep.driving.tolist() == [s == "in_progress" for s in statuses]


def test_a_csv_header_locates_the_columns_in_any_order(tmp_path: Path) -> None:
    """Columns shuffled, an unknown one added, deepracer-utils' names, an unquoted ``[a, b]`` action."""
    columns = ["tstamp", "episode_status", "x", "y", "action", "heading_extra", "episode", "steps", "yaw",
               "steering_angle", "speed", "progress", "reward"]  # fmt: skip
    rows = [
        "20.31,prepare,3.2,0.68,[23.44, 0.5],a,0,1.0,0.18,23.44,0.5,0.79,0",
        "20.38,in_progress,3.3,0.69,[-5.17, 2.72],b,0,2.0,0.19,-5.17,2.72,0.8,1",
        "20.45,lap_complete,3.4,0.70,[1.0, 1.5],c,0,3.0,0.2,1.0,1.5,100.0,2",
    ]
    path = tmp_path / "0-iteration.csv"
    path.write_text("\r\n".join([",".join(columns), *rows]) + "\r\n\r\n")
    trace = read_trace_file(path)
    assert (trace.layout, trace.rows, trace.malformed) == ("csv", 3, ())
    assert trace.columns[:4] == ("tstamp", "episode_status", "X", "Y")  # deepracer-utils' x, y: DeepRacer's
    (ep,) = trace.episodes
    assert ep.tstamp.tolist() == [20.31, 20.38, 20.45] and ep.x.tolist() == [3.2, 3.3, 3.4]
    assert ep.steer.tolist() == [23.44, -5.17, 1.0] and ep.throttle.tolist() == [0.5, 2.72, 1.5]
    assert ep.progress.tolist() == [0.79, 0.8, 100.0] and ep.steps.tolist() == [1.0, 2.0, 3.0]
    assert ep.status == ("prepare", "in_progress", "lap_complete")


def test_a_csv_quoted_by_a_csv_writer_reads(tmp_path: Path) -> None:
    """drx's own traces (``drx.train.trace``) quote the continuous action, as ``csv.writer`` does."""
    out = io.StringIO()
    writer = csv.writer(out)
    writer.writerow(ROW_LAYOUTS[18])
    for i in range(3):
        writer.writerow([0, i + 1, 1.0 + i, 2.0, 0.0, 10.0, 1.5, "[10, 1.5]", 1.0, False, True, i, 1, 17.7,
                         5.0 + i / 15, "in_progress", 0.0, 0])  # fmt: skip
    path = tmp_path / "1-iteration.csv"
    path.write_text(out.getvalue())
    (ep,) = read_trace(path)
    assert ep.x.tolist() == [1.0, 2.0, 3.0] and ep.throttle.tolist() == [1.5] * 3


def test_a_header_less_csv_is_named_by_its_count_of_fields(tmp_path: Path) -> None:
    path = tmp_path / "rows.csv"
    path.write_text(_rows(17, "[-20.0, 3.62]").replace(TRACE_PREFIX, "").split("\n", 1)[1].rsplit("\n", 1)[0])
    trace = read_trace_file(path)
    assert (trace.layout, trace.rows, trace.field_counts) == ("robomaker", 3, {17: 3})


def test_prefixed_lines_and_returning_episode_numbers(tmp_path: Path) -> None:
    """A log exported with a time before each line still reads; an episode number that comes back
    later, or steps that start again (a restarted job), start another episode rather than joining."""
    first, other = (
        _rows(18, "[1.0 2.0]"),
        _rows(18, "[1.0 2.0]").replace(f"{TRACE_PREFIX}3,", f"{TRACE_PREFIX}4,"),
    )
    text = "\n".join(
        f"2025-10-31T19:33:52.000Z {line}" for line in f"{first}\n{first}\n{other}\n{first}".split("\n")
    )
    log = tmp_path / "robomaker.log"
    log.write_text(text)
    episodes = read_trace(log)
    assert [(e.episode, len(e)) for e in episodes] == [(3, 3), (3, 3), (4, 3), (3, 3)]
    assert all(e.steps.tolist() == [1.0, 2.0, 3.0] for e in episodes)


def test_malformed_rows_are_counted_and_named_never_dropped_silently(tmp_path: Path) -> None:
    lines = _rows(18, "[-20.0 3.62]").split("\n")
    lines.insert(2, TRACE_PREFIX + "0,2,1.0,2.0")  # cut short
    lines.insert(3, lines[1].replace("1.0000,2.0000", "nan,2.0000"))  # not finite
    lines.insert(4, lines[1].replace(",1.0000,2.0000,", ",abc,2.0000,"))  # X not a number
    lines.insert(5, lines[1].replace("prepare", "12.5"))  # no status word
    log = tmp_path / "robomaker.log"
    log.write_text("\n".join(lines))
    trace = read_trace_file(log)
    assert trace.rows == 3 and [m.line for m in trace.malformed] == [3, 4, 5, 6]
    assert trace.malformed[0].reason == "4 fields, not 16 to 19"
    assert trace.malformed[1].reason == "X is nan, not a finite number"
    assert trace.malformed[2].reason == "X 'abc' is not a number"
    assert trace.malformed[3].reason == "episode_status '12.5' is not a status word"
    note = trace.malformed_note()
    assert note is not None and note.startswith(
        f"4 of the 7 trace rows of {log} do not read and were skipped"
    )
    assert "line 3: 4 fields" in note and "1 more" in note
    # a row with a field count the CSV's header does not have is malformed too
    path = tmp_path / "0-iteration.csv"
    path.write_text(",".join(ROW_LAYOUTS[17]) + "\n" + "0,1,2\n")
    words = r"none of the 1 trace rows of .* reads as a DeepRacer sim-trace row \(line 2: 3 fields, not 17\)"
    with pytest.raises(DrxError, match=words + r"; give the log as DeepRacer wrote it\.$"):
        read_trace(path)


def test_a_header_without_the_columns_read_is_refused_naming_them(tmp_path: Path) -> None:
    path = tmp_path / "0-iteration.csv"
    path.write_text("episode,steps,X,Y,heading,steer,speed_command,progress,tstamp,episode_status\n")
    with pytest.raises(DrxError, match=r"the header of .* lacks the columns yaw, throttle; give a DeepRacer "
                       r"sim-trace CSV, whose header names episode, steps, X, Y, yaw"):  # fmt: skip
        read_trace(path)


def test_reading_is_fast(tmp_path: Path) -> None:
    """21,700 steps, the longest shared log, read in well under a second (about 0.1 s)."""
    import time

    log = tmp_path / "robomaker.log"
    statuses = tuple("in_progress" for _ in range(100))
    log.write_text("\n".join(_rows(18, "[-20.0 3.6195427934404245]", statuses) for _ in range(217)))
    start = time.perf_counter()
    trace = read_trace_file(log)
    assert trace.rows == 21_700 and time.perf_counter() - start < 1.0


# --- the metadata beside a log ------------------------------------------------------------------


def _console_pair(folder: Path, job: str = "k8lvx-yPSy-6ZpPsayBIow") -> tuple[Path, Path]:
    """The console's robomaker log (its steps only) and the job's sagemaker log, a second apart."""
    folder.mkdir(parents=True, exist_ok=True)
    robomaker = folder / f"training-20251031193352-{job}-robomaker.log"
    robomaker.write_text(_rows(18, "[-20.0 3.62]"))
    sagemaker = folder / f"training-20251031193351-{job}-sagemaker.log"
    sagemaker.write_text(
        "Sensor list ['FRONT_FACING_CAMERA'], network DEEP_CONVOLUTIONAL_NETWORK_SHALLOW, "
        "simapp_version 5.0, training_algorithm clipped_ppo, action_space_type continuous\n"
        "Action space from file: "
        "{'steering_angle': {'high': 30, 'low': -20}, 'speed': {'high': 4, 'low': 1.3}}\n"
    )
    return robomaker, sagemaker


def test_the_sagemaker_log_of_the_same_job_is_found_by_its_id(tmp_path: Path) -> None:
    robomaker, sagemaker = _console_pair(tmp_path)
    assert sagemaker_log_of(robomaker) == sagemaker
    later = (
        tmp_path / "training-20251031203351-k8lvx-yPSy-6ZpPsayBIow-sagemaker.log"
    )  # the same job, an hour on
    later.write_text("")
    assert sagemaker_log_of(robomaker) == sagemaker  # the one started nearest
    other = tmp_path / "other"
    other.mkdir()
    (other / robomaker.name).write_text("")
    (other / "training-20251031193351-0miDyq4OS4Suo24dz9BQAA-sagemaker.log").write_text("")  # another job's
    assert sagemaker_log_of(other / robomaker.name) is None
    txt = tmp_path / "txt"
    txt.mkdir()
    (txt / robomaker.name.replace(".log", ".txt")).write_text("")
    (txt / sagemaker.name.replace(".log", ".txt")).write_text("")
    assert sagemaker_log_of(txt / robomaker.name.replace(".log", ".txt")) == txt / sagemaker.name.replace(
        ".log", ".txt"
    )
    assert sagemaker_log_of(tmp_path / "deepracer-0_robomaker.1.abc.log") is None
    assert sagemaker_log_of(sagemaker) is None


def test_the_sagemaker_log_gives_the_action_space_and_simulator(tmp_path: Path) -> None:
    robomaker, sagemaker = _console_pair(tmp_path)
    space = action_space_of_log(robomaker)
    assert space == LogActionSpace("continuous", (-20.0, 30.0), (1.3, 4.0), (), "sagemaker", sagemaker)
    assert space.describe() == "continuous, steering -20 to 30 deg, speed 1.3 to 4 m/s"
    assert space.source.startswith("Action space from file in ") and space.source.endswith(sagemaker.name)
    assert space.allows_speed(1.3) and space.allows_speed(4.0) and not space.allows_speed(4.1)
    found = simulator_of_log(robomaker)
    assert (found.version, found.logged, found.kind, found.where) == ("5", "5.0", "sagemaker", sagemaker)
    assert found.reason == f"simapp_version 5.0 in {sagemaker.name}"
    # the robomaker log's own lines come first
    robomaker.write_text("simapp_version 4.0\nAction space from file: [{'steering_angle': 0, 'speed': 1}]\n")
    assert simulator_of_log(robomaker).kind == "robomaker" and simulator_of_log(robomaker).version == "4"
    own = action_space_of_log(robomaker)
    assert own is not None and own.found_in == "robomaker" and own.actions == ((0.0, 1.0),)


def test_action_space_from_meta_json_and_model_metadata(tmp_path: Path) -> None:
    log = tmp_path / "a" / "deepracer-0_robomaker.1.x.log"
    log.parent.mkdir()
    log.write_text(_rows(17, "3"))
    assert action_space_of_log(log) is None and action_space_of_log(tmp_path / "missing.log") is None
    metadata = tmp_path / "model" / "model_metadata.json"
    metadata.parent.mkdir()
    metadata.write_text(json.dumps({"action_space": {"steering_angle": {"low": -30, "high": 30},
                                                     "speed": {"low": 1.25, "high": 4}},
                                    "action_space_type": "continuous", "version": "5"}))  # fmt: skip
    space = action_space_of_log(log)
    assert space is not None and (space.kind, space.speed, space.found_in) == (
        "continuous",
        (1.25, 4.0),
        "model_metadata",
    )
    meta = log.with_name(log.name + ".meta.json")
    actions = [{"speed": 4.0, "steering_angle": 0}, {"speed": 1.0, "steering_angle": 30}]
    meta.write_text(json.dumps({"action_space": {"type": "DISCRETE", "min_speed": 1.0, "max_speed": 4.0,
                                                 "actions": actions}}))  # fmt: skip
    space = action_space_of_log(log)
    assert space is not None and space.found_in == "meta.json" and space.actions == ((0.0, 4.0), (30.0, 1.0))
    assert space.describe() == "discrete, 2 actions: steering 0 to 30 deg, speeds 1, 4 m/s"
    assert space.allows_speed(1.0) and not space.allows_speed(2.0)
    meta.write_text("{not json")
    assert action_space_of_log(log) is not None  # passed over: model_metadata.json still says


@pytest.mark.parametrize("run", sorted(RUNS_2025))
def test_the_2025_sagemaker_logs_name_each_runs_action_space(tmp_path: Path, run: str) -> None:
    """Each 2025 sagemaker log's ``Action space from file`` (read through a robomaker log that says
    nothing itself, beside a link to the real sagemaker log) gives the run's ranges (SOURCE.txt)."""
    (sagemaker,) = need(CONSOLE_2025 / run).glob("*-sagemaker.*")
    name = re.sub(r"-(\d{14})-", lambda m: f"-{int(m.group(1)) + 1}-", sagemaker.name)
    robomaker = tmp_path / name.replace("-sagemaker.", "-robomaker.")
    robomaker.write_text(_rows(18, "[1.0 2.0]"))
    (tmp_path / sagemaker.name).symlink_to(sagemaker)
    space = action_space_of_log(robomaker)
    steering, speed = RUNS_2025[run]
    assert space is not None and (space.kind, space.steering, space.speed) == ("continuous", steering, speed)
    assert space.found_in == "sagemaker" and simulator_of_log(robomaker).logged == "5.0"


# --- drx sim replay on the logs that failed ----------------------------------------------------


def test_every_2025_run_has_stretches_to_replay() -> None:
    """What ``drx sim replay`` said none of the four 2025 runs had: 15 steps in progress."""
    for run in RUNS_2025:
        (log,) = need(CONSOLE_2025 / run).glob("*-robomaker.*")
        assert len(windows(read_trace(log), 15, stride=50)) > 20, run


@pytest.mark.parametrize("run", ["vitor", "reinvencementModel", "september-pro"])
def test_cli_replays_the_2025_and_september_pro_logs(run: str) -> None:
    logs = (
        sorted(need(SEPTEMBER_PRO).glob("*_robomaker.*.log"))
        if run == "september-pro"
        else list(need(CONSOLE_2025 / run).glob("*-robomaker.*"))
    )
    result = CliRunner().invoke(app, ["sim", "replay", *map(str, logs), "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert data["overall"]["windows"] > 500 and data["simulator"] == "5" and data["malformed_rows"] == {}
    (space,) = data["action_spaces"]
    assert space["kind"] == "continuous" and space["logs"] == len(logs)
    if run == "september-pro":
        assert (space["steering_deg"], space["speed_mps"]) == ([-30.0, 30.0], [1.25, 4.0])
    else:
        assert (tuple(space["steering_deg"]), tuple(space["speed_mps"])) == RUNS_2025[run]


def test_cli_prints_the_action_space_and_refuses_a_log_that_does_not_read(tmp_path: Path) -> None:
    robomaker, sagemaker = _console_pair(tmp_path)
    robomaker.write_text(_rows(18, "[-20.0 3.62]", ("in_progress",) * 40) + f"\n{TRACE_PREFIX}3,41,1.0\n")
    result = CliRunner().invoke(app, ["sim", "replay", str(robomaker)])
    assert result.exit_code == 0, result.output
    note = (
        f"Note: 1 of the 41 trace rows of {robomaker} does not read and was skipped (line 43: 3 fields, not"
    )
    assert note in result.stdout
    assert (
        "Action space: continuous, steering -20 to 30 deg, speed 1.3 to 4 m/s (Action space from"
        in result.stdout
    )
    bad = tmp_path / "0-iteration.csv"
    bad.write_text("episode,steps,X,Y\n0,1,2,3\n")
    result = CliRunner().invoke(app, ["sim", "replay", str(bad)])
    assert (
        result.exit_code == 2 and "lacks the columns yaw, steer, throttle, progress, tstamp" in result.stderr
    )
    assert "Traceback" not in result.output
