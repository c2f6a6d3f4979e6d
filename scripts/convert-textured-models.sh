#!/usr/bin/env bash
# Convert the textured models of Debian's assimp-testmodels that hexbake's example
# scenes place (issues 18 and 29) to glTF 2.0 with the assimp CLI (assimp-utils):
# the Cesium milk truck, the Collada duck, the OBJ spider and the glTF sample box.
# Used by scripts/build-textured-scene.sh and scripts/build-terrain-scene.sh.
#
#   scripts/convert-textured-models.sh SRC
#
# Writes SRC/truck, SRC/duck, SRC/spider and SRC/box (each a .gltf with its .bin
# and textures), and SRC/textures/CWALL02.jpg (a concrete wall, the terrain scene's
# building). Network: only `apt-get download assimp-testmodels` (a Debian mirror).
set -euo pipefail

src=${1:?usage: convert-textured-models.sh SRC}
die() { echo "convert-textured-models: $*" >&2; exit 1; }
command -v assimp >/dev/null 2>&1 || die "the assimp CLI is missing (apt-get install assimp-utils)"

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
(cd "$work" && apt-get download assimp-testmodels >download.log 2>&1) || {
    cat "$work/download.log" >&2
    die "apt-get download assimp-testmodels failed: is a Debian package mirror reachable?"
}
dpkg-deb -x "$work"/assimp-testmodels_*.deb "$work/x"
m=$work/x/usr/share/assimp/models
mkdir -p "$src"/truck "$src"/duck "$src"/spider "$src"/box "$src"/textures

# assimp writes glTF 2.0 with external .bin buffers; textures keep their file names.
convert() { # convert SRC_FILE DEST_DIR NAME.gltf, then copy the listed textures.
    local in=$1 dir=$2 name=$3
    shift 3
    assimp export "$in" "$src/$dir/$name" -f gltf2 >"$work/$dir.log" 2>&1 ||
        { cat "$work/$dir.log" >&2; die "assimp could not convert $in"; }
    for t in "$@"; do cp "$t" "$src/$dir/"; done
}
convert "$m/glTF/CesiumMilkTruck/CesiumMilkTruck.gltf" truck CesiumMilkTruck.gltf \
    "$m/glTF/CesiumMilkTruck/CesiumMilkTruck.png"
convert "$m/Collada/duck.dae" duck duck.gltf "$m/Collada/duckCM.tga"
convert "$m/OBJ/spider.obj" spider spider.gltf "$m"/OBJ/*.jpg
# The box is glTF 2.0 already.
cp "$m/glTF2/BoxTextured-glTF/"* "$src/box/"
cp "$m/3DS/CWALL02.jpg" "$src/textures/"
