"""Errors a user can fix.

A :class:`DrxError` carries one clear sentence naming the bad value and the fix.
The CLI catches it once, prints the sentence and exits with code 2, without a
traceback. Bugs raise anything else and keep their traceback.
"""


class DrxError(Exception):
    """A problem with the user's input or data that the user can fix."""

    exit_code = 2


class NotFoundError(DrxError):
    """A named thing (car, track, model, job...) does not exist."""


class AlreadyExistsError(DrxError):
    """A name is already taken."""


class Interruption(BaseException):  # noqa: N818 - a control signal, not an error
    """drx's own interruption of a run (worker shutdown, a stop request).

    A ``BaseException``, so that neither a reward function's ``except Exception`` nor drx's
    error handling turns it into a failure: it passes up to the code that asked for it.
    """


def not_a_file(path: object, what: str, fix: str = "") -> NotFoundError:
    """The error for a path that should be a file and is not: a folder is called a folder.

    :param path: the path the user gave.
    :param what: what it should be, capitalised (``"Track file"``).
    :param fix: the rest of the sentence after ``; `` (e.g. ``give a .npy route file``).
    """
    from pathlib import Path  # errors.py stays import-light: everything imports it

    state = "is a folder, not a file" if Path(str(path)).expanduser().is_dir() else "does not exist"
    return NotFoundError(f"{what} {str(path)!r} {state}" + (f"; {fix}." if fix else "."))
