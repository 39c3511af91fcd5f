#!/usr/bin/env bash
# Install the TensorFlow CHECK environment .venv-tf (beside .venv) (never a drx runtime dependency).
# tools/tf_check/restore_check.py runs under it to restore drx-written checkpoints into
# DeepRacer's own TF graph. Idempotent: a marker keyed on the pinned version skips reinstalls.
# Exits 0 with a reason when it cannot install (e.g. no network), so callers can skip the check.
set -u
TF_VERSION="2.21.0"
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
VENV="$ROOT/.venv-tf"
MARKER="$VENV/.installed"
WANT="tensorflow-cpu==$TF_VERSION"

if [ -f "$MARKER" ] && [ "$(cat "$MARKER")" = "$WANT" ]; then
    echo "tf_check: $VENV already has $WANT"
    exit 0
fi
PY="$(command -v python3.11 || true)"
if [ -z "$PY" ]; then
    echo "tf_check: python3.11 not found; TensorFlow check environment not installed"
    exit 0
fi
if [ ! -x "$VENV/bin/python" ]; then
    "$PY" -m venv "$VENV" || { echo "tf_check: could not create $VENV"; exit 0; }
fi
LOG="$(mktemp)"
if "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check "$WANT" numpy 2>"$LOG"; then
    echo "$WANT" > "$MARKER"
    echo "tf_check: installed $WANT into $VENV"
else
    tail -n 5 "$LOG"
    echo "tf_check: pip could not install $WANT (no network?); TensorFlow checks unavailable"
fi
rm -f "$LOG"
exit 0
