"""Race pace: re-run a published DeepRacer experiment in drx and judge the best *and* the last model.

The experiment (issue 23, ``docs/RACING.md``): A to Z Speedway clockwise
(``reInvent2019_wide_cw``), the "pursuit" reward (``rewards/pursuit.py``), DeepRacer's
hyperparameters as the blog post set them (batch 128, learning rate 0.0003, discount 0.995,
Huber loss, 25 episodes per iteration, 10 epochs), drx's default network:

- ``exp1``: continuous, steering -30..30 deg, speed 1.1..4 m/s; DeepRacer's 3 hours: 10.597 s, 3 off-track;
- ``exp2``: the same with speed 1.1..3 m/s; DeepRacer's 3 hours: 10.000 s, 0 off-track;
- ``exp3``: a clone of exp2's model with speed 1.1..3.5 m/s, trained on; DeepRacer's 1 more hour: 9.257 s;
- ``discrete``: 15 actions (5 steering x 3 speeds up to 4 m/s); the issue's target 9.0 s, <= 1 off-track.

Each runs as a new user runs it, through the CLI in a fresh data home (``drx garage add``,
``drx model create``, ``drx train --max-minutes M --seed S``; exp3 ``drx model clone`` then
``drx train``), then ``drx evaluate --laps 3 --seed S`` drives the **best** and the **last**
checkpoint. The table gives, per checkpoint: fastest / average lap (of the completed laps),
laps completed, off-tracks, the fastest lap's ratio to DeepRacer's figure and to the car's
theoretical best lap (``drx track best-lap``), the steps trained and the wall time, with the
core count and the load. ``--parallel 2`` runs two chains of experiments at once (each trains
on one core: the compact network's update uses one thread); exp3 follows exp2 in its chain.

``--track`` and ``--reward`` run the same cars on another track or reward, to check that what
holds on A to Z Speedway is not tuned to it; ``--algo sac`` trains the continuous experiments with
SAC (DeepRacer's SAC defaults but the batch, learning rate and discount above; ``--sac-alpha`` sets its
temperature). ``--lr-schedule anneal|constant|linear|settle`` sets the learning rate's schedule (drx's
``lr_schedule``) for every experiment; a clone keeps its parent's. ``--rollout-workers N`` gives
each run N processes sampling its episodes (drx's ``rollout_workers``; PPO only, as in drx).

``--recipe race-pace [--tracks ...] [--seeds 0 1]`` runs the race-pace recipe on four tracks of the
league instead, against the theoretical best lap and the league's fastest (``benchmarks/recipe_pace.py``).

Run: ``python benchmarks/race_pace.py [--minutes 30] [--clone-minutes 10] [--only exp1 exp2 exp3 discrete]
[--parallel 2] [--seed 0] [--track NAME] [--reward FILE] [--algo ppo|sac] [--sac-alpha A]
[--lr-schedule anneal|constant|linear|settle] [--rollout-workers N] [--json FILE] [--keep]``.
``--keep`` leaves each chain's data home in place (printed) for ``benchmarks/checkpoint_returns.py``.
``--defaults`` trains with drx's default hyperparameters (issue 41, item 4: the experiment's car and
reward, drx's settings). ``--network shallow --towers separate`` trains DeepRacer's network with its
two towers (drx's ``towers``), ``--towers shared`` with drx's one trunk under both heads.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
SHARED_TRACKS = ROOT.parent / "shared" / "tracks"
TRACK = "reInvent2019_wide_cw"
REWARD = ROOT / "rewards" / "pursuit.py"
HYPERPARAMETERS = (
    "--batch-size", "128", "--lr", "0.0003", "--discount", "0.995", "--loss", "huber",
    "--episodes-per-iteration", "25", "--epochs", "10",
)  # fmt: skip
SAC_HYPERPARAMETERS = ("--algo", "sac", "--batch-size", "128", "--lr", "0.0003", "--discount", "0.995")
RACE_PACE_GOAL = 7.5  # [s] the goal beyond DeepRacer on A to Z Speedway (record pace)


@dataclass(frozen=True)
class Experiment:
    """One row of the experiment: a car, how long it trains, and DeepRacer's figure to beat.

    :param name: ``exp1`` ...
    :param car: ``drx garage add`` options.
    :param deepracer_lap: DeepRacer's fastest evaluation lap [s] (or the issue's target).
    :param deepracer_off_track: off-tracks DeepRacer's evaluation had (the most allowed).
    :param parent: the experiment whose model this one clones (``None``: trained from scratch).
    """

    name: str
    car: tuple[str, ...]
    deepracer_lap: float
    deepracer_off_track: int
    parent: str | None = None


CONTINUOUS = ("--continuous", "--max-steering", "30", "--min-speed", "1.1", "--max-speed")
EXPERIMENTS = {
    "exp1": Experiment("exp1", (*CONTINUOUS, "4"), 10.597, 3),
    "exp2": Experiment("exp2", (*CONTINUOUS, "3"), 10.000, 0),
    "exp3": Experiment("exp3", (*CONTINUOUS, "3.5"), 9.257, 0, parent="exp2"),
    "discrete": Experiment(
        "discrete",
        ("--max-steering", "30", "--steering-levels", "5", "--max-speed", "4", "--speed-levels", "3"),
        9.0,
        1,
    ),
}  # fmt: skip


@dataclass
class Outcome:
    """What one experiment left: its training and the time trials of its best and last checkpoints."""

    name: str
    minutes: float = 0.0
    steps: int = 0
    iterations: int = 0
    stop_reason: str | None = None
    best_iteration: int | None = None
    theoretical_best: float | None = None
    comparable: bool = True  # DeepRacer's figure applies: the experiment's own track, reward and PPO
    health: dict[str, Any] = field(default_factory=dict)  # the run's evaluations and update figures
    trials: dict[str, dict[str, Any]] = field(default_factory=dict)


class Home:
    """A fresh ``DRX_HOME`` and the CLI run in it."""

    def __init__(self, folder: str) -> None:
        self.env = {**os.environ, "DRX_HOME": folder, "PYTHONPATH": str(ROOT), "COLUMNS": "80"}
        for elsewhere in ("DRX_DATABASE_URL", "DRX_ARTIFACTS_URL"):  # a fresh home: not a shared registry
            self.env.pop(elsewhere, None)

    def drx(self, *args: str) -> Any:
        """Run ``drx ARGS --json`` and return its JSON (exit on failure, with what it said)."""
        done = subprocess.run(
            [sys.executable, "-m", "drx.cli.main", *args, "--json"],
            capture_output=True, text=True, env=self.env, cwd=ROOT,
        )  # fmt: skip
        if done.returncode != 0:
            raise SystemExit(f"drx {' '.join(args)} failed ({done.returncode}): {done.stderr.strip()}")
        return json.loads(done.stdout)

    def has_track(self, name: str) -> bool:
        """Whether ``drx track show NAME`` knows the track (shipped, built in or imported)."""
        done = subprocess.run(
            [sys.executable, "-m", "drx.cli.main", "track", "show", name, "--json"],
            capture_output=True, text=True, env=self.env, cwd=ROOT,
        )  # fmt: skip
        return done.returncode == 0


# Reads the model's iteration rows from the registry of the data home it runs in (stdout: JSON).
_ITERATIONS = """
import json, sys
from sqlalchemy import select
from drx.registry import Episode, IterationMetric, Model, session_scope
with session_scope() as s:
    model = s.scalar(select(Model).where(Model.name == sys.argv[1]))
    rows = s.execute(select(IterationMetric.iteration, IterationMetric.eval_mean_progress, IterationMetric.kl,
                            IterationMetric.health).where(IterationMetric.model_id == model.id)
                     .order_by(IterationMetric.iteration)).all()
    laps = s.execute(select(Episode.iteration, Episode.lap_time).where(
        Episode.model_id == model.id, Episode.phase == "evaluation", Episode.lap_time.is_not(None))).all()
