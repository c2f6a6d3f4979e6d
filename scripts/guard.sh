#!/usr/bin/env bash
# The guard against slipping back (issue 30 item 6; tests/guard.rs): bakes the fixed
# sample manifests/guard.ron under valgrind's cachegrind and compares its instruction
# counts, pack bytes and short walk with tests/data/guard-baseline.ron. It runs in
# scripts/test.sh (CI) like any test; this script runs it alone.
#   scripts/guard.sh            check against the baseline
#   scripts/guard.sh --update   measure and rewrite the baseline (commit it, and say
#                               in the commit why the sample now costs what it does)
# Needs valgrind (apt install valgrind) and, for the walk, a wgpu adapter (lavapipe).
set -euo pipefail
cd "$(dirname "$0")/.."
if [ "${1:-}" = --update ]; then
    export HEXBAKE_GUARD_UPDATE=1
elif [ $# -gt 0 ]; then
    echo "usage: scripts/guard.sh [--update]" >&2
    exit 2
fi
exec cargo test -p hexbake-tests --test guard -- --nocapture
