#!/usr/bin/env bash
# Time trial: the track to itself; the car learns to lap fast and stay on the road.
# (examples/quickstart.sh walks through the whole loop; this is the training part.)
# Run from anywhere with drx on PATH (or after `make setup`); data goes to $DRX_HOME.
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH="$PWD/.venv/bin:$PATH"
MINUTES="${DRX_EXAMPLE_MINUTES:-10}"
TRACK="${DRX_EXAMPLE_TRACK:-oval}"
MODEL="laps-$(date +%Y%m%d-%H%M%S)"
mkdir -p out

step() { printf '\n\033[1m==> %s\033[0m\n' "$*"; }

step "The car: DeepRacer's default (one camera, 10 actions)"
drx garage show default

step "The reward: progress and speed (rewards/progress_speed.py)"
drx reward validate rewards/progress_speed.py --track "$TRACK"

step "Create $MODEL (a time trial is the default race type)"
drx model create "$MODEL" --track "$TRACK" --reward rewards/progress_speed.py \
    --race-type time-trial --max-minutes "$MINUTES"

step "Train for up to $MINUTES minutes"
drx train "$MODEL" --max-minutes "$MINUTES"

step "Evaluate: a 3-lap time trial, video in out/$MODEL.mp4"
drx evaluate "$MODEL" --laps 3 --video "out/$MODEL.mp4"
drx leaderboard --track "$TRACK"
