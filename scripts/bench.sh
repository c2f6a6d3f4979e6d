#!/usr/bin/env bash
# scripts/bench.sh [--full]: re-run the paper's experiments (000 §4: Tables 3–8,
# Fig. 14) on hexbake and regenerate BENCHMARKS.md's measured tables (issue 8).
#
# Default run, sized for a 2-core machine: 68 min measured (BENCHMARKS.md, run
# 20261121T140328Z, with the 0.5 px deviation bound): park-2m and park-4m baked along
# the walk only (10–16 and 19 min, 104 cells each), 19 min player (1024², lavapipe),
# 15 min sweeps (9 settings × 5 cells, each baked and measured by the player), plus
# the release build. Per scene the player runs one compare (full, frustum and hybrid
# per frame, plus a no-prefetch pass), two renders, and on park-2m two lod compares.
# BENCH_SIZE=512x512 makes the player part ~2× faster (PSNR then differs a little).
#   1. scripts/fetch-models.sh; cargo build --release -p pipeline -p player -p hexbake-bench
#   2. bake the BENCH_FULL_SCENES fully (default none; --full: all three parks;
#      resumable: done jobs are skipped)
#   3. bake park-2m and park-4m along park-walk.ron only (--cells path:...: the
#      path's cells and their neighbours, so the player's prefetcher finds packs);
#      their per-cell tables are then averages over those cells (the report says
#      "partial: X of Y cells")
#   4. player compare (hybrid vs full) + player render --mode frustum|hybrid along
#      park-walk.ron on each, and player compare --mode lod on park-2m (recorded as
#      "lod: not available" when the player has no lod mode)
#   5. sweeps on park-4m over a fixed sample of cells (one job per cell):
#      T_s ∈ {3,5,7} (Table 3), T_l ∈ {3.0,4.5,6.0} (Table 4), cell size ∈ {50,100}
#      (Table 5); the sample is cells 275 (centre), 264 and 517 (edges), 0 and 527
#      (corners) of the 50-unit grid, mapped by position onto other grids (grid:50:ID);
#      each setting's bake is then measured by `player compare` over `worker check`'s
#      16 viewpoints in each sampled cell (`hexbake-bench views`): the FPS, PSNR
#      and triangles rows of Tables 3–5; and our deviation bound (not in the paper)
#      bake.max_deviation_px ∈ {0 (the paper's algorithm), 0.5, 1, 2}
#   6. cell load times; one JSON of raw results in docs/bench/run-<UTC time>.json
#      (machine, commands, reports, player output); BENCHMARKS.md regenerated between
#      its <!-- bench:NAME --> markers, plots in docs/bench/.
# --full also bakes park-4m and park-8m fully and runs the player on them (hours).
#
# Environment overrides (for trying the script on small inputs, e.g.
#   BENCH_FULL_SCENES=demo BENCH_PATH_SCENES=tiny BENCH_PATH=manifests/paths/demo-walk.ron ...):
#   BENCH_FULL_SCENES   scenes baked fully            (default none; --full: park-2m park-4m park-8m)
#   BENCH_PATH_SCENES   scenes baked along the path   (default park-2m park-4m; --full: none)
#   BENCH_MANIFESTS     folder of <scene>.ron          (default manifests; a scene may also be a path to a .ron)
#   BENCH_PATH          camera path                   (default manifests/paths/park-walk.ron)
#   BENCH_SWEEP_SCENE   scene of the sweeps           (default park-4m; empty: no sweeps)
#   BENCH_SAMPLE        sample cell ids               (default 275,264,517,0,527)
#   BENCH_SAMPLE_GRID   cell size the ids refer to    (default 50)
#   BENCH_SWEEP_VIEWS   player views per sampled cell (default 16; 0: no sweep compares)
#   BENCH_TS / BENCH_TL / BENCH_CELL_SIZES            (defaults "3 5 7" / "3.0 4.5 6.0" / "50 100")
#   BENCH_BASE_TS / BENCH_BASE_TL / BENCH_BASE_CELL   the manifest's values (5 / 4.5 / 50)
#   BENCH_DEVIATIONS / BENCH_BASE_DEV                 (defaults "0 0.5 1 2" / the manifest's 0.5)
#   BENCH_OUT           bake outputs: $BENCH_OUT/<scene> (default out)
#   BENCH_RESULTS       run files and plots            (default docs/bench)
#   BENCH_DOC           document to regenerate         (default docs/bench/paper.md)
#   BENCH_SIZE          player frame size, e.g. 512x512 (default: the path's, 1024²)
#   BENCH_LOD_ERRORS    --lod-pixel-error values for the lod baseline (default "1 4";
#                       --full "0.0625 0.125 0.25 0.5 1 2 4"; "default": the player's
#                       default only). Two or more points that bracket the hybrid give
#                       the comparison at equal triangles and at equal PSNR.
#   BENCH_LOD_SCENES    scenes the lod baseline runs on (default: the first scene,
#                       park-2m; --full: every scene)
#   BENCH_THREADS       pipeline --threads             (default: all cores)
#   BENCH_FETCH=0       skip scripts/fetch-models.sh (procedural scenes)
#   BENCH_BUILD=0       skip the release build (binaries must exist)
#   BENCH_BAKE=0        skip every bake (outputs must exist): a player-only run whose
#                       tables take the bakes from earlier run files
#   BENCH_BIN_DIR       where pipeline, player and hexbake-bench are
#                       (default $CARGO_TARGET_DIR/release or target/release)
#
# The tables, plots, run files, cell load timing and the sweeps' view paths are
# hexbake-bench's (bench/, beside the product). The labels of the work files
# (bake-<label>.txt, compare-<label>.txt, ...), the sweep parameters and their
# `sweep=PARAM:VALUE` lines are a contract with it, defined once in
# bench/src/labels.rs (RunLabel, SweepParam) and checked against this script by
# bench/tests/bench_sh_contract.rs.
set -uo pipefail

