#!/usr/bin/env bash
# The "Scale" table of BENCHMARKS.md (issue 27): one cell of park-2m and the same
# cell in the centre tile of park-2m tiled 3 × 3 (world-18m) and 7 × 7
# (world-100m), baked with --cells (its job and every far-field group of its
# chain), then 16 views within 15 units of its centre compared with full geometry
# (player compare --reference-ss $REF_SS, default 1; 512²). Prints one JSON line per bake
# (scripts/scale-cell.py: bytes and bake ms with the groups amortised over their
# cells, triangles, draw calls, PSNR).
#   scripts/scale.sh [OUT] [--set key=value ...]   (binaries: $BIN or target/release)
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/scale}; shift || true
bin=${BIN:-target/release}
export WGPU_BACKEND=${WGPU_BACKEND:-vulkan}
mkdir -p "$out"
scenes=${SCENES:-"park-2m:275 world-18m:2409 world-100m:13013"}
for spec in $scenes; do
    spec=${spec/:/ }
    set -- $spec "$@"
    name=$1 cell=$2; shift 2
    dir="$out/$name"
    /usr/bin/time -f "%e s wall, %U s user, %S s sys, %M KB peak RSS" \
        "$bin/pipeline" run "manifests/$name.ron" --cells "$cell" --out "$dir" "$@" \
        >"$dir.bake.log" 2>&1
    "$bin/player" compare "$dir" --path "manifests/paths/$name-cell-$cell.ron" \
        --reference-ss "${REF_SS:-1}" --no-crossings --json >"$dir.compare.json" 2>"$dir.compare.log"
    echo "{\"scene\": \"$name\", \"cell\": $cell, \"bake\": \"$(tail -1 "$dir.bake.log")\", \"figures\": $(scripts/scale-cell.py "$dir" "$cell" "$dir.compare.json")}"
done
