"""Reward functions: find them, store them by content hash, validate them like the console does.

``--reward`` accepts a path to a ``.py`` file or the name of a sample in the
project's ``rewards/`` folder (``follow_center_line``, ...). The registry keeps
every reward's code in ``reward_sources`` under its sha256, so a model always
knows the exact code it was trained with.
"""

from __future__ import annotations

import math
import statistics
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from drx.config import project_root
from drx.errors import DrxError, NotFoundError, SettingError, not_a_file
from drx.registry import Model, RewardSource, code_sha256, session_scope
from drx.sim.reward_loader import RewardFunction, RewardFunctionError, load_reward_function

if TYPE_CHECKING:
    from drx.sim.track import Track

DEFAULT_REWARD = "follow_center_line"
SLOW_CALL_SECONDS = 1e-3  # a call slower than this slows training down
TIMING_REPEATS = 5  # calls per case; the median is reported


def sample_rewards() -> list[str]:
    """Names of the sample reward functions shipped in the project's ``rewards/`` folder."""
    folder = project_root() / "rewards"
    if not folder.is_dir():
        return []
    return sorted(p.stem for p in folder.glob("*.py") if not p.name.startswith("_"))


def resolve_reward_path(ref: str | Path) -> Path:
    """A reward file: ``ref`` itself when it exists, else the sample ``rewards/<ref>.py``.

    :raises NotFoundError: neither exists; the message lists the samples.
    """
    path = Path(ref).expanduser()
    if path.is_file():
        return path
    sample = project_root() / "rewards" / f"{Path(str(ref)).stem}.py"
    if path.suffix in ("", ".py") and path.parent == Path(".") and sample.is_file():
        return sample
    raise not_a_file(ref, "Reward file", f"give a .py file or a sample: {', '.join(sample_rewards())}")


def load_reward(ref: str | Path) -> RewardFunction:
    """Resolve, read and compile a reward file; it must define ``reward_function(params)``.

    :raises DrxError: the file is missing, has a syntax error, fails on import or lacks the function.
    """
    return load_reward_function(resolve_reward_path(ref))


def compile_reward(code: str, filename: str) -> RewardFunction:
    """Load reward code drx wrote (a recipe's) as if it were the file ``filename``.

    :raises DrxError: the code fails to load (as :func:`load_reward`).
    """
    with tempfile.TemporaryDirectory(prefix="drx-reward-") as folder:
        path = Path(folder) / Path(filename).name
        path.write_text(code, encoding="utf-8")
        return load_reward_function(path)


def store_reward(session: Session, reward: RewardFunction) -> RewardSource:
    """Get or add the ``reward_sources`` row for a loaded reward function (inside ``session``).

    A loaded reward ran here already (the user's own file, or one they trusted), so its row is trusted.
    """
    return store_reward_code(session, reward.source_code or "", Path(reward.source_path or "reward.py").name)


def store_reward_code(session: Session, code: str, filename: str, trusted: bool = True) -> RewardSource:
    """Get or add the ``reward_sources`` row for reward code (inside ``session``) without running it.

    :param trusted: whether drx may run it; storing trusted code marks an untrusted row trusted,
        storing untrusted code leaves a trusted row as it is.
    """
    sha = code_sha256(code)
    row = session.get(RewardSource, sha)
    if row is None:
        row = RewardSource(sha256=sha, code=code, filename=filename, trusted=trusted)
        session.add(row)
        session.flush()
    elif trusted and not row.trusted:
        row.trusted = True
    return row


def check_trusted(session: Session, sha256: str, model_name: str) -> None:
    """Refuse to run a reward that came in an imported package and was never trusted.

    :raises DrxError: the sentence says how to read it and how to trust it.
    """
    row = session.get(RewardSource, sha256)
    if row is not None and not row.trusted:
        raise SettingError(
            "Model {model!r} uses a reward function from an imported package that drx has not run "
            "(sha256 {sha}); read it with `drx reward show {model}`, then train with {field} to run it.",
            "trust_reward",
            model=model_name,
            sha=sha256[:12],
        )


def trust_reward_of(model_name: str) -> None:
    """Mark the reward function of model ``model_name`` as trusted (``drx train --trust-reward``).

    :raises NotFoundError: no such model.
    """
    with session_scope() as session:
        sha = session.scalar(select(Model.reward_sha256).where(Model.name == model_name))
        if sha is None:
            raise NotFoundError(f"Model {model_name!r} does not exist; see `drx model list`.")
        row = session.get(RewardSource, sha)
        if row is not None:
            row.trusted = True


@dataclass(frozen=True)
class StoredReward:
    """A stored reward source and the models that use it."""

    sha256: str
    filename: str
    code: str
    created_at: Any
    models: tuple[str, ...]

    def to_dict(self, with_code: bool = True) -> dict[str, Any]:
        """JSON form."""
        d = {"sha256": self.sha256, "filename": self.filename, "models": list(self.models),
             "created_at": self.created_at}  # fmt: skip
        return {**d, "code": self.code} if with_code else d


def _stored(session: Session, row: RewardSource) -> StoredReward:
    users = session.scalars(select(Model.name).where(Model.reward_sha256 == row.sha256).order_by(Model.name))
    return StoredReward(row.sha256, row.filename, row.code, row.created_at, tuple(users))


def list_stored_rewards() -> list[StoredReward]:
    """Every reward source in the registry (oldest first) with the models using it."""
    with session_scope() as session:
        rows = session.scalars(select(RewardSource).order_by(RewardSource.created_at))
        return [_stored(session, r) for r in rows]