print(json.dumps({"rows": [list(r) for r in rows], "laps": [list(r) for r in laps]}))
"""
QUARTERS = 4  # the run's evaluation laps are averaged over this many equal spans of iterations


def pace_by_quarter(laps: list[list[float]], iterations: int) -> list[float | None]:
    """The mean evaluation lap time [s] in each quarter of a run's iterations (None: no lap)."""
    spans: list[list[float]] = [[] for _ in range(QUARTERS)]
    for iteration, lap_time in laps:
        spans[min(QUARTERS - 1, int(iteration * QUARTERS / max(1, iterations)))].append(lap_time)
    return [sum(span) / len(span) if span else None for span in spans]


def run_health(home: Home, model: str) -> dict[str, Any]:
    """How the run went, iteration by iteration: its first 3/3-lap evaluation, how low evaluation
    went after it, the collapse warning, the largest KL and share of sampled steering on a bound."""
    try:
        from drx.train.health import LAP_PROGRESS, collapse_warning
    except ImportError:  # a drx from before the collapse warning
        return {}

    done = subprocess.run([sys.executable, "-c", _ITERATIONS, model], capture_output=True, text=True,
                          env=home.env, cwd=ROOT)  # fmt: skip
    if done.returncode != 0:  # a drx from before iterations kept their health figures
        return {}
    stored = json.loads(done.stdout)
    rows = stored["rows"]
    lapped = [it for it, progress, _, _ in rows if (progress or 0.0) >= LAP_PROGRESS]
    after = [progress for it, progress, _, _ in rows if lapped and it > lapped[0] and progress is not None]
    at_bound = [(h or {}).get("at_bound_steering") for _, _, _, h in rows]
    return {
        "first_lap_iteration": lapped[0] if lapped else None,
        "lowest_after_first_lap": min(after) if after else None,
        "full_laps_after_first_lap": f"{sum(p >= LAP_PROGRESS for p in after)}/{len(after)}",
        "collapse_warning": collapse_warning([(it, p) for it, p, _, _ in rows]) is not None,
        "largest_kl": max((kl for _, _, kl, _ in rows if kl is not None), default=None),
        "most_steering_at_bound": max((b for b in at_bound if b is not None), default=None),
        "pace_by_quarter": pace_by_quarter(stored["laps"], len(rows)),
        "rollbacks": sum((h or {}).get("rollback_to") is not None for _, _, _, h in rows),  # anneal
    }


