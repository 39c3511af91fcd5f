#!/usr/bin/env bash
# Install the TensorFlow CHECK environment .venv-tf (beside .venv) (never a drx runtime dependency).
# tools/tf_check/restore_check.py runs under it to restore drx-written checkpoints into
# DeepRacer's own TF graph. Idempotent; exits 0 with a reason when it cannot install (tools/check_env.sh).
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
exec bash "$ROOT/tools/check_env.sh" tf_check "$ROOT/.venv-tf" "tensorflow-cpu==2.21.0" numpy
