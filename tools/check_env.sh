#!/usr/bin/env bash
# Install a CHECK environment: a virtual environment beside .venv holding one tool that only checks drx
# (TensorFlow for tools/tf_check, DART for tools/dart_check), never a drx dependency.
#   bash tools/check_env.sh LABEL VENV REQUIREMENT [MORE_PACKAGES...]
# Idempotent: a marker keyed on REQUIREMENT skips reinstalls. Exits 0 with a reason when it cannot
# install (e.g. no network), so the tests needing the tool skip and say why.
set -u
LABEL="$1"; VENV="$2"; WANT="$3"; shift 3
MARKER="$VENV/.installed"

if [ -f "$MARKER" ] && [ "$(cat "$MARKER")" = "$WANT" ]; then
    echo "$LABEL: $VENV already has $WANT"
    exit 0
fi
PY="$(command -v python3.11 || true)"
if [ -z "$PY" ]; then
    echo "$LABEL: python3.11 not found; $WANT not installed"
    exit 0
fi
if [ ! -x "$VENV/bin/python" ]; then
    "$PY" -m venv "$VENV" || { echo "$LABEL: could not create $VENV"; exit 0; }
fi
LOG="$(mktemp)"
if "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check "$WANT" "$@" 2>"$LOG"; then
    echo "$WANT" > "$MARKER"
    echo "$LABEL: installed $WANT into $VENV"
else
    tail -n 5 "$LOG"
    echo "$LABEL: pip could not install $WANT (no network?); its checks are unavailable"
fi
rm -f "$LOG"
exit 0
