#!/usr/bin/env bash
# The test command (README, CI): fetch the real meshes, start a local one-node Slurm
# for the Slurm end-to-end tests (skipped when it cannot be started, unless
# HEXBAKE_REQUIRE_SLURM=1), install the Khronos glTF-Validator when npm is there (the
# export test skips without it, unless HEXBAKE_REQUIRE_GLTF_VALIDATOR=1), then run
# every test.
#   scripts/test.sh [extra cargo test args]
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/fetch-models.sh
if command -v npm >/dev/null; then
    scripts/install-gltf-validator.sh ||
        echo "test.sh: the glTF-Validator did not install: the export test's validator step will skip"
fi

if [ "${HEXBAKE_SLURM:-1}" != 0 ]; then
    state=$(mktemp -d /tmp/hexbake-slurm-test.XXXXXX)
    if scripts/slurm-local.sh start "$state" >"$state.log" 2>&1; then
        export SLURM_CONF=$state/slurm.conf
        trap 'scripts/slurm-local.sh stop "$state" >/dev/null 2>&1 || true' EXIT
        echo "test.sh: local Slurm up ($SLURM_CONF)"
    else
        echo "test.sh: no local Slurm (see $state.log): the Slurm tests will skip"
    fi
fi

cargo test --workspace "$@"
