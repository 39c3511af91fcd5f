"""Load a user's DeepRacer reward function and call it safely.

A reward file is plain DeepRacer Python: it defines ``reward_function(params)``
returning a number. Errors (syntax, import-time, call-time, bad return value)
become :class:`RewardFunctionError`, naming the user's file and line, so the
CLI can print one sentence and the env can end the episode cleanly.

Every call and the file's top-level code run under :mod:`drx.sim.reward_guard`: a time
limit, ``print`` to a capped standard error, ``os._exit`` / ``sys.exit`` reported as
errors, and the call's own copy of ``params``. drx's own interruptions
(:class:`drx.errors.Interruption`: a worker's shutdown, a stop request) pass through.
"""

from __future__ import annotations

import difflib
import hashlib
import inspect
import math
import sys
import traceback
import types
from _thread import get_ident
from collections.abc import Callable
from pathlib import Path
from time import perf_counter
from typing import Any

from drx.errors import DrxError, Interruption, not_a_file
from drx.sim import reward_guard as guard
from drx.sim.reward_guard import RewardExit, RewardTimeout

REWARD_LIMIT = 1e5  # DeepRacer: a reward must lie within [-1e5, 1e5]
FUNCTION_NAME = "reward_function"


class RewardFunctionError(DrxError):
    """The user's reward function failed; says file, line and the failing ``params``.

    :param message: the sentence to show.
    :param path: the reward file (or ``None`` for an in-memory callable without a file).
    :param line: the line in that file, when known.
    :param params: the ``params`` dict of the failing call, when it failed in a call.
    """

    def __init__(
        self, message: str, path: str | None = None, line: int | None = None, params: dict | None = None
    ) -> None:
        super().__init__(message)
        self.path, self.line, self.params = path, line, params


class RewardFunction:
    """A loaded reward function: call it with ``params``, get a float.

    :param func: the user's ``reward_function``.
    :param source_path: the file it came from, if any.
    :param source_code: its source text, if known.
    :param time_limit: seconds a call may take (default :func:`drx.sim.reward_guard.time_limit`).
    """

    def __init__(
        self,
        func: Callable[[dict], Any],
        source_path: str | None,
        source_code: str | None,
        time_limit: float | None = None,
    ) -> None:
        self.func = func
        self.source_path = source_path
        self.source_code = source_code
        self.time_limit = float(time_limit) if time_limit is not None else guard.time_limit()
        self.calls = 0
        self.seconds = 0.0  # total time spent inside the user's function [s]
        self._own = guard.ParamsCopier().copy

    @property
    def sha256(self) -> str | None:
        """Hash of the source text (the registry keys rewards by content)."""
        return hashlib.sha256(self.source_code.encode()).hexdigest() if self.source_code is not None else None

    @property
    def name(self) -> str:
        """A short label: the file name or the function's name."""
        return Path(self.source_path).name if self.source_path else getattr(self.func, "__name__", "reward")

    def __call__(self, params: dict[str, Any]) -> float:
        """Run the function on its own copy of ``params``, under the time limit.

        :raises RewardFunctionError: when it raises, runs past the time limit, exits, or returns
            something other than a finite number within [-1e5, 1e5].
        :raises drx.errors.Interruption: drx interrupted the call (shutdown, stop request).
        """
        own = self._own(params)
        w = guard._watch  # the fast path of guard.guarded_call, inlined: this runs every step
        if not w.pid:
            guard.ensure_watchdog()
        w.limit = self.time_limit
        w.thread = get_ident()
        w.started = t0 = perf_counter()
        try:
            value = self.func(own)
        except BaseException as exc:  # noqa: BLE001 - SystemExit and the guard's exceptions included
            # first, before any call: the watchdog's next interruption must not land in the handling
            w.started = 0.0
            if isinstance(exc, (Interruption, KeyboardInterrupt)):
                raise
            raise self._call_error(exc, params) from exc
        finally:
            w.started = 0.0
            self.seconds += perf_counter() - t0
            self.calls += 1
        if type(value) is float and -REWARD_LIMIT <= value <= REWARD_LIMIT:
            return value  # the common case, without the slower checks below
        try:
            reward = float(value)
        except (TypeError, ValueError):
            reward = math.nan
        if isinstance(value, bool) or not math.isfinite(reward) or abs(reward) > REWARD_LIMIT:
            line = self._return_line(params, value)
            raise RewardFunctionError(
                f"{self._where(line)}: reward_function returned {value!r}; "
                f"return a finite number within [-{REWARD_LIMIT:g}, {REWARD_LIMIT:g}].",
                self.source_path, line, params,
            )  # fmt: skip
        return reward

    def _return_line(self, params: dict[str, Any], value: Any) -> int | None:
        """The line of the ``return`` that gave the bad ``value``, else the ``def`` line.

        Only on this error path: the call runs once more, on a fresh copy of ``params``, with a
        profile hook noting where the function's own frame returns; the line counts when that
        call returns the same kind of value (a reward keeping state across calls might not).
        """
        code = getattr(self.func, "__code__", None)
        if code is None:
            return None
        lines: list[int] = []

        def hook(frame: types.FrameType, event: str, arg: Any) -> None:
            if event == "return" and frame.f_code is code:
                lines.append(frame.f_lineno)

        previous = sys.getprofile()
        again: Any = _NOTHING
        try:
            with guard.guarded_call(self.time_limit):
                sys.setprofile(hook)
                try:
                    again = self.func(self._own(params))
                finally:
                    sys.setprofile(previous)
        except (Interruption, KeyboardInterrupt):
            raise
        except BaseException:  # noqa: BLE001 - the first call's error is the one to report
            pass
        same = again is not _NOTHING and type(again) is type(value) and repr(again) == repr(value)
        return lines[-1] if same and lines else code.co_firstlineno

    def _call_error(self, exc: BaseException, params: dict[str, Any]) -> RewardFunctionError:
        guard._watch.pending = None  # the guard's exception, if it was one, is spent
        line = _user_line(exc.__traceback__, self.source_path)
        where = self._where(line)
        if isinstance(exc, RewardTimeout):
            text = (
                f"{where}: reward_function ran longer than {self.time_limit:g} s (the time limit); make it "
                f"faster, or raise the limit with {guard.ENV_TIME_LIMIT}=SECONDS."
            )
        elif isinstance(exc, RewardExit):
            text = f"{where}: reward_function called {exc.call}; a reward function must return a number."
        elif isinstance(exc, SystemExit):
            text = (
                f"{where}: reward_function called sys.exit({exc.code!r}); "
                "a reward function must return a number."
            )
        else:
            text = f"{where}: reward_function raised {type(exc).__name__}: {exc}{_key_hint(exc, params)}"
        return RewardFunctionError(text, self.source_path, line, params)

    def _where(self, line: int | None) -> str:
        where = self.source_path or f"<{self.name}>"
        return f"{where}, line {line}" if line else where