cd "$(dirname "$0")/.."

FULL=0
for arg in "$@"; do
    case "$arg" in
        --full) FULL=1 ;;
        -h | --help)
            sed -n '2,/^set -uo/p' "$0" | sed '$d' | sed 's/^# \{0,1\}//'
            exit 0
            ;;
        *)
            echo "bench.sh: unknown argument $arg (usage: scripts/bench.sh [--full])" >&2
            exit 2
            ;;
    esac
done

if [ "$FULL" = 1 ]; then
    : "${BENCH_FULL_SCENES:=park-2m park-4m park-8m}"
    : "${BENCH_PATH_SCENES:=}"
    : "${BENCH_LOD_ERRORS:=0.0625 0.125 0.25 0.5 1 2 4}"
    : "${BENCH_LOD_SCENES:=park-2m park-4m park-8m}"
    MODE=full
else
    : "${BENCH_FULL_SCENES=}"
    : "${BENCH_PATH_SCENES=park-2m park-4m}"
    : "${BENCH_LOD_ERRORS:=1 4}"
    MODE=default
fi
: "${BENCH_MANIFESTS:=manifests}"
: "${BENCH_PATH:=manifests/paths/park-walk.ron}"
: "${BENCH_SWEEP_SCENE=park-4m}"
: "${BENCH_SAMPLE:=275,264,517,0,527}"
: "${BENCH_SAMPLE_GRID:=50}"
: "${BENCH_SWEEP_VIEWS:=16}"
: "${BENCH_TS:=3 5 7}"
: "${BENCH_TL:=3.0 4.5 6.0}"
: "${BENCH_CELL_SIZES:=50 100}"
: "${BENCH_BASE_TS:=5}"
: "${BENCH_BASE_TL:=4.5}"
: "${BENCH_BASE_CELL:=50}"
: "${BENCH_DEVIATIONS:=0 0.5 1 2}"
: "${BENCH_BASE_DEV:=0.5}"
: "${BENCH_OUT:=out}"
: "${BENCH_RESULTS:=docs/bench}"
: "${BENCH_DOC:=docs/bench/paper.md}"
: "${BENCH_SIZE:=}"
: "${BENCH_THREADS:=}"
: "${BENCH_FETCH:=1}"
: "${BENCH_BUILD:=1}"
: "${BENCH_BAKE:=1}"
[ -n "${BENCH_MODE:-}" ] && MODE=$BENCH_MODE

if [ -z "${BENCH_LOD_SCENES+x}" ]; then
    for first in $BENCH_FULL_SCENES $BENCH_PATH_SCENES; do break; done
    BENCH_LOD_SCENES=$(basename "${first:-park-2m}" .ron)
fi

BIN_DIR=${BENCH_BIN_DIR:-${CARGO_TARGET_DIR:-target}/release}
PIPELINE=$BIN_DIR/pipeline
PLAYER=$BIN_DIR/player
BENCH=$BIN_DIR/hexbake-bench
RUN_ID=$(date -u +%Y%m%dT%H%M%SZ)
WORK=$BENCH_OUT/bench-work/$RUN_ID
mkdir -p "$WORK" "$BENCH_RESULTS"
FAILED=()

say() { printf '\n== %s\n' "$*" >&2; }

