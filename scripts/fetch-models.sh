#!/usr/bin/env bash
# Fetch the real meshes hexbake's park manifests and tests use, from Debian's
# packages only (`apt-get download`; no other network), into models/.
#
#   scripts/fetch-models.sh [DEST]     (default: <repo>/models)
#
# Idempotent: a model already present with the right checksum is left alone.
# Every output file is verified against scripts/models.sha256. Then builds the
# textured example scenes unless they are there: the plaza
# (scripts/build-textured-scene.sh, issue 18) into DEST/textured-plaza/ and the
# terrain (scripts/build-terrain-scene.sh, issue 29) into DEST/terrain/.
set -euo pipefail

repo=$(cd "$(dirname "$0")/.." && pwd)
dest=${1:-$repo/models}
sums=$repo/scripts/models.sha256
packages=(glmark2-data libcgal-demo assimp-testmodels assimp-utils)

die() { echo "fetch-models: $*" >&2; exit 1; }

verify() { (cd "$dest" && sha256sum --quiet -c "$sums" >/dev/null 2>&1); }

mkdir -p "$dest"
textured_scene() {
    "$repo/scripts/build-textured-scene.sh" "$dest/textured-plaza"
    "$repo/scripts/build-terrain-scene.sh" "$dest/terrain"
}

if [ -f "$sums" ] && verify; then
    echo "fetch-models: $dest is complete ($(wc -l <"$sums") files verified)"
    textured_scene
    exit 0
fi

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"

sudo_if() { if [ "$(id -u)" = 0 ]; then "$@"; else sudo "$@"; fi; }

# 1. Download the .deb files (no install). apt may need a fresh list first.
if ! apt-get download "${packages[@]}" >download.log 2>&1; then
    sudo_if apt-get update -qq >/dev/null 2>&1 || true
    apt-get download "${packages[@]}" >download.log 2>&1 || {
        cat download.log >&2
        die "apt-get download ${packages[*]} failed: is a Debian package mirror reachable? (see above)"
    }
fi
chmod -R a+r . 2>/dev/null || true
for deb in *.deb; do
    name=${deb%%_*}
    mkdir -p "x/$name"
    dpkg-deb -x "$deb" "x/$name"
done

# 2. The assimp CLI converts formats our loaders do not read (3DS). Its library
#    comes from the distribution; install it only when it is missing.
assimp_bin=$(command -v assimp || true)
if [ -z "$assimp_bin" ]; then
    sudo_if apt-get install -y -qq --no-install-recommends -o DPkg::Lock::Timeout=600 assimp-utils >/dev/null \
        || die "could not install assimp-utils (needed to convert the .3ds models)"
    assimp_bin=$(command -v assimp)
fi

glmark=x/glmark2-data/usr/share/glmark2/models
cgal=x/cgal/data/meshes
testm=x/assimp-testmodels/usr/share/assimp/models
mkdir -p x/cgal
tar xzf x/libcgal-demo/usr/share/doc/libcgal-dev/data.tar.gz -C x/cgal

# 3. Copy / convert into dest.
cp "$glmark/bunny.obj" "$dest/bunny.obj"
for m in horse cat asteroid-high; do
    "$assimp_bin" export "$glmark/$m.3ds" "$work/$m.obj" >/dev/null
    cp "$work/$m.obj" "$dest/$m.obj"
done
for m in refined_elephant armadillo diplodocus man camel ChineseDragon-10kv bunny00 bull lion; do
    cp "$cgal/$m.off" "$dest/$m.off"
done
cp "$cgal/pig.stl" "$dest/pig.stl"
cp "$testm/STL/Wuson.stl" "$dest/wuson.stl"
cp "$testm/PLY/Wuson.ply" "$dest/wuson.ply"
cp "$testm/PLY/cube_binary.ply" "$dest/cube_binary.ply"
cp "$testm/PLY/float-color.ply" "$dest/float-color.ply"
cp "$testm/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb" "$dest/2CylinderEngine.glb"
cp "$testm/glTF2/BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb" "$dest/BoxWithInfinites.glb"
mkdir -p "$dest/IndexOutOfRange"
cp "$testm/glTF2/IndexOutOfRange/"* "$dest/IndexOutOfRange/"
# CesiumMilkTruck ships as glTF 1.0; convert it to glTF 2.0 binary (several nodes).
"$assimp_bin" export "$testm/glTF/CesiumMilkTruck/CesiumMilkTruck.gltf" "$work/CesiumMilkTruck.glb" -f glb2 >/dev/null
cp "$work/CesiumMilkTruck.glb" "$dest/CesiumMilkTruck.glb"
# Its texture, which the GLB names by URI (read by `scene: Gltf(..)`, issue 18).
cp "$testm/glTF/CesiumMilkTruck/CesiumMilkTruck.png" "$dest/CesiumMilkTruck.png"

# 4. Verify.
if [ -f "$sums" ]; then
    verify || { (cd "$dest" && sha256sum -c "$sums" | grep -v ': OK$') >&2; die "checksum mismatch in $dest (see above)"; }
    echo "fetch-models: fetched and verified $(wc -l <"$sums") files into $dest"
else
    (cd "$dest" && find . -type f | sed 's|^\./||' | sort | xargs sha256sum) >"$sums"
    echo "fetch-models: wrote $sums (first run)"
fi
textured_scene
