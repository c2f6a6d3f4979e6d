#!/usr/bin/env bash
# Build hexbake's textured example scene (issue 18 item 2) from Debian's
# assimp-testmodels: the Cesium milk truck, the Collada duck, the OBJ spider and the
# glTF sample box, converted to glTF 2.0 with the assimp CLI (assimp-utils,
# scripts/convert-textured-models.sh) and placed on a plaza by
# scripts/build-textured-scene.py. Read by manifests/textured-plaza.ron.
#
#   scripts/build-textured-scene.sh [DEST]     (default: <repo>/models/textured-plaza)
#
# Idempotent: does nothing when DEST/textured-plaza.gltf exists. Network: only
# `apt-get download assimp-testmodels` (a Debian mirror), as fetch-models.sh.
set -euo pipefail

repo=$(cd "$(dirname "$0")/.." && pwd)
dest=${1:-$repo/models/textured-plaza}
die() { echo "build-textured-scene: $*" >&2; exit 1; }

if [ -f "$dest/textured-plaza.gltf" ]; then
    echo "build-textured-scene: $dest/textured-plaza.gltf exists"
    exit 0
fi
command -v python3 >/dev/null 2>&1 || die "python3 is missing (apt-get install python3)"

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$repo/scripts/convert-textured-models.sh" "$work/src"
mkdir -p "$dest"
python3 "$repo/scripts/build-textured-scene.py" "$work/src" "$dest"
