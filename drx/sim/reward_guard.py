"""Limits around a user's reward function: time, printed output, ``os._exit``, its own ``params``.

A reward file is the user's own Python and runs in drx's process (as on DeepRacer,
where it runs inside the simulation app). These guards are against mistakes, not a
sandbox:

- **time**: a watchdog thread ends a call that runs longer than the limit
  (:func:`time_limit`, ``$DRX_REWARD_TIME_LIMIT``, default 1 s) by raising inside it;
  the same path lets another thread (a job's heartbeat seeing ``drx jobs stop``) end a
  call at once (:func:`interrupt`). The exception is raised at the call's next bytecode: in
  the main thread by a Python signal handler run through ``_thread.interrupt_main`` (it raises
  only while the call still runs, so a late one is harmless), in other threads by
  ``PyThreadState_SetAsyncExc``. A call blocked in a system call (``time.sleep``) gets it when
  that returns. No OS signal is sent: one sent to the main thread to cut a ``time.sleep``
  short crashed a long test process (a segfault in the full suite).
  The per-call cost is two attribute stores: the watchdog polls, nothing is armed per call.
- **output**: ``print`` in the reward file writes to standard error (never to standard
  output, which carries ``--json``), at most :data:`OUTPUT_CAP` bytes per process; a note
  says how much more was dropped.
- **exits**: ``os._exit`` / ``os.abort`` imported by the reward file raise
  :class:`RewardExit` instead of ending the process; ``sys.exit`` raises ``SystemExit``,
  which the caller reports.
- **params**: :func:`own_params` gives every call its own dict and its own copies of the
  lists in it, so a reward that changes them reaches neither drx's state nor the trace.
"""

from __future__ import annotations

import _thread
import builtins
import contextlib
import ctypes
import os
import signal
import sys
import threading
import time
import types
from collections.abc import Callable, Iterator
from typing import Any

from drx.errors import DrxError

DEFAULT_TIME_LIMIT = 1.0  # [s] per call; generous: the console warns above 1 ms
LOAD_TIME_LIMIT = 30.0  # [s] running a reward file's top-level code (imports of numpy, scipy...)
OUTPUT_CAP = 256 << 10  # [bytes] of a process's reward output kept (the rest is counted, dropped)
ENV_TIME_LIMIT = "DRX_REWARD_TIME_LIMIT"
# The signal number whose Python handler raises the interruption in the main thread. No such
# signal is ever sent: ``_thread.interrupt_main(_SLOT)`` runs the handler as if it had arrived.
_SLOT = signal.SIGALRM


class RewardTimeout(BaseException):  # noqa: N818 - raised inside the user's code, reported by the caller
    """Raised inside a reward call that ran past its time limit (a BaseException, so that the
    user's ``except Exception`` does not swallow it)."""


class RewardExit(BaseException):  # noqa: N818
    """Raised when the reward file calls ``os._exit`` or ``os.abort``.

    :param call: what was called, e.g. ``os._exit(3)``.
    """

    def __init__(self, call: str) -> None:
        super().__init__(call)
        self.call = call


def time_limit() -> float:
    """The per-call limit [s]: ``$DRX_REWARD_TIME_LIMIT`` or :data:`DEFAULT_TIME_LIMIT`.

    :raises DrxError: the variable is not a positive number.
    """
    raw = os.environ.get(ENV_TIME_LIMIT)
    if not raw:
        return DEFAULT_TIME_LIMIT
    try:
        value = float(raw)
    except ValueError:
        value = float("nan")
    if not value > 0.0 or value == float("inf"):
        raise DrxError(
            f"{ENV_TIME_LIMIT}={raw!r} is not a positive number of seconds; unset it or give e.g. 5."
        )
    return value


# ----- the watchdog ------------------------------------------------------------------------------
class _Watch:
    """The reward call running now (one at a time per process: drx calls rewards from one thread)."""

    def __init__(self) -> None:
        self.started = 0.0  # perf_counter() at the call's start; 0.0 when no call runs
        self.limit = DEFAULT_TIME_LIMIT
        self.thread = 0  # ident of the calling thread
        self.pending: type[BaseException] | BaseException | None = None
        self.pid = 0  # the process the watchdog thread runs in (a fork has none)
        self.lock = threading.Lock()


_watch = _Watch()


def _forget_watchdog() -> None:
    _watch.pid = 0  # a forked child has no watchdog thread: start one on its first call
    _watch.started = 0.0


os.register_at_fork(after_in_child=_forget_watchdog)
_POLL = 0.02  # [s] how often the watchdog looks


