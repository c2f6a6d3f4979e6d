#!/usr/bin/env bash
# Installs the Khronos glTF-Validator (npm package `gltf-validator`, the version
# pinned in tools/package.json) into tools/node_modules (git-ignored), for
# tools/gltf-validate.mjs and the export test (pipeline/tests/export_gltf.rs).
# Idempotent: nothing to do (and no network) when that version is installed.
#   scripts/install-gltf-validator.sh
set -euo pipefail
cd "$(dirname "$0")/../tools"
want=$(sed -n 's/.*"gltf-validator": *"\([^"]*\)".*/\1/p' package.json)
have=$(sed -n 's/^ *"version": *"\([^"]*\)".*/\1/p' node_modules/gltf-validator/package.json 2>/dev/null || true)
if [ -n "$want" ] && [ "$have" = "$want" ]; then
    exit 0
fi
if ! command -v npm >/dev/null || ! command -v node >/dev/null; then
    echo "install-gltf-validator.sh: node and npm are needed (Debian: apt-get install nodejs npm)" >&2
    exit 1
fi
npm install --no-audit --no-fund --loglevel=error
echo "install-gltf-validator.sh: gltf-validator $want in tools/node_modules"
