#!/usr/bin/env bash
# Build hexbake's textured example scene (issue 18 item 2) from Debian's
# assimp-testmodels: the Cesium milk truck, the Collada duck, the OBJ spider and the
# glTF sample box, converted to glTF 2.0 with the assimp CLI (assimp-utils) and
# placed on a plaza by scripts/build-textured-scene.py. Read by
# manifests/textured-plaza.ron.
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
command -v assimp >/dev/null 2>&1 || die "the assimp CLI is missing (apt-get install assimp-utils)"
command -v python3 >/dev/null 2>&1 || die "python3 is missing (apt-get install python3)"

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
if ! apt-get download assimp-testmodels >download.log 2>&1; then
    cat download.log >&2
    die "apt-get download assimp-testmodels failed: is a Debian package mirror reachable?"
fi
dpkg-deb -x assimp-testmodels_*.deb x
m=x/usr/share/assimp/models
mkdir -p src/truck src/duck src/spider src/box

# assimp writes glTF 2.0 with external .bin buffers; textures keep their file names.
convert() { # convert SRC_FILE DEST_DIR NAME.gltf, then copy the listed textures.
    local in=$1 dir=$2 name=$3
    shift 3
    assimp export "$in" "src/$dir/$name" -f gltf2 >"src/$dir.log" 2>&1 ||
        { cat "src/$dir.log" >&2; die "assimp could not convert $in"; }
    for t in "$@"; do cp "$t" "src/$dir/"; done
}
convert "$m/glTF/CesiumMilkTruck/CesiumMilkTruck.gltf" truck CesiumMilkTruck.gltf \
    "$m/glTF/CesiumMilkTruck/CesiumMilkTruck.png"
convert "$m/Collada/duck.dae" duck duck.gltf "$m/Collada/duckCM.tga"
convert "$m/OBJ/spider.obj" spider spider.gltf "$m"/OBJ/*.jpg
# The box is glTF 2.0 already.
cp "$m/glTF2/BoxTextured-glTF/"* src/box/

mkdir -p "$dest"
python3 "$repo/scripts/build-textured-scene.py" src "$dest"
