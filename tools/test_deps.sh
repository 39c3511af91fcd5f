#!/usr/bin/env bash
# Installs what the tests need beyond pip (Debian packages), one section per need. Idempotent;
# skips quietly where it cannot install (not root, no apt-get, no network): the tests that need
# a missing piece then skip with the reason. Called by `make test` before pytest.
set -u

can_apt() { [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; }
apt_updated=""
apt_install() {  # apt_install PACKAGE...: install the missing ones
    local missing=()
    for p in "$@"; do dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p"); done
    [ ${#missing[@]} -eq 0 ] && return 0
    can_apt || return 0
    if [ -z "$apt_updated" ]; then apt-get update -qq >/dev/null 2>&1 || true; apt_updated=1; fi
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" \
        >/dev/null 2>&1 || echo "test_deps: could not install ${missing[*]}; the tests needing them skip" >&2
}

# --- drx watch: the page is tested in headless Chromium (tests/watch/test_browser.py) -----------
if ! { command -v chromium >/dev/null 2>&1 && command -v chromedriver >/dev/null 2>&1; }; then
    apt_install chromium chromium-driver fonts-dejavu-core
fi

# --- DeepRacer's own TensorFlow graph restores drx's exported checkpoints (tests/interchange) ------
# TensorFlow is a check tool, never a drx dependency: it gets its own environment, .venv-tf.
bash "$(dirname "$0")/tf_check/setup.sh" || true

# --- DeepRacer simulator 6's car in DART judges drx's car (tests/calibration/test_referee.py) --------
# DART is a check tool, never a drx dependency: it gets its own environment, .venv-dart.
bash "$(dirname "$0")/dart_check/setup.sh" || true
