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