def ensure_track(home: Home, track: str) -> None:
    """Import the route from ``../shared/tracks`` when this drx does not know the track by name."""
    if home.has_track(track):
        return
    route = SHARED_TRACKS / f"{track}.npy"
    if not route.is_file():
        raise SystemExit(f"track {track!r} is unknown to drx and {route} is absent.")
    home.drx("track", "import", str(route))


def run_experiment(home: Home, exp: Experiment, args: argparse.Namespace) -> Outcome:
    """Train one experiment in ``home`` and time-trial its best and last checkpoints."""
    out = Outcome(exp.name)
    out.comparable = args.track == TRACK and args.reward == REWARD.resolve() and args.algo == "ppo"
    home.drx("garage", "add", f"{exp.name}-car", *exp.car)
    minutes = args.clone_minutes if exp.parent else args.minutes
    if exp.parent:
        home.drx("model", "clone", exp.parent, exp.name, "--car", f"{exp.name}-car",
                 "--max-minutes", f"{minutes:g}")  # fmt: skip
    else:
        settings = SAC_HYPERPARAMETERS if args.algo == "sac" else HYPERPARAMETERS
        if args.defaults:  # the experiment's car and reward, drx's own algorithm settings
            settings = ("--algo", args.algo)
        if args.sac_alpha is not None:
            settings = (*settings, "--sac-alpha", f"{args.sac_alpha:g}")
        if args.lr_schedule is not None:
            settings = (*settings, "--lr-schedule", args.lr_schedule)
        if args.rollout_workers is not None:
            settings = (*settings, "--rollout-workers", str(args.rollout_workers))
        if args.network is not None:
            settings = (*settings, "--network", args.network)
        if args.towers is not None:
            settings = (*settings, "--towers", args.towers)
        home.drx("model", "create", exp.name, "--car", f"{exp.name}-car", "--track", args.track,
                 "--reward", str(args.reward), *settings, "--max-minutes", f"{minutes:g}")  # fmt: skip
    started = time.monotonic()
    trained = home.drx("train", exp.name, "--max-minutes", f"{minutes:g}", "--seed", str(args.seed))
    out.minutes = (time.monotonic() - started) / 60.0
    out.steps = int(trained.get("steps") or 0)
    out.iterations = int(trained.get("iterations") or 0)
    out.stop_reason = trained.get("stop_reason")
    best = trained.get("best") or {}
    out.best_iteration = best.get("iteration")
    out.health = run_health(home, exp.name)
    solved = home.drx("track", "best-lap", args.track, "--car", f"{exp.name}-car")
    out.theoretical_best = solved.get("lap_time")
    out.trials = time_trials(home, exp.name, args.seed)
    return out


def time_trials(home: Home, model: str, seed: int) -> dict[str, dict[str, Any]]:
    """``drx evaluate --laps 3 --seed S`` of the model's best and last checkpoints: each one's
    iteration, laps completed, fastest and average lap and off-tracks."""
    trials = {}
    for checkpoint in ("best", "last"):
        trial = home.drx("evaluate", model, "--laps", "3", "--seed", str(seed), "--checkpoint", checkpoint)
        trials[checkpoint] = {
            "iteration": trial.get("checkpoint_iteration"),
            "laps_completed": trial.get("laps_completed"),
            "fastest": trial.get("fastest_lap"),
            "average": trial.get("average_lap"),
            "off_track": trial.get("off_track_count"),
        }
    return trials


