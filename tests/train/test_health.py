"""The collapse warning: a run whose evaluation fell from laps to almost nothing and stayed there."""

from __future__ import annotations

from drx.train.health import COLLAPSED_ITERATIONS, collapse_warning


def _run(*progress: float | None) -> list[tuple[int, float | None]]:
    return list(enumerate(progress))


def test_a_run_that_lapped_and_fell_away_is_told_what_to_do() -> None:
    fallen = [30.0, 80.0, 100.0, 100.0] + [6.0] * COLLAPSED_ITERATIONS
    warning = collapse_warning(_run(*fallen), "exp2")
    assert warning is not None
    assert "collapsed" in warning and "iteration 3" in warning and "6%" in warning
    assert "drx model clone exp2 exp2-2 --lr 0.0001" in warning


def test_no_warning_before_a_lap_or_while_it_still_drives() -> None:
    assert collapse_warning(_run(*[5.0] * 30)) is None  # never lapped: still learning
    assert collapse_warning(_run(100.0, *[6.0] * (COLLAPSED_ITERATIONS - 1))) is None  # not long enough
    dip = [100.0] + [6.0] * (COLLAPSED_ITERATIONS - 1) + [40.0]
    assert collapse_warning(_run(*dip)) is None  # came back above almost nothing
    assert collapse_warning(_run(*[100.0] * 20)) is None


def test_iterations_that_were_not_evaluated_do_not_count() -> None:
    skipped = [100.0] + [None] * 20 + [6.0] * (COLLAPSED_ITERATIONS - 1)
    assert collapse_warning(_run(*skipped)) is None
    assert collapse_warning(_run(*skipped, 5.0)) is not None
