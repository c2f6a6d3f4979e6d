#!/usr/bin/env bash
# Build hexbake's second textured example (issue 29 item 5) from Debian's packages:
# a terrain textured with glmark2-data's grass, an L-shaped building block textured
# with assimp-testmodels' concrete wall (one mesh spanning more than ten cells), and
# the plaza's milk trucks, ducks, spiders and boxes (scripts/convert-textured-models.sh)
# standing on the terrain, assembled by scripts/build-terrain-scene.py. Read by
# manifests/terrain.ron; its walk is manifests/paths/terrain-walk.ron.
#
#   scripts/build-terrain-scene.sh [DEST]     (default: <repo>/models/terrain)
#
# Idempotent: does nothing when DEST/terrain.gltf exists. Network: only
# `apt-get download assimp-testmodels glmark2-data` (a Debian mirror), as
# fetch-models.sh.
set -euo pipefail

repo=$(cd "$(dirname "$0")/.." && pwd)
dest=${1:-$repo/models/terrain}
die() { echo "build-terrain-scene: $*" >&2; exit 1; }

if [ -f "$dest/terrain.gltf" ]; then
    echo "build-terrain-scene: $dest/terrain.gltf exists"
    exit 0
fi
command -v python3 >/dev/null 2>&1 || die "python3 is missing (apt-get install python3)"

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$repo/scripts/convert-textured-models.sh" "$work/src"
(cd "$work" && apt-get download glmark2-data >download.log 2>&1) || {
    cat "$work/download.log" >&2
    die "apt-get download glmark2-data failed: is a Debian package mirror reachable?"
}
dpkg-deb -x "$work"/glmark2-data_*.deb "$work/x"
cp "$work/x/usr/share/glmark2/textures/terrain-grasslight-512.jpg" "$work/src/textures/"
mkdir -p "$dest"
python3 "$repo/scripts/build-terrain-scene.py" "$work/src" "$dest"
