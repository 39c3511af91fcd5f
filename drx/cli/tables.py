"""Tables that fit the terminal: columns chosen by priority, names never cut.

A list command describes its columns once (:class:`Column`) and gives its rows as text.
:func:`fitted_table` keeps the columns that fit the console's width (80 when output is not a
terminal, or ``$COLUMNS``), dropping the least important first, and says in the caption which
it hid and that ``--wide`` shows them. Name columns (models, cars, tracks) are never shortened:
they keep their full width and other columns give way; prose columns (an error) wrap at words.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Annotated, Literal

import typer
from rich.cells import cell_len
from rich.console import Console
from rich.table import Table

WIDE_HELP = "Show every column, however wide the table gets (the default fits the terminal)."
Wide = Annotated[bool, typer.Option("--wide", "-w", help=WIDE_HELP)]

Justify = Literal["left", "right"]


@dataclass(frozen=True)
class Column:
    """One column of a list table.

    :param header: the heading.
    :param priority: 0 = always shown; columns with a higher number are hidden first.
    :param justify: ``left`` or ``right``.
    :param kind: ``name`` (never shortened: a model, car or track name), ``prose`` (wraps at
        words, takes the width left over) or ``value`` (short, kept on one line when it can).
    :param min_width: a prose column's narrowest width (default 24): the table hides other
        columns before it squeezes this one further.
    """

    header: str
    priority: int = 0
    justify: Justify = "left"
    kind: Literal["name", "prose", "value"] = "value"
    min_width: int | None = None

    def prose_min(self) -> int:
        """The narrowest a prose column may get."""
        return self.min_width if self.min_width is not None else _PROSE_MIN


# A column costs its text plus one space of padding each side and one border line.
_COLUMN_OVERHEAD = 3
_PROSE_MIN = 24  # a prose column narrower than this reads badly; hide others first


def _width_needed(columns: Sequence[Column], widths: dict[str, int]) -> int:
    """The table's width with ``columns`` at the given widths (prose at its minimum)."""
    total = 1  # the left border
    for col in columns:
        w = min(widths[col.header], col.prose_min()) if col.kind == "prose" else widths[col.header]
        total += w + _COLUMN_OVERHEAD
    return total


def _natural_widths(columns: Sequence[Column], rows: Sequence[Sequence[str]]) -> dict[str, int]:
    """Each column's width without wrapping: its longest cell or header (a prose column's header
    wraps, so its longest word)."""
    widths = {}
    for i, col in enumerate(columns):
        words = col.header.split() if col.kind == "prose" else [col.header]
        header = max((cell_len(word) for word in words), default=0)
        widths[col.header] = max([header, *(cell_len(row[i]) for row in rows)])
    return widths


def choose_columns(
    columns: Sequence[Column], rows: Sequence[Sequence[str]], width: int
) -> tuple[list[int], list[str]]:
    """Which columns fit ``width``: their indexes, and the headers hidden to make room.

    Columns go least important first (highest priority number, the rightmost among equals)
    until the rest fit; priority-0 columns always stay.
    """
    widths = _natural_widths(columns, rows)
    kept = list(range(len(columns)))
    hidden: list[str] = []
    while _width_needed([columns[i] for i in kept], widths) > width:
        candidates = [i for i in kept if columns[i].priority > 0]
        if not candidates:
            break
        drop = max(candidates, key=lambda i: (columns[i].priority, i))
        kept.remove(drop)
        hidden.append(columns[drop].header)
    return kept, hidden


def fitted_table(
    columns: Sequence[Column],
    rows: Sequence[Sequence[str]],
    *,
    console: Console,
    wide: bool = False,
    title: str | None = None,
) -> Table:
    """A Rich table of ``rows`` that fits the console (every column with ``wide``).

    Hidden columns are named in the caption with the flag that shows them.
    """
    width = 10**6 if wide else console.width
    kept, hidden = choose_columns(columns, rows, width)
    hidden = [c.header for c in columns if c.header in hidden]  # in the table's order
    caption = f"hidden: {', '.join(hidden)} (--wide shows every column)" if hidden else None
    table = Table(title=title, caption=caption, caption_justify="left")
    widths = _natural_widths(columns, rows)
    # only when even the essential columns cannot fit does a name fold onto a second line
    squeezed = _width_needed([columns[i] for i in kept], widths) > width
    for i in kept:
        col = columns[i]
        whole = col.kind == "name" and not squeezed
        table.add_column(
            col.header,
            justify=col.justify,
            no_wrap=col.kind == "value" or whole,
            overflow="fold",  # a cell too long for its column wraps; it is never cut with an ellipsis
            min_width=widths[col.header] if whole else _prose_floor(col, widths, squeezed),
        )
    for row in rows:
        table.add_row(*(row[i] for i in kept))
    return table


def _prose_floor(col: Column, widths: dict[str, int], squeezed: bool) -> int | None:
    """The width Rich must leave a prose column (none when even the essentials cannot fit)."""
    if col.kind != "prose" or squeezed:
        return None
    return min(widths[col.header], col.prose_min())


def print_table(table: Table, console: Console, wide: bool = False) -> None:
    """Print a fitted table; with ``wide``, at its full width even past the terminal's edge."""
    if not wide:
        console.print(table)
        return
    needed = console.measure(table, options=console.options.update_width(10**4)).maximum
    saved = console._width  # Console.print caps its width at the console's: widen the console itself
    console.width = max(needed, console.width)
    try:
        console.print(table, crop=False)
    finally:
        console._width = saved


_PATH = re.compile(r"(?:[A-Za-z]:)?(?:[\\/][^\s\\/,:;'\"]+)+[\\/]([^\s\\/,:;'\"]+)")


def short_paths(text: str) -> str:
    """``text`` with every absolute path shortened to its file name (for a table cell)."""
    return _PATH.sub(lambda m: m.group(1), text)