def load_reward_function(
    source: str | Path | Callable[[dict], Any] | RewardFunction, time_limit: float | None = None
) -> RewardFunction:
    """Load ``reward_function(params)`` from a Python file, or wrap a callable.

    The file's top-level code runs (under :data:`drx.sim.reward_guard.LOAD_TIME_LIMIT`, with
    ``print`` and ``os._exit`` guarded): load only the user's own files or trusted ones.

    :param source: a path to a ``.py`` file, a callable, or an already loaded :class:`RewardFunction`.
    :param time_limit: seconds a call may take (default: ``$DRX_REWARD_TIME_LIMIT`` or 1 s).
    :raises RewardFunctionError: when the file is missing, does not compile, fails at import, or
        has no callable ``reward_function``.
    """
    if isinstance(source, RewardFunction):
        return source
    if callable(source) and not isinstance(source, (str, Path)):
        path = _source_file(source)
        try:
            code = inspect.getsource(source)
        except (OSError, TypeError):
            code = None
        return RewardFunction(source, path, code, time_limit)
    file = Path(source).expanduser()
    if not file.is_file():
        raise RewardFunctionError(str(not_a_file(file, "Reward file", "give a .py file")), str(file))
    text = file.read_text(encoding="utf-8")
    filename = str(file.resolve())
    try:
        code_obj = compile(text, filename, "exec")
    except SyntaxError as exc:
        raise RewardFunctionError(
            f"{filename}, line {exc.lineno}: syntax error: {exc.msg}.", filename, exc.lineno
        ) from None
    module = types.ModuleType(f"drx_reward_{hashlib.sha1(filename.encode()).hexdigest()[:8]}")
    module.__file__ = filename
    module.__dict__["__builtins__"] = guard.reward_builtins()
    try:
        with guard.guarded_call(guard.LOAD_TIME_LIMIT):
            exec(code_obj, module.__dict__)
    except (Interruption, KeyboardInterrupt):
        raise
    except BaseException as exc:  # noqa: BLE001 - SystemExit and the guard's exceptions included
        line = _user_line(exc.__traceback__, filename)
        raise RewardFunctionError(
            f"{filename}, line {line}: loading the file {_load_failure(exc)}", filename, line
        ) from exc
    func = module.__dict__.get(FUNCTION_NAME)
    if not callable(func):
        raise RewardFunctionError(
            f"{filename} defines no function named reward_function(params); DeepRacer calls that name.",
            filename,
        )
    return RewardFunction(func, filename, text, time_limit)


def _load_failure(exc: BaseException) -> str:
    if isinstance(exc, RewardTimeout):
        return f"ran longer than {guard.LOAD_TIME_LIMIT:g} s (its top-level code must only define functions)."
    if isinstance(exc, RewardExit):
        return f"called {exc.call}."
    if isinstance(exc, SystemExit):
        return f"called sys.exit({exc.code!r})."
    return f"raised {type(exc).__name__}: {exc}"


def _source_file(func: Callable[..., Any]) -> str | None:
    try:
        f = inspect.getsourcefile(func)
    except TypeError:
        return None
    return str(Path(f).resolve()) if f else None


_NOTHING = object()


def _key_hint(exc: BaseException, params: dict[str, Any]) -> str:
    """For a ``KeyError`` on a misspelt params key: "; did you mean 'distance_from_center'?"."""
    if not isinstance(exc, KeyError) or len(exc.args) != 1 or not isinstance(exc.args[0], str):
        return ""
    key = exc.args[0]
    if key in params:
        return ""  # the key was missing from some other dict
    close = difflib.get_close_matches(key, [k for k in params if isinstance(k, str)], n=1, cutoff=0.6)
    return f"; did you mean {close[0]!r}?" if close else ""


def _user_line(tb: types.TracebackType | None, path: str | None) -> int | None:
    """The deepest traceback line inside the user's file (or the last frame when the file is unknown)."""
    frames = traceback.extract_tb(tb)
    if path is not None:
        resolved = str(Path(path).resolve())
        mine = [f for f in frames if f.filename and _same(f.filename, resolved)]
        if mine:
            return mine[-1].lineno
    return frames[-1].lineno if frames else None


def _same(a: str, b: str) -> bool:
    try:
        return str(Path(a).resolve()) == b
    except OSError:
        return False
