#!/usr/bin/env bash
# The test command (README, CI): fetch the real meshes, start a local one-node Slurm
# for the Slurm end-to-end tests (skipped when it cannot be started, unless
# HEXBAKE_REQUIRE_SLURM=1), install the Khronos glTF-Validator when npm is there (the
# export test skips without it, unless HEXBAKE_REQUIRE_GLTF_VALIDATOR=1), then run
# every test, and at the end print which tests skipped and why.
#   scripts/test.sh [extra cargo test args]
#
# A test that lacks a GPU adapter, the fetched models, Slurm or the glTF-Validator
# skips through tests/testkit (one helper): it appends "<test>\t<reason>" to
# $HEXBAKE_SKIP_LOG, which this script creates. HEXBAKE_REQUIRE_GPU, _MODELS, _SLURM,
# _GLTF_VALIDATOR, _VALGRIND and _WEB set to 1/true/yes make such a test fail instead
# (.ci/run sets all six). tests/guard.rs is the guard against slipping back
# (scripts/guard.sh).
set -euo pipefail
cd "$(dirname "$0")/.."

skip_log=$(mktemp /tmp/hexbake-skips.XXXXXX)
export HEXBAKE_SKIP_LOG=$skip_log
# The summary comes last, whatever happened before it (a failed fetch included).
skip_summary() {
    local n
    n=$(cut -f1 "$skip_log" 2>/dev/null | sort -u | grep -c . || true)
    echo
    if [ "${n:-0}" -gt 0 ]; then
        # N tests; a test that skipped several parts has a line for each.
        echo "skipped tests: $n"
        sort -u "$skip_log" | while IFS=$'\t' read -r name why; do
            echo "  $name: $why"
        done
    else
        echo "skipped tests: none"
    fi
    rm -f "$skip_log"
}
cleanups=(skip_summary)
run_cleanups() {
    local status=$? c
    for c in "${cleanups[@]}"; do "$c" || true; done
    exit "$status"
}
trap run_cleanups EXIT

scripts/fetch-models.sh
if command -v npm >/dev/null; then
    scripts/install-gltf-validator.sh ||
        echo "test.sh: the glTF-Validator did not install: the export test's validator step will skip"
    # The browser viewer's npm packages and bundle (tests/web.rs skips without them,
    # unless HEXBAKE_REQUIRE_WEB=1); no apt here: CI installs chromium.
    scripts/install-web.sh --no-apt ||
        echo "test.sh: the web viewer did not install: tests/web.rs will skip"
fi

if [ "${HEXBAKE_SLURM:-1}" != 0 ]; then
    state=$(mktemp -d /tmp/hexbake-slurm-test.XXXXXX)
    if scripts/slurm-local.sh start "$state" >"$state.log" 2>&1; then
        export SLURM_CONF=$state/slurm.conf
        stop_slurm() { scripts/slurm-local.sh stop "$state" >/dev/null 2>&1 || true; }
        cleanups=(stop_slurm "${cleanups[@]}")
        echo "test.sh: local Slurm up ($SLURM_CONF)"
    else
        echo "test.sh: no local Slurm (see $state.log): the Slurm tests will skip"
    fi
fi

cargo test --workspace "$@"
