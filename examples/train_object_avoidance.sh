#!/usr/bin/env bash
# Object avoidance: boxes in the lanes; the car learns to change lanes round them.
# DeepRacer's rules: 1-6 boxes between 7% and 90% of the lap, at least 13% apart, each in
# the inside or outside lane; --randomize-objects moves them every training episode.
# The stereo camera judges the distance to a box, the lidar sees it beside the car.
# Run from anywhere with drx on PATH (or after `make setup`); data goes to $DRX_HOME.
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH="$PWD/.venv/bin:$PATH"
MINUTES="${DRX_EXAMPLE_MINUTES:-10}"
TRACK="${DRX_EXAMPLE_TRACK:-kidney}"
MODEL="boxes-$(date +%Y%m%d-%H%M%S)"
mkdir -p out

step() { printf '\n\033[1m==> %s\033[0m\n' "$*"; }

step "The car: stereo camera + lidar (garage/stereo-lidar.toml)"
drx garage show stereo-lidar >/dev/null 2>&1 || drx garage add stereo-lidar --from garage/stereo-lidar.toml

step "The reward: stay on the road, out of the next box's lane (rewards/object_avoidance.py)"
drx reward validate rewards/object_avoidance.py --track "$TRACK"

step "Create $MODEL: 3 boxes at random places every episode"
drx model create "$MODEL" --car stereo-lidar --track "$TRACK" --reward rewards/object_avoidance.py \
    --race-type object-avoidance --objects 3 --randomize-objects --max-minutes "$MINUTES"
# Fixed places instead: --object-at 20:inside --object-at 45:outside --object-at 70:inside
drx model show "$MODEL"

step "Train for up to $MINUTES minutes"
drx train "$MODEL" --max-minutes "$MINUTES"

step "Evaluate with boxes, video in out/$MODEL.mp4"
if drx evaluate --help | grep -q -- "--race-type"; then
  drx evaluate "$MODEL" --race-type object-avoidance --objects 3 --video "out/$MODEL.mp4"
else
  drx evaluate "$MODEL" --video "out/$MODEL.mp4"
fi
