#!/usr/bin/env bash
# Install the DART CHECK environment .venv-dart (beside .venv) (never a drx runtime dependency).
# tools/dart_check/referee.py runs under it: DeepRacer's simulated car from simapp's URDF in DART, the
# engine simulator 6 runs, to judge drx's car (drx/calibration/referee.py calls it). Idempotent: a
# marker keyed on the pinned version skips reinstalls. Exits 0 with a reason when it cannot install
# (e.g. no network), so the referee's tests skip and say why.
set -u
DART_VERSION="6.20.0"
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
VENV="$ROOT/.venv-dart"
MARKER="$VENV/.installed"
WANT="dartpy==$DART_VERSION"

if [ -f "$MARKER" ] && [ "$(cat "$MARKER")" = "$WANT" ]; then
    echo "dart_check: $VENV already has $WANT"
    exit 0
fi
PY="$(command -v python3.11 || true)"
if [ -z "$PY" ]; then
    echo "dart_check: python3.11 not found; DART check environment not installed"
    exit 0
fi
if [ ! -x "$VENV/bin/python" ]; then
    "$PY" -m venv "$VENV" || { echo "dart_check: could not create $VENV"; exit 0; }
fi
LOG="$(mktemp)"
if "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check "$WANT" numpy 2>"$LOG"; then
    echo "$WANT" > "$MARKER"
    echo "dart_check: installed $WANT into $VENV"
else
    tail -n 5 "$LOG"
    echo "dart_check: pip could not install $WANT (no network?); DART referee checks unavailable"
fi
rm -f "$LOG"
exit 0
