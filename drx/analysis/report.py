"""``drx analyze``: why a model drives as it does, from its training trace and registry rows.

:func:`analyze_model` reads the model's training trace (all iterations, or one), writes
three pictures and returns the figures for the terminal summary:

- ``<model>-paths.png``: the best episodes' paths over the track;
- ``<model>-heatmaps.png``: mean reward and mean commanded speed over the track;
- ``<model>-actions.png``: the actions chosen in each section (turns and straights);

plus the per-iteration table (completion rate, mean progress, lap times).

A model that trains on several tracks gets each track's figures apart: its episodes' table and
totals, best episodes, action breakdown and the three pictures over that track
(``<model>-<track>-paths.png``...), in :attr:`AnalysisReport.tracks`; the whole model's table and
totals stay on top, and no picture draws one track's episodes over another.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from drx.analysis import actions, iterations, track_plots
from drx.analysis.data import episode_table, load_run, load_training_trace, model_folder, trace_tracks
from drx.errors import SettingError
from drx.services.tracks import load_track_by_name

BEST_EPISODES = 5


@dataclass
class TrackPart:
    """One track's share of a several-track model's training (see :class:`AnalysisReport`).

    :param track: the route's name.
    :param overall: totals over its training episodes.
    :param table: its per-iteration table (the evaluation columns on the first track only: the
        trainer's evaluation drives it).
    :param best: its best episodes; :param breakdown: its actions per section; :param pictures:
        name -> PNG path, drawn over this track.
    """

    track: str
    overall: dict[str, Any]
    table: pd.DataFrame
    best: pd.DataFrame
    breakdown: pd.DataFrame
    pictures: dict[str, Path] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """JSON form."""
        return {"track": self.track, **_parts_dict(self.overall, self.table, self.best, self.breakdown,
                                                    self.pictures)}  # fmt: skip


def _parts_dict(
    overall: dict[str, Any], table: pd.DataFrame, best: pd.DataFrame, breakdown: pd.DataFrame,
    pictures: dict[str, Path],
) -> dict[str, Any]:  # fmt: skip
    shown = best[["iteration", "episode", "progress", "steps", "reward", "status", "lap_time"]]
    return {
        "overall": overall,
        "table": iterations.as_records(table),
        "best_episodes": iterations.as_records(shown),
        "actions_per_section": {
            sec: {k: round(float(v), 2) for k, v in row.items()} for sec, row in breakdown.iterrows()
        },
        "pictures": {k: str(v) for k, v in pictures.items()},
    }


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
    :param tracks: each track's part when the model trained on several (then ``breakdown`` and
        ``pictures`` are empty: they are per track), else empty.
    """

    model: str
    folder: Path
    iterations: list[int]
    table: pd.DataFrame
    overall: dict[str, Any]
    best: pd.DataFrame
    breakdown: pd.DataFrame
    pictures: dict[str, Path] = field(default_factory=dict)
    tracks: list[TrackPart] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        """JSON form (``tracks``: each track's part, for a model that trained on several)."""
        return {
            "model": self.model,
            "folder": str(self.folder),
            "iterations": self.iterations,
            **_parts_dict(self.overall, self.table, self.best, self.breakdown, self.pictures),
            "tracks": [part.to_dict() for part in self.tracks],
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
    suffix = f"-iteration-{iteration}" if iteration is not None else ""
    driven = run.training_tracks()
    report = AnalysisReport(
        model=name,
        folder=folder,
        iterations=sorted(int(i) for i in trace["iteration"].unique()),
        table=iterations.iteration_table(episodes),
        overall=iterations.overall(episodes),
        best=top,
        breakdown=pd.DataFrame(),
    )
    if len(driven) < 2:  # one track: the model's
        track = load_track_by_name(run.model.track_name)
        report.breakdown = actions.action_breakdown(track, vehicle, trace)
        report.pictures = _pictures(track, vehicle, trace, top, scope, out / f"{name}{suffix}")
        return report
    rows_on = trace_tracks(trace, run.episodes)
    for track_name in driven:
        part_trace = trace[rows_on == track_name]
        if part_trace.empty:  # not driven in the iteration analysed
            continue
        evaluated = (registry["phase"] == "evaluation") & (track_name == run.model.track_name)  # its first
        mine = registry[(registry["track_name"] == track_name) | evaluated]
        track = load_track_by_name(track_name)
        part_top = track_plots.best_episodes(_episodes_from_trace(part_trace), best)
        report.tracks.append(
            TrackPart(
                track=track_name,
                overall=iterations.overall(mine),
                table=iterations.iteration_table(mine),
                best=part_top,
                breakdown=actions.action_breakdown(track, vehicle, part_trace),
                pictures=_pictures(track, vehicle, part_trace, part_top, f"{scope} on {track_name}",
                                   out / f"{name}{suffix}-{track_name}"),
            )  # fmt: skip
        )
    return report


def _pictures(
    track: Any, vehicle: Any, trace: pd.DataFrame, top: pd.DataFrame, scope: str, stem: Path
) -> dict[str, Path]:
    """The paths, heat maps and actions pictures of ``trace`` over ``track``, as ``<stem>-<key>.png``."""
    figures = {
        "paths": track_plots.paths_figure(track, trace, top, scope),
        "heatmaps": track_plots.heatmap_figure(track, trace, scope),
        "actions": actions.breakdown_figure(track, vehicle, trace, scope),
    }
    pictures = {}
    for key, fig in figures.items():
        path = stem.parent / f"{stem.name}-{key}.png"
        fig.savefig(path)
        pictures[key] = path
    return pictures