def run_chain(names: list[str], args: argparse.Namespace) -> list[Outcome]:
    """Experiments that share a data home (a clone and its parent), in order."""
    if args.keep:
        folder = tempfile.mkdtemp(prefix="drx-race-pace-")
        print(f"  {' '.join(names)}: data home kept at {folder}", flush=True)
        return run_in_home(Home(folder), names, args)
    with tempfile.TemporaryDirectory(prefix="drx-race-pace-") as folder:
        return run_in_home(Home(folder), names, args)


def run_in_home(home: Home, names: list[str], args: argparse.Namespace) -> list[Outcome]:
    """Run a chain's experiments, in order, in one data home."""
    ensure_track(home, args.track)
    outcomes = []
    for name in names:
        outcome = run_experiment(home, EXPERIMENTS[name], args)
        outcomes.append(outcome)
        print(f"  {row_text(outcome)}", flush=True)
    return outcomes


def chains(only: list[str]) -> list[list[str]]:
    """The chains to run: a clone after its parent, every other experiment alone."""
    out: list[list[str]] = []
    for name in only:
        parent = EXPERIMENTS[name].parent
        if parent and parent in only:
            next(c for c in out if parent in c).append(name)
        elif parent:
            raise SystemExit(f"{name} clones {parent}'s model: add {parent} to --only.")
        else:
            out.append([name])
    return out


def _s(value: float | None, spec: str = ".2f") -> str:
    return "-" if value is None else format(value, spec)


def row_text(o: Outcome) -> str:
    """One experiment, both checkpoints, in one line per checkpoint."""
    exp = EXPERIMENTS[o.name]
    lines = []
    for checkpoint, t in o.trials.items():
        fastest = t.get("fastest")
        vs_best = fastest / o.theoretical_best if fastest and o.theoretical_best else None
        deepracer = ""
        if o.comparable:
            vs_dr = fastest / exp.deepracer_lap if fastest else None
            deepracer = (
                f"x{_s(vs_dr)} DeepRacer's {exp.deepracer_lap:.3f} s (off-track {exp.deepracer_off_track}), "
            )
        lines.append(
            f"{o.name:8s} {checkpoint:4s} it {t.get('iteration')!s:>5s}: fastest {_s(fastest)} s, average "
            f"{_s(t.get('average'))} s, laps {t.get('laps_completed')}/3, off-track {t.get('off_track')}; "
            f"{deepracer}x{_s(vs_best)} the best lap {_s(o.theoretical_best)} s; {o.steps} steps in "
            f"{o.minutes:.1f} min ({o.iterations} iterations, {o.stop_reason})"
        )
    h = o.health
    if h:
        lines.append(
            f"{o.name:8s} first 3/3-lap evaluation at iteration {h['first_lap_iteration']}; after it "
            f"{h['full_laps_after_first_lap']} evaluations at 100%, the lowest "
            f"{_s(h['lowest_after_first_lap'], '.0f')}%; collapse warning: "
            f"{'yes' if h['collapse_warning'] else 'no'}; largest KL {_s(h['largest_kl'], '.4f')}; "
            f"steering on a bound at most {_s(h['most_steering_at_bound'])}; "
            f"rollbacks to the best: {h.get('rollbacks', 0)}"
        )
        if "pace_by_quarter" in h:
            pace = ", ".join(_s(t) for t in h["pace_by_quarter"])
            lines.append(f"{o.name:8s} evaluation laps' mean time by quarter of the run: {pace} s")
    best, last = (o.trials.get(k, {}).get("fastest") for k in ("best", "last"))
    if best and last:
        lines.append(f"{o.name:8s} last / best fastest lap: {last / best:.2f} (issue 23: within 1.15)")
    return "\n  ".join(lines)