# logged OUT ERR CMD...: runs CMD with stdout to OUT and stderr to ERR ("-": the
# terminal), appends "wall_s<TAB>exit<TAB>command" to commands.tsv, sets WALL and RC.
logged() {
    local out=$1 err=$2
    shift 2
    local start end
    start=$(date +%s.%N)
    printf '+ %s\n' "$*" >&2
    if [ "$out" = - ] && [ "$err" = - ]; then
        "$@"
    elif [ "$out" = - ]; then
        "$@" 2>"$err"
    elif [ "$err" = - ]; then
        "$@" >"$out"
    else
        "$@" >"$out" 2>"$err"
    fi
    RC=$?
    end=$(date +%s.%N)
    WALL=$(awk -v a="$start" -v b="$end" 'BEGIN { printf "%.3f", b - a }')
    printf '%s\t%s\t%s\n' "$WALL" "$RC" "$*" >>"$WORK/commands.tsv"
    return 0
}

manifest_of() { # scene name or .ron path → manifest path
    case "$1" in
        *.ron) echo "$1" ;;
        *) echo "$BENCH_MANIFESTS/$1.ron" ;;
    esac
}
scene_of() { basename "$1" .ron; }

# 0. Machine.
{
    echo "run=$RUN_ID"
    echo "mode=$MODE"
    echo "date=$(date -u +%Y-%m-%dT%H:%M:%SZ)"
    echo "git_commit=$(git rev-parse --short=12 HEAD 2>/dev/null || echo unknown)$(git diff --quiet HEAD 2>/dev/null || echo '+dirty')"
    echo "nproc=$(nproc)"
    echo "cpu_model=$(grep -m1 'model name' /proc/cpuinfo 2>/dev/null | cut -d: -f2- | sed 's/^ *//' || echo unknown)"
    echo "memory=$(awk '/MemTotal/ { printf "%.0f GiB", $2 / 1048576 }' /proc/meminfo 2>/dev/null)"
    echo "os=$( (. /etc/os-release 2>/dev/null && echo "$PRETTY_NAME") || uname -sr)"
    echo "kernel=$(uname -r)"
    echo "rustc=$(rustc --version 2>/dev/null || echo unknown)"
    echo "load_average_at_start=$(cut -d' ' -f1-3 /proc/loadavg 2>/dev/null)"
    echo "player_size=${BENCH_SIZE:-path default}"
} >"$WORK/meta.txt"
say "bench run $RUN_ID ($MODE): work folder $WORK"

# 1. Models and binaries.
if [ "$BENCH_FETCH" = 1 ]; then
    say "fetching models"
    logged - - scripts/fetch-models.sh
    [ "$RC" = 0 ] || { echo "bench.sh: fetch-models failed" >&2; exit 1; }
fi
if [ "$BENCH_BUILD" = 1 ]; then
    say "building release binaries"
    logged - - cargo build --release -p pipeline -p player -p hexbake-bench
    [ "$RC" = 0 ] || { echo "bench.sh: build failed" >&2; exit 1; }
fi

THREADS=()
[ -n "$BENCH_THREADS" ] && THREADS=(--threads "$BENCH_THREADS")
SIZE=()
[ -n "$BENCH_SIZE" ] && SIZE=(--size "$BENCH_SIZE")

# bake LABEL SCENE OUT [pipeline run args...]: one `pipeline run`, recorded in
# bake-LABEL.txt (extra "key=value" lines come from the BAKE_META array).
BAKE_META=()
bake() {
    local label=$1 scene=$2 out=$3
    shift 3
    local manifest
    manifest=$(manifest_of "$scene")
    if [ "$BENCH_BAKE" = 0 ]; then
        say "bake $label: skipped (BENCH_BAKE=0), using $out"
        BAKE_META=()
        return
    fi
    say "bake $label: $manifest → $out $*"
    logged - - "$PIPELINE" run "$manifest" --out "$out" "${THREADS[@]}" "$@"
    {
        echo "label=$label"
        echo "scene=$(scene_of "$manifest")"
        echo "manifest=$manifest"
        echo "out=$out"
        echo "wall_s=$WALL"
        echo "exit=$RC"
        local prev=""
        for a in "$@"; do
            [ "$prev" = --cells ] && echo "cells=$a"
            [ "$prev" = --set ] && echo "set=$a"
            prev=$a
        done
        for m in "${BAKE_META[@]}"; do echo "$m"; done
    } >"$WORK/bake-$label.txt"
    BAKE_META=()
    [ "$RC" = 0 ] || FAILED+=("bake $label (exit $RC)")
}

