#!/usr/bin/env bash
# The whole DeepRacer loop on built-in defaults: a car, a track, a reward function;
# create a model, train it briefly, evaluate it, show the leaderboard.
# Run it through `make demo` (which sets up .venv first) or directly with drx on PATH.
# Data goes to $DRX_HOME (default ~/.drx); re-running adds a new model each time.
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH="$PWD/.venv/bin:$PATH"
MINUTES="${DRX_DEMO_MINUTES:-3}"
STAMP="$(date +%Y%m%d-%H%M%S)"
MODEL="demo-$STAMP"
TRACK="${DRX_DEMO_TRACK:-oval}"
mkdir -p out

step() { printf '\n\033[1m==> %s\033[0m\n' "$*"; }

step "drx info"
drx info

step "The car: DeepRacer's default (10 actions, 30 deg x 5, 1 m/s x 2, camera, shallow CNN)"
drx garage show demo-car >/dev/null 2>&1 || drx garage add demo-car --from garage/default.toml
drx garage show demo-car

step "The track: $TRACK"
drx track show "$TRACK" --png "out/$TRACK.png"

step "The reward function: rewards/follow_center_line.py"
drx reward validate rewards/follow_center_line.py --track "$TRACK"

step "Create the model $MODEL (drx's compact network: trains ~10x faster on a CPU than DeepRacer's shallow CNN)"
drx model create "$MODEL" --car demo-car --track "$TRACK" --reward rewards/follow_center_line.py \
    --network compact --max-minutes "$MINUTES"
drx model show "$MODEL"

if drx train --help >/dev/null 2>&1; then
  step "Train for up to $MINUTES minutes (or until 3 evaluation iterations in a row complete the lap)"
  drx train "$MODEL" --max-minutes "$MINUTES" --target-iterations 3
fi
if drx evaluate --help >/dev/null 2>&1; then
  step "Evaluate: a 3-lap time trial, video in out/$MODEL.mp4"
  drx evaluate "$MODEL" --laps 3 --video "out/$MODEL.mp4"
  step "Leaderboard"
  drx leaderboard --track "$TRACK"
  step "The reward graph: out/$MODEL-reward.png"
  drx plot "$MODEL" --out "out/$MODEL-reward.png"
fi