def main() -> None:
    """Run the chosen experiments and print the table (``--recipe`` / ``--compare-kinds``: the
    race-pace recipe on the league's tracks instead, ``benchmarks/recipe_pace.py``)."""
    if any(a.split("=")[0] in ("--recipe", "--compare-kinds") for a in sys.argv[1:]):
        from recipe_pace import main as recipe_main

        recipe_main(sys.argv[1:])
        return
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=30.0, help="minutes of exp1, exp2, discrete")
    parser.add_argument("--clone-minutes", type=float, default=10.0, help="training minutes of exp3")
    parser.add_argument("--only", nargs="+", choices=sorted(EXPERIMENTS), default=list(EXPERIMENTS))
    parser.add_argument("--parallel", type=int, default=1, help="chains of experiments run at once")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--track", default=TRACK)
    parser.add_argument("--reward", type=Path, default=REWARD)
    parser.add_argument("--algo", choices=("ppo", "sac"), default="ppo", help="sac: continuous cars only")
    parser.add_argument("--sac-alpha", type=float, help="SAC's temperature (default DeepRacer's 0.2)")
    parser.add_argument("--lr-schedule", choices=("anneal", "constant", "linear", "settle"),
                        help="the learning rate over the run (default: drx's default)")  # fmt: skip
    parser.add_argument("--json", type=Path, help="also write the outcomes to this JSON file")
    parser.add_argument("--rollout-workers", type=int,
                        help="processes sampling a run's episodes (drx's default: 1 on 2 cores)")  # fmt: skip
    parser.add_argument("--keep", action="store_true", help="keep each chain's data home and print where")
    parser.add_argument("--network", choices=("compact", "shallow", "deep"), help="the cars' network")
    parser.add_argument("--towers", choices=("shared", "separate"),
                        help="PPO's heads on one trunk or DeepRacer's two towers")  # fmt: skip
    parser.add_argument("--defaults", action="store_true",
                        help="drx's default hyperparameters instead of the blog post's (the car and reward "
                        "stay the experiment's)")  # fmt: skip
    args = parser.parse_args()
    if args.towers is not None and args.algo != "ppo":
        parser.error("--towers applies to PPO; leave it out with --algo sac.")
    if args.algo == "sac" and "discrete" in args.only:
        parser.error("SAC trains continuous cars only; leave discrete out of --only.")
    if args.sac_alpha is not None and (args.algo != "sac" or not 0.0 <= args.sac_alpha <= 1.0):
        parser.error(f"--sac-alpha {args.sac_alpha:g} needs --algo sac and a value from 0 to 1.")
    if args.rollout_workers is not None and not 1 <= args.rollout_workers <= 64:
        parser.error(f"--rollout-workers {args.rollout_workers} is out of range; give 1 to 64.")
    if args.minutes <= 0 or args.clone_minutes <= 0 or args.parallel < 1:
        parser.error("--minutes and --clone-minutes must be above 0 and --parallel at least 1.")
    args.reward = args.reward.resolve()
    if not args.reward.is_file():
        parser.error(f"--reward {str(args.reward)!r} is not a file; give a reward_function .py file.")
    with tempfile.TemporaryDirectory(prefix="drx-race-pace-") as folder:
        if not Home(folder).has_track(args.track) and not (SHARED_TRACKS / f"{args.track}.npy").is_file():
            parser.error(f"--track {args.track!r} is neither a drx track nor a route in {SHARED_TRACKS}; "
                         "see `drx track list`.")  # fmt: skip
    cores = len(os.sched_getaffinity(0))
    print(
        f"race pace on {args.track} with {args.reward.name}, {args.algo}"
        f"{'' if args.sac_alpha is None else f' (sac_alpha {args.sac_alpha:g})'}"
        f"{'' if args.lr_schedule is None else f' (lr_schedule {args.lr_schedule})'}"
        f"{'' if args.rollout_workers is None else f' ({args.rollout_workers} rollout workers)'}"
        f"{'' if args.network is None else f' ({args.network} network)'}"
        f"{'' if args.towers is None else f' ({args.towers} towers)'}"
        f"{' (drx defaults)' if args.defaults else ''}"
        f": {', '.join(args.only)}; "
        f"{args.minutes:g} min "
        f"({args.clone_minutes:g} for a clone), seed {args.seed}; cores: {cores}, {args.parallel} at once, "
        f"load average at start: {os.getloadavg()[0]:.1f}",
        flush=True,
    )
    with concurrent.futures.ThreadPoolExecutor(max_workers=args.parallel) as pool:
        results = list(pool.map(lambda c: run_chain(c, args), chains(args.only)))
    outcomes = [o for chain in results for o in chain]
    print(f"load average at the end: {os.getloadavg()[0]:.1f} (1 min), {os.getloadavg()[2]:.1f} (15 min)")
    for o in outcomes:
        print(f"  {row_text(o)}")
    fastest = [t["fastest"] for o in outcomes for t in o.trials.values() if t.get("fastest")]
    if fastest:
        print(f"fastest lap of any checkpoint: {min(fastest):.2f} s (goal: {RACE_PACE_GOAL} s)")
    if args.json:
        args.json.write_text(json.dumps([o.__dict__ for o in outcomes], indent=2))


if __name__ == "__main__":
    main()