# player_runs SCENE OUT: compare (hybrid, lod) and render (frustum, hybrid).
player_runs() {
    local scene=$1 out=$2
    if [ ! -f "$out/index.pack" ]; then
        FAILED+=("player on $scene: no index.pack in $out")
        return
    fi
    local meta="scene=$scene
out=$out
path=$BENCH_PATH
size=${BENCH_SIZE:-path default}"
    say "player compare $scene (hybrid vs full, frustum timing, prefetch on/off)"
    logged "$WORK/compare-$scene-hybrid.json" "$WORK/compare-$scene-hybrid.err" \
        "$PLAYER" compare "$out" --path "$BENCH_PATH" --json "${SIZE[@]}"
    printf 'label=%s\nmode=hybrid\n%s\nwall_s=%s\nexit=%s\n' "$scene-hybrid" "$meta" "$WALL" "$RC" \
        >"$WORK/compare-$scene-hybrid.txt"
    [ "$RC" = 0 ] || FAILED+=("player compare $scene (exit $RC, see $WORK/compare-$scene-hybrid.err)")

    for mode in frustum hybrid; do
        say "player render $scene --mode $mode"
        logged /dev/null "$WORK/render-$scene-$mode.err" \
            "$PLAYER" render "$out" --path "$BENCH_PATH" --frames "$WORK/render-$scene-$mode" --mode "$mode" "${SIZE[@]}"
        printf 'label=%s\nmode=%s\n%s\nwall_s=%s\nexit=%s\n' "$scene-$mode" "$mode" "$meta" "$WALL" "$RC" \
            >"$WORK/render-$scene-$mode.txt"
        [ "$RC" = 0 ] || FAILED+=("player render $scene $mode (exit $RC)")
    done

    # The distance-LOD baseline, at the player's default --lod-pixel-error or at each
    # of BENCH_LOD_ERRORS (more points let the tables compare at equal triangles and
    # at equal PSNR).
    local errs=${BENCH_LOD_ERRORS:-default}
    case " $BENCH_LOD_SCENES " in
        *" $scene "*) ;;
        *) errs="" ;;
    esac
    for e in $errs; do
        local label=$scene-lod extra=()
        if [ "$e" != default ]; then
            label=$scene-lod-e$e
            extra=(--lod-pixel-error "$e")
        fi
        say "player compare $scene --mode lod ${extra[*]} (distance-LOD baseline)"
        logged "$WORK/compare-$label.json" "$WORK/compare-$label.err" \
            "$PLAYER" compare "$out" --path "$BENCH_PATH" --json --mode lod --no-crossings "${extra[@]}" "${SIZE[@]}"
        local note=""
        if [ "$RC" != 0 ]; then
            if grep -qiE "unexpected argument|unknown mode|invalid value|unrecognized" "$WORK/compare-$label.err"; then
                note="lod: not available (this player has no --mode lod for compare)"
                echo "bench.sh: $note" >&2
            else
                FAILED+=("player compare $scene --mode lod $e (exit $RC)")
            fi
        fi
        printf 'label=%s\nmode=lod\n%s\nwall_s=%s\nexit=%s\nnote=%s\n' "$label" "$meta" "$WALL" "$RC" "$note" \
            >"$WORK/compare-$label.txt"
        [ "$e" != default ] && echo "lod_pixel_error=$e" >>"$WORK/compare-$label.txt"
        [ -n "$note" ] && break
    done

    say "cell load times $scene"
    logged "$WORK/load-$scene.json" "$WORK/load-$scene.err" "$BENCH" load "$out" --label "$scene"
    [ "$RC" = 0 ] || rm -f "$WORK/load-$scene.json"
}

# sweep_compare LABEL OUT: `player compare` of a sweep bake over `worker check`'s
# viewpoints in its sampled cells (Tables 3–5: FPS, PSNR, triangles in the frustum).
# Every texture is uploaded before its frame (a 1 GiB budget): the views jump between
# cells, and pending proxies drawn as originals would measure the streaming instead.
sweep_compare() {
    local label=$1 out=$2
    [ "$BENCH_SWEEP_VIEWS" -gt 0 ] 2>/dev/null || return 0
    if [ ! -f "$out/index.pack" ]; then
        FAILED+=("sweep compare $label: no index.pack in $out")
        return
    fi
    say "player compare $label over $BENCH_SWEEP_VIEWS views per sampled cell"
    logged - "$WORK/views-$label.err" \
        "$BENCH" views "$out" --per-cell "$BENCH_SWEEP_VIEWS" --path "$out/views.ron"
    if [ "$RC" != 0 ]; then
        FAILED+=("hexbake-bench views $label (exit $RC, see $WORK/views-$label.err)")
        return
    fi
    logged "$WORK/compare-$label.json" "$WORK/compare-$label.err" \
        "$PLAYER" compare "$out" --path "$out/views.ron" --json --no-crossings \
        --upload-budget-mib 1024 "${SIZE[@]}"
    printf 'label=%s\nmode=hybrid\nscene=%s\nout=%s\npath=%s\nsize=%s\nwall_s=%s\nexit=%s\n' \
        "$label" "$sweep_name" "$out" "$out/views.ron" "${BENCH_SIZE:-path default}" "$WALL" "$RC" \
        >"$WORK/compare-$label.txt"
    [ "$RC" = 0 ] || FAILED+=("player compare $label (exit $RC, see $WORK/compare-$label.err)")
}