def get_stored_reward(ref: str) -> StoredReward:
    """The reward code a model was made with (``ref`` = model name) or stored under a sha256 prefix.

    :raises DrxError: no such model or hash, or an ambiguous prefix.
    """
    with session_scope() as session:
        sha = session.scalar(select(Model.reward_sha256).where(Model.name == ref))
        if sha is None:
            if len(ref) < 6 or any(c not in "0123456789abcdef" for c in ref.lower()):
                raise NotFoundError(
                    f"No model named {ref!r}; give a model name or 6+ hex digits of a reward's sha256."
                )
            prefix = select(RewardSource.sha256).where(RewardSource.sha256.startswith(ref.lower()))
            matches = list(session.scalars(prefix.limit(2)))
            if not matches:
                raise NotFoundError(f"No stored reward function has a sha256 starting with {ref!r}.")
            if len(matches) > 1:
                raise DrxError(f"sha256 prefix {ref!r} matches several reward functions; give more digits.")
            sha = matches[0]
        return _stored(session, session.get_one(RewardSource, sha))


@dataclass
class CaseResult:
    """One sample call of a reward function."""

    case: str
    value: float | None = None
    error: str | None = None
    line: int | None = None
    seconds: float = 0.0  # median call time
    warning: str | None = None

    @property
    def ok(self) -> bool:
        """Whether the call returned a valid reward."""
        return self.error is None


@dataclass
class ValidationReport:
    """What ``drx reward validate`` found."""

    path: str
    sha256: str
    track: str
    cases: list[CaseResult] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """Whether every case returned a valid reward."""
        return all(c.ok for c in self.cases)

    @property
    def failures(self) -> list[CaseResult]:
        """The failing cases."""
        return [c for c in self.cases if not c.ok]

    def to_dict(self) -> dict[str, Any]:
        """JSON form."""
        return {
            "path": self.path,
            "sha256": self.sha256,
            "track": self.track,
            "ok": self.ok,
            "cases": [
                {
                    "case": c.case,
                    "ok": c.ok,
                    "value": c.value,
                    "error": c.error,
                    "line": c.line,
                    "milliseconds": round(c.seconds * 1e3, 4),
                    "warning": c.warning,
                }
                for c in self.cases
            ],
        }


def validate_reward(ref: str | Path, track: str | None = None) -> ValidationReport:
    """Do what the console's Validate button does: load ``ref``, then :func:`check_reward`.

    :param ref: a reward file or a sample name.
    :param track: the track the sample states lie on (default: drx's default track).
    :raises DrxError: the file cannot be loaded (missing, syntax error, no ``reward_function``)
        or the track is unknown. Failing cases are reported, not raised.
    """
    from drx.services.tracks import DEFAULT_TRACK

    return check_reward(load_reward(ref), track or DEFAULT_TRACK)


def check_reward(reward: RewardFunction, track: str | Track) -> ValidationReport:
    """Call a loaded reward function on sample ``params`` for ``track`` (start line, mid-lap near
    each border, off track, lap complete), as the console's Validate button does.

    A case fails on an exception or a value that is not a finite number within [-1e5, 1e5];
    a call slower than 1 ms gets a warning.

    :param track: a loaded track, or a track's name (route id, display name) or ``.npy`` route.
    :raises DrxError: the track is unknown. Failing cases are reported, not raised.
    """
    from drx.services.tracks import load_track_by_name
    from drx.sim.params import sample_params_cases

    geometry = load_track_by_name(track) if isinstance(track, str) else track
    report = ValidationReport(
        path=str(reward.source_path), sha256=code_sha256(reward.source_code or ""), track=geometry.name
    )
    for case, params in sample_params_cases(geometry).items():
        result = CaseResult(case)
        times = []
        try:
            for _ in range(TIMING_REPEATS):
                t0 = time.perf_counter()
                value = reward(dict(params))
                times.append(time.perf_counter() - t0)
            result.value = value
        except RewardFunctionError as exc:
            result.error, result.line = str(exc), exc.line
        if times:
            result.seconds = statistics.median(times)
            if result.seconds > SLOW_CALL_SECONDS:
                result.warning = (
                    f"a call takes {result.seconds * 1e3:.1f} ms (over 1 ms); it will slow training down"
                )
        if result.value is not None and not math.isfinite(result.value):  # defensive: loader checks
            result.error = f"returned {result.value!r}; return a finite number"
        report.cases.append(result)
    return report


def failure_sentence(report: ValidationReport) -> str:
    """What failed in a report, as the start of one sentence: how many cases, and the first error."""
    first = report.failures[0]
    return (
        f"reward_function failed {len(report.failures)} of {len(report.cases)} sample states on "
        f"{report.track}; first, {first.case}: {(first.error or '').rstrip('.')}"
    )


def require_valid_reward(reward: RewardFunction, track: Track) -> None:
    """Refuse a reward function that fails :func:`check_reward` on ``track`` (``drx model create``).

    :raises DrxError: naming the first failure and the two ways on (fix it, or ``--force``).
    """
    report = check_reward(reward, track)
    if not report.ok:
        raise SettingError(
            "{failure} (`drx reward validate {path} --track {track}` shows every case); fix it, "
            "or give {field} to create the model anyway.",
            "force",
            failure=failure_sentence(report),
            path=reward.source_path,
            track=track.name,
        )
