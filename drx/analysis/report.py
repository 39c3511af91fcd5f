"""``drx analyze``: why a model drives as it does, from its training trace and registry rows.

:func:`analyze_model` reads the model's training trace (all iterations, or one), writes
three pictures and returns the figures for the terminal summary:

- ``<model>-paths.png``: the best episodes' paths over the track;
- ``<model>-heatmaps.png``: mean reward and mean commanded speed over the track;
- ``<model>-actions.png``: the actions chosen in each section (turns and straights);

plus the per-iteration table (completion rate, mean progress, lap times).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from drx.analysis import actions, iterations, track_plots
from drx.analysis.data import episode_table, load_run, load_training_trace, model_folder
from drx.errors import SettingError
from drx.services.tracks import load_track_by_name

BEST_EPISODES = 5


@dataclass
class AnalysisReport:
    """What ``drx analyze`` found.

    :param model: the model's name.
    :param folder: its model folder (traces).
    :param iterations: the iterations analysed.
    :param table: the per-iteration table (:func:`drx.analysis.iterations.iteration_table`).
    :param overall: totals over the analysed training episodes.
    :param best: the best episodes (iteration, episode, progress, steps, lap_time, ...).
    :param breakdown: share of each action [%] per section.
    :param pictures: name -> PNG path.
    """

    model: str
    folder: Path
    iterations: list[int]
    table: pd.DataFrame
    overall: dict[str, Any]
    best: pd.DataFrame
    breakdown: pd.DataFrame
    pictures: dict[str, Path] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """JSON form."""
        best = self.best[["iteration", "episode", "progress", "steps", "reward", "status", "lap_time"]]
        return {
            "model": self.model,
            "folder": str(self.folder),
            "iterations": self.iterations,
            "overall": self.overall,
            "table": iterations.as_records(self.table),
            "best_episodes": iterations.as_records(best),
            "actions_per_section": {
                sec: {k: round(float(v), 2) for k, v in row.items()} for sec, row in self.breakdown.iterrows()
            },
            "pictures": {k: str(v) for k, v in self.pictures.items()},
        }


def _episodes_from_trace(trace: pd.DataFrame) -> pd.DataFrame:
    table = episode_table(trace)
    table["phase"] = "training"
    return table


def analyze_model(
    name: str, iteration: int | None = None, out: Path | None = None, best: int = BEST_EPISODES
) -> AnalysisReport:
    """Analyse a model's training; write the pictures to ``out`` (default ``<model folder>/analysis``).

    :param name: the model.
    :param iteration: analyse this iteration only (default: all).
    :param out: folder for the PNGs.
    :param best: how many best episodes to draw.
    :raises DrxError: unknown model, no trace (or no such iteration), unknown track.
    """
    run = load_run(name)
    folder = model_folder(run.model)
    if iteration is not None and iteration < 0:
        raise SettingError(
            "{field} {value} is invalid; iterations count from 0.", "iteration", value=iteration
        )
    trace = load_training_trace(folder, [iteration] if iteration is not None else None)
    track = load_track_by_name(run.model.track_name)
    vehicle = run.model.vehicle()
    from_trace = _episodes_from_trace(trace)
    registry = run.episodes
    if iteration is not None:
        registry = registry[registry["iteration"] == iteration]
    episodes = registry if not registry[registry["phase"] == "training"].empty else from_trace
    top = track_plots.best_episodes(from_trace, best)
    scope = f"{name}, iteration {iteration}" if iteration is not None else name
    out = Path(out) if out is not None else folder / "analysis"
    out.mkdir(parents=True, exist_ok=True)
    report = AnalysisReport(
        model=name,
        folder=folder,
        iterations=sorted(int(i) for i in trace["iteration"].unique()),
        table=iterations.iteration_table(episodes),
        overall=iterations.overall(episodes),
        best=top,
        breakdown=actions.action_breakdown(track, vehicle, trace),
    )
    figures = {
        "paths": track_plots.paths_figure(track, trace, top, scope),
        "heatmaps": track_plots.heatmap_figure(track, trace, scope),
        "actions": actions.breakdown_figure(track, vehicle, trace, scope),
    }
    suffix = f"-iteration-{iteration}" if iteration is not None else ""
    for key, fig in figures.items():
        path = out / f"{name}{suffix}-{key}.png"
        fig.savefig(path)
        report.pictures[key] = path
    return report