STUCK_GRACE = 5.0  # [s] after the limit, a call that caught every interruption ends the process
_last_words: list[Callable[[str], None]] = []


def on_stuck(callback: Callable[[str], None]) -> Callable[[], None]:
    """Call ``callback(sentence)`` before the process ends over a call that cannot be interrupted
    (it catches every exception in a loop); returns a function that unregisters it."""
    _last_words.append(callback)
    return lambda: _last_words.remove(callback) if callback in _last_words else None


def _watchdog() -> None:
    w = _watch
    while True:
        time.sleep(_POLL)
        started = w.started
        if not started:
            continue
        over = time.perf_counter() - started - w.limit
        if over > max(STUCK_GRACE, w.limit):
            _end_process(w.limit)
        elif over > 0.0:
            _deliver(RewardTimeout, started)  # again every poll, should the call catch it


def _end_process(limit: float) -> None:
    """The last resort: the call swallowed every interruption; say so and end the process (exit 2)."""
    sentence = (
        f"The reward function ran past its {limit:g} s time limit and caught every attempt to stop it "
        "(an except clause catching BaseException in a loop, or a call that blocks?); drx ended the process."
    )
    for callback in list(_last_words):
        with contextlib.suppress(Exception):
            callback(sentence)
    with contextlib.suppress(Exception):
        (sys.__stderr__ or sys.stderr).write(f"Error: {sentence}\n")
        (sys.__stderr__ or sys.stderr).flush()
    os._exit(2)


def _deliver(exc: type[BaseException] | BaseException, started: float | None = None) -> bool:
    """Raise ``exc`` in the thread of the reward call running now; ``False`` when none runs."""
    w = _watch
    with w.lock:
        if not w.started or (started is not None and w.started != started):
            return False
        w.pending = exc
        thread = w.thread
    if thread == threading.main_thread().ident and signal.getsignal(_SLOT) is _on_signal:
        # the main thread runs the handler at its next bytecode, which raises only while the call
        # still runs (a late one is ignored); no OS signal is sent (one crashed a full test run)
        _thread.interrupt_main(_SLOT)
    else:  # another thread: raised at its next bytecode
        cls = exc if isinstance(exc, type) else type(exc)
        ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(thread), ctypes.py_object(cls))
    return True


def _on_signal(signum: int, frame: Any) -> None:
    w = _watch
    exc = w.pending
    if exc is None or not w.started:  # a late interruption after the call returned is ignored
        w.pending = None
        return
    if frame is not None and str(frame.f_globals.get("__name__", "")).startswith("drx."):
        return  # drx's own code (the wrapper unwinding an earlier one): the watchdog repeats if needed
    raise exc


def ensure_watchdog() -> None:
    """Start this process's watchdog thread once."""
    w = _watch
    if w.pid == os.getpid():
        return
    w.pid = os.getpid()
    if threading.current_thread() is threading.main_thread():
        with contextlib.suppress(ValueError, OSError):
            signal.signal(_SLOT, _on_signal)
    threading.Thread(target=_watchdog, name="drx-reward-watchdog", daemon=True).start()


def interrupt(exc: type[BaseException] | BaseException, running_for: float = 0.0) -> bool:
    """From any thread: end the reward call running now by raising ``exc`` inside it.

    Used by a job's heartbeat when ``drx jobs stop`` arrives during a slow call.

    :param running_for: only a call that has run at least this long [s] (a fast call ends by itself).
    :return: whether a call was running (and got the exception).
    """
    started = _watch.started
    if not started or time.perf_counter() - started < running_for:
        return False
    return _deliver(exc, started)


@contextlib.contextmanager
def guarded_call(limit: float) -> Iterator[None]:
    """Run the body (one reward call, or loading a reward file) under the time limit.

    :meth:`drx.sim.reward_loader.RewardFunction.__call__` inlines the same stores (it runs every step).
    """
    ensure_watchdog()
    w = _watch
    w.limit, w.thread, w.pending = limit, threading.get_ident(), None
    w.started = time.perf_counter()
    try:
        yield
    finally:
        w.started = 0.0
        w.pending = None


