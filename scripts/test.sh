#!/usr/bin/env bash
# The test command (README, CI): fetch the real meshes, then run every test.
#   scripts/test.sh [extra cargo test args]
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/fetch-models.sh
exec cargo test --workspace "$@"