# 2–3. Bakes at the paper's settings.
for scene in $BENCH_FULL_SCENES; do
    name=$(scene_of "$(manifest_of "$scene")")
    bake "$name" "$scene" "$BENCH_OUT/$name"
done
for scene in $BENCH_PATH_SCENES; do
    name=$(scene_of "$(manifest_of "$scene")")
    bake "$name-path" "$scene" "$BENCH_OUT/$name" --cells "path:$BENCH_PATH"
done

# 4. Player along the path.
for scene in $BENCH_FULL_SCENES $BENCH_PATH_SCENES; do
    name=$(scene_of "$(manifest_of "$scene")")
    player_runs "$name" "$BENCH_OUT/$name"
done

# 5. Sweeps (Tables 3–5) over the fixed cell sample, one job per cell.
if [ -n "$BENCH_SWEEP_SCENE" ]; then
    sweep_name=$(scene_of "$(manifest_of "$BENCH_SWEEP_SCENE")")
    spec=$(echo "$BENCH_SAMPLE" | tr ',' '\n' | sed "s/^ *//; s/^/grid:$BENCH_SAMPLE_GRID:/" | paste -sd, -)
    sweep_out=$BENCH_OUT/bench-sweeps/$sweep_name
    # The base setting is a point of every sweep.
    BAKE_META=("sweep=T_s:$BENCH_BASE_TS" "sweep=T_l:$BENCH_BASE_TL" "sweep=cell_size:$BENCH_BASE_CELL"
        "sweep=deviation:$BENCH_BASE_DEV")
    bake sweep-base "$BENCH_SWEEP_SCENE" "$sweep_out/base" --cells "$spec" --set cells_per_job=1
    sweep_compare sweep-base "$sweep_out/base"
    # sweep_points PARAM LABEL-PREFIX SET-KEY BASE VALUES...: one bake + compare per
    # value other than the base.
    sweep_points() {
        local param=$1 prefix=$2 key=$3 base=$4 v
        shift 4
        for v in "$@"; do
            [ "$v" = "$base" ] && continue
            BAKE_META=("sweep=$param:$v")
            bake "sweep-$prefix$v" "$BENCH_SWEEP_SCENE" "$sweep_out/$prefix$v" --cells "$spec" \
                --set cells_per_job=1 --set "$key=$v"
            sweep_compare "sweep-$prefix$v" "$sweep_out/$prefix$v"
        done
    }
    # shellcheck disable=SC2086 # the value lists split on spaces
    sweep_points T_s ts T_s "$BENCH_BASE_TS" $BENCH_TS
    # shellcheck disable=SC2086
    sweep_points T_l tl T_l "$BENCH_BASE_TL" $BENCH_TL
    # shellcheck disable=SC2086
    sweep_points cell_size c cells.cell_size "$BENCH_BASE_CELL" $BENCH_CELL_SIZES
    # shellcheck disable=SC2086
    sweep_points deviation dev bake.max_deviation_px "$BENCH_BASE_DEV" $BENCH_DEVIATIONS
fi

# 6. Results and tables.
RESULT=$BENCH_RESULTS/run-$RUN_ID.json
say "collecting $RESULT"
"$BENCH" collect "$WORK" --out "$RESULT" || FAILED+=("collect")
say "regenerating $BENCH_DOC"
"$BENCH" tables --results "$BENCH_RESULTS" --write "$BENCH_DOC" \
    --plot-prefix "$(realpath --relative-to "$(dirname "$BENCH_DOC")" "$BENCH_RESULTS")" || FAILED+=("tables")

if [ "${#FAILED[@]}" -gt 0 ]; then
    printf '\nbench.sh: finished with failures:\n' >&2
    printf '  - %s\n' "${FAILED[@]}" >&2
    exit 1
fi
printf '\nbench.sh: done: %s, %s regenerated\n' "$RESULT" "$BENCH_DOC" >&2
