"""Errors a user can fix.

A :class:`DrxError` carries one clear sentence naming the bad value and the fix.
The CLI catches it once, prints the sentence and exits with code 2, without a
traceback. Bugs raise anything else and keep their traceback. A :class:`SettingError`
names a setting by its field name; the CLI words it with its own flag for the field.
"""

from collections.abc import Callable
from typing import Any


class DrxError(Exception):
    """A problem with the user's input or data that the user can fix."""

    exit_code = 2


class NotFoundError(DrxError):
    """A named thing (car, track, model, job...) does not exist."""


class AlreadyExistsError(DrxError):
    """A name is already taken."""


class SettingError(DrxError):
    """A setting's value is not allowed; the sentence names the field, the value and what is allowed.

    ``template`` is a sentence whose ``{field}`` placeholder names the offending setting
    (``fields[0]``), ``{<name>}`` placeholders name the settings in ``fields``, and the other
    placeholders are filled from ``values``. ``str()`` says the field
    names (``max_minutes 0 is out of range; use 1 to 1440.``); the CLI says its flags instead
    (:func:`worded` with its field->flag table, ``drx/cli/flags.py``).

    :param template: the sentence, e.g. ``"{field} {value:g} is out of range; use 1 to 1440."``.
    :param fields: the settings the sentence names, the offending one first.
    :param values: the other placeholders' values (the offending value, the allowed range...).
    """

    def __init__(self, template: str, *fields: str, **values: object) -> None:
        self.template = template
        self.fields = fields
        self.values = values
        super().__init__(self.worded(lambda name: name))

    @property
    def field(self) -> str:
        """The offending setting's name."""
        return self.fields[0]

    def worded(self, name_of: Callable[[str], str]) -> str:
        """The sentence with each field called ``name_of(field)`` (e.g. its CLI flag)."""
        names = {f: name_of(f) for f in self.fields}
        return self.template.format(field=names[self.field], **names, **self.values)


class NameTakenError(SettingError, AlreadyExistsError):
    """A name a setting gives is taken; the sentence names the setting (see :class:`SettingError`)."""


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


def check_png(path: Any, field: str) -> Any:
    """``path`` when it names a PNG file (ends in ``.png``), for options that write a picture.

    :param path: the path the user gave.
    :param field: the setting that gave it (``png``, ``out``), for the message.
    :raises SettingError: another suffix (matplotlib and OpenCV would fail late, or write another format).
    """
    if not str(path).lower().endswith(".png"):
        raise SettingError("{field} {value} must end in .png.", field, value=path)
    return path
