#!/usr/bin/env bash
# Head-to-bot: bot cars drive the lanes at their own speed; the car learns to follow at a
# safe gap and overtake in the other lane. DeepRacer's rules: 1-4 bots at 0.2-6 m/s,
# optionally changing lanes every 3-5 s (--bot-lane-change).
# The lidar sees bots beside and behind the car; a crash (either car hitting the other)
# ends a training episode.
# Run from anywhere with drx on PATH (or after `make setup`); data goes to $DRX_HOME.
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH="$PWD/.venv/bin:$PATH"
MINUTES="${DRX_EXAMPLE_MINUTES:-10}"
TRACK="${DRX_EXAMPLE_TRACK:-oval}"
MODEL="bots-$(date +%Y%m%d-%H%M%S)"
mkdir -p out

step() { printf '\n\033[1m==> %s\033[0m\n' "$*"; }

step "The car: stereo camera + lidar (garage/stereo-lidar.toml)"
drx garage show stereo-lidar >/dev/null 2>&1 || drx garage add stereo-lidar --from garage/stereo-lidar.toml

step "The reward: keep a gap to the bot ahead, overtake in the other lane (rewards/head_to_bot.py)"
drx reward validate rewards/head_to_bot.py --track "$TRACK"

step "Create $MODEL: 2 bots at 0.8 m/s that change lanes"
drx model create "$MODEL" --car stereo-lidar --track "$TRACK" --reward rewards/head_to_bot.py \
    --race-type head-to-bot --bots 2 --bot-speed 0.8 --bot-lane-change --max-minutes "$MINUTES"
drx model show "$MODEL"

step "Train for up to $MINUTES minutes"
drx train "$MODEL" --max-minutes "$MINUTES"

step "Evaluate against the bots, video in out/$MODEL.mp4"
if drx evaluate --help | grep -q -- "--race-type"; then
  drx evaluate "$MODEL" --race-type head-to-bot --bots 2 --bot-speed 0.8 --video "out/$MODEL.mp4"
else
  drx evaluate "$MODEL" --video "out/$MODEL.mp4"
fi
