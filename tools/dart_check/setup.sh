#!/usr/bin/env bash
# Install the DART CHECK environment .venv-dart (beside .venv) (never a drx runtime dependency).
# tools/dart_check/referee.py runs under it: DeepRacer's simulated car from simapp's URDF in DART, the
# engine simulator 6 runs, to judge drx's car (drx/calibration/referee.py calls it). Idempotent; exits
# 0 with a reason when it cannot install, so the referee's tests skip and say why (tools/check_env.sh).
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
exec bash "$ROOT/tools/check_env.sh" dart_check "$ROOT/.venv-dart" "dartpy==6.20.0" numpy