# ----- output ------------------------------------------------------------------------------------
class CappedOutput:
    """Where a reward file's ``print`` goes: standard error, up to :data:`OUTPUT_CAP` bytes per process."""

    def __init__(self, cap: int = OUTPUT_CAP) -> None:
        self.cap = cap
        self.written = 0
        self.dropped = 0
        self.lines = 0

    def write(self, text: str) -> int:
        """Write (or count and drop, past the cap) ``text``."""
        n = len(text)
        self.lines += text.count("\n")
        room = self.cap - self.written
        if room <= 0:
            self.dropped += n
            return n
        if n > room:
            self.dropped += n - room
            text = (
                text[:room] + f"\n[drx] the reward function printed more than {self.cap >> 10} KiB; "
                "the rest of its output is dropped.\n"
            )
        self.written += min(n, room)
        stream = sys.__stderr__ or sys.stderr
        with contextlib.suppress(OSError, ValueError):
            stream.write(text)
        return n

    def flush(self) -> None:
        """Flush standard error."""
        stream = sys.__stderr__ or sys.stderr
        with contextlib.suppress(OSError, ValueError):
            stream.flush()


output = CappedOutput()


def _print(
    *args: Any, sep: str | None = " ", end: str | None = "\n", file: Any = None, flush: bool = False
) -> None:
    if file is None or file is sys.stdout or file is sys.stderr or file is sys.__stdout__:
        file = output
    builtins.print(*args, sep=sep, end=end, file=file, flush=flush)


# ----- os._exit ----------------------------------------------------------------------------------
def _refuse_exit(code: int = 0) -> None:
    raise RewardExit(f"os._exit({code})")


def _refuse_abort() -> None:
    raise RewardExit("os.abort()")


class _GuardedOs(types.ModuleType):
    """``os`` as a reward file sees it: everything but ``_exit`` and ``abort``, which raise."""

    _exit = staticmethod(_refuse_exit)
    abort = staticmethod(_refuse_abort)

    def __getattr__(self, name: str) -> Any:
        return getattr(os, name)


_guarded_os = _GuardedOs("os")


def _import(name: str, globals: Any = None, locals: Any = None, fromlist: Any = (), level: int = 0) -> Any:
    module = builtins.__import__(name, globals, locals, fromlist, level)
    if module is os and level == 0:
        return _guarded_os
    return module


def reward_builtins() -> dict[str, Any]:
    """The builtins of a reward file's module: Python's, with ``print`` and ``import os`` guarded."""
    table = dict(vars(builtins))
    table["print"] = _print
    table["__import__"] = _import
    return table


# ----- params ------------------------------------------------------------------------------------
class ParamsCopier:
    """Copies a ``params`` dict for one reward call: a new dict, new lists, new inner lists.

    A deep copy costs ~300 µs per step; this ~1 µs. It is enough because drx's ``params``
    hold numbers, bools, strings, lists of numbers, lists of ``(x, y)`` tuples and lists of
    ``[x, y]`` lists (``objects_location``); anything else is deep-copied. Which keys hold
    which is worked out once per set of keys (an env's keys never change) and the plan is
    redone when a value does not fit it.
    """

    NESTED = frozenset({"objects_location"})  # DeepRacer's list of [x, y] lists

    def __init__(self) -> None:
        self._size = -1
        self._lists: tuple[str, ...] = ()
        self._nested: tuple[str, ...] = ()
        self._others: tuple[str, ...] = ()

    def copy(self, params: dict[str, Any]) -> dict[str, Any]:
        """The reward's own copy of ``params``."""
        p = params.copy()
        if len(p) != self._size:
            self._plan(p)
        try:
            for k in self._lists:
                p[k] = p[k][:]  # slicing a list: the fastest copy (a tuple or str: itself)
        except (KeyError, TypeError):  # not the plan's keys or types: plan again
            self._plan(p)
            return self.copy(params)
        for k in self._nested:
            v = p.get(k)
            if type(v) is list:
                p[k] = [e[:] if type(e) is list else e for e in v] if v else []
            elif v is not None:
                p[k] = _deep(v)
        for k in self._others:
            p[k] = _deep(p[k])
        return p

    def _plan(self, p: dict[str, Any]) -> None:
        self._size = len(p)
        mutable = [k for k, v in p.items() if type(v) not in _IMMUTABLE]
        nested = {k for k in mutable if type(p[k]) is list and p[k] and type(p[k][0]) is list}
        nested |= self.NESTED & set(mutable)
        self._nested = tuple(sorted(nested))
        self._lists = tuple(k for k in mutable if k not in nested and type(p[k]) is list)
        self._others = tuple(k for k in mutable if k not in nested and type(p[k]) is not list)


_IMMUTABLE = {float, int, bool, str, type(None)}


def _deep(value: Any) -> Any:
    import copy

    return copy.deepcopy(value)
