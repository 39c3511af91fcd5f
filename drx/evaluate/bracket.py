"""Single-elimination brackets of head-to-head races, as DeepRacer's "Bracket of 16".

The console's one model-against-model league race (the Bracket of 16, 2021-11-22 on
``caecer_gp``, 2 s penalties) seeded racers by their qualifying time trials and raced them two at a
time, the winner of each match going on, until one was left. drx does the same with its own
results: a model's seed is its fastest time-trial lap on the track (:func:`seeds`, from
``drx evaluate``), models without one follow in the order given; the field is filled to a power of
two with byes for the best seeds, and seed 1 meets the lowest seed, 2 the second lowest, ... in
the usual bracket order (:func:`bracket_order`), so the best two can only meet in the final.

This module is pure (seeding and pairing); ``drx race --bracket`` runs each match with
:mod:`drx.evaluate.race_service` and stores it as a race of the bracket.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

BRACKET_RANGE = (2, 16)


def bracket_order(size: int) -> list[int]:
    """The seeds (1-based) in bracket order for a power-of-two ``size``: ``[1, 8, 4, 5, 2, 7, 3, 6]``
    for 8, so consecutive pairs are the first round's matches and 1 and 2 meet last."""
    order = [1]
    while len(order) < size:
        n = 2 * len(order)
        order = [x for seed in order for x in (seed, n + 1 - seed)]
    return order


@dataclass
class Match:
    """One match: two models (``None``: a bye), its winner and its stored race."""

    round: int
    a: str | None
    b: str | None
    winner: str | None = None
    race_id: int | None = None
    result: dict[str, Any] = field(default_factory=dict)

    @property
    def bye(self) -> bool:
        """Whether one side is empty (the other goes on without racing)."""
        return self.a is None or self.b is None


def first_round(seeded: list[str]) -> list[Match]:
    """The first round's matches of models in seed order (byes for the best seeds)."""
    size = 1
    while size < len(seeded):
        size *= 2
    slots = [seeded[s - 1] if s <= len(seeded) else None for s in bracket_order(size)]
    return [Match(1, slots[i], slots[i + 1]) for i in range(0, size, 2)]


def seeds(models: list[str], best_laps: dict[str, float]) -> list[str]:
    """Models in seed order: those with a time-trial lap by it (fastest first), then the rest as given."""
    timed = sorted((m for m in models if m in best_laps), key=lambda m: (best_laps[m], models.index(m)))
    return timed + [m for m in models if m not in best_laps]


def tree_lines(rounds: list[list[Match]]) -> list[str]:
    """The bracket as text, one block per round: ``a  beat  b  (race 3)``."""
    lines = []
    total = len(rounds)
    for r, matches in enumerate(rounds, start=1):
        lines.append("Final" if r == total else "Semi-finals" if r == total - 1 else f"Round {r}")
        for m in matches:
            if m.bye:
                lines.append(f"  {m.a or m.b}  (bye)")
                continue
            loser = m.b if m.winner == m.a else m.a
            lines.append(f"  {m.winner}  beat  {loser}  (race {m.race_id})")
    if rounds and rounds[-1]:
        lines.append(f"Winner: {rounds[-1][0].winner}")
    return lines


def tree_diagram(rounds: list[list[Match]]) -> list[str]:
    """The bracket drawn as a tree, first round on the left, the winner on the right::

        steady ─┐
                ├─ steady ─┐
        fourth ─┘          │
                           ├─ steady
        quick ──┐          │
                ├─ quick ──┘
        third ──┘

    A bye shows as ``-`` opposite the seed that went on without racing.
    """
    if not rounds or not rounds[0]:
        return []
    columns: list[list[str]] = [[name or "-" for m in rounds[0] for name in (m.a, m.b)]]
    for matches in rounds:
        columns.append([m.winner or "?" for m in matches])
    width = max(len(name) for col in columns for name in col)
    height = 2 * len(columns[0]) - 1
    step = width + 5  # a name, " ─┐" (at least one dash) and the next column's "├─ "
    grid = [[" "] * (step * (len(columns) - 1) + width) for _ in range(height)]
    rows = [2 * i for i in range(len(columns[0]))]

    def put(row: int, col: int, text: str) -> None:
        for i, ch in enumerate(text):
            grid[row][col + i] = ch

    for k, names in enumerate(columns):
        x = k * step
        for row, name in zip(rows, names, strict=True):
            put(row, x, name)
        if k == len(columns) - 1:
            break
        bar = x + width + 2
        nxt = []
        for j in range(0, len(rows), 2):
            top, bottom = rows[j], rows[j + 1]
            mid = (top + bottom) // 2
            put(top, x + len(names[j]), " " + "─" * (bar - x - len(names[j]) - 1) + "┐")
            put(bottom, x + len(names[j + 1]), " " + "─" * (bar - x - len(names[j + 1]) - 1) + "┘")
            for r in range(top + 1, bottom):
                put(r, bar, "│")
            put(mid, bar, "├─ ")
            nxt.append(mid)
        rows = nxt
    return ["".join(line).rstrip() for line in grid]
