#!/usr/bin/env bash
# Fuzz the pack readers (issue 5; STYLE.md habit 5).
#
#   scripts/fuzz.sh SECONDS          run each target for SECONDS seconds
#   scripts/fuzz.sh --build-only     only build the targets
#
# With `cargo fuzz` and a nightly toolchain: runs the libFuzzer targets of fuzz/
# (pack_base, pack_cell, pack_index, seeded with the golden packs of tests/data/;
# gltf_scene, the glTF scene reader of issue 18, seeded with the textured sample
# scene of scene::load::gltf_sample; gltf_graph, structure-aware (issue 32): the
# bytes spell a node graph, scene::load::gltf_sample::node_graph, whose verdict the
# reader must reach).
# Otherwise (no nightly or no cargo-fuzz; fuzz/ is then not built), the stable fallback driver
# (format/examples/fuzz_packs.rs: seeded random mutations of the sample packs,
# checksums resealed half the time) runs for SECONDS per target-equivalent instead,
# and format/scene/examples/fuzz_gltf.rs (mutations of the sample glTF scene, JSON and GLB)
# for SECONDS, then its graph mode (random node graphs against their verdicts) for
# SECONDS.
# Exit status: non-zero on any crash/panic or build failure.
set -euo pipefail

repo=$(cd "$(dirname "$0")/.." && pwd)
cd "$repo"
arg=${1:-60}
targets=(pack_base pack_cell pack_index gltf_scene gltf_graph)

have_cargo_fuzz() {
    command -v cargo-fuzz >/dev/null 2>&1 || cargo fuzz --version >/dev/null 2>&1
}
have_nightly() {
    command -v rustup >/dev/null 2>&1 && rustup toolchain list 2>/dev/null | grep -q '^nightly'
}

if have_cargo_fuzz && have_nightly; then
    echo "fuzz.sh: cargo fuzz + nightly available: libFuzzer targets"
    (cd fuzz && cargo +nightly fuzz build)
    if [ "$arg" = "--build-only" ]; then
        exit 0
    fi
    for t in "${targets[@]}"; do
        corpus=fuzz/corpus/$t
        mkdir -p "$corpus"
        if [ "$t" = gltf_scene ]; then
            cargo run -q -p scene --example write_gltf_sample -- "$corpus" >/dev/null
        elif [ "$t" = gltf_graph ]; then
            : # any bytes spell a graph: libFuzzer starts from nothing
        else
            cp tests/data/*.pack "$corpus"/
        fi
        echo "fuzz.sh: $t for $arg s"
        (cd fuzz && cargo +nightly fuzz run "$t" "corpus/$t" -- -max_total_time="$arg" -max_len=65536 2>&1) |
            tee "/tmp/hexbake-fuzz-$t.log" | grep -E '^(#[0-9]+[[:space:]]+(DONE|INITED)|Done|==[0-9]+==|SUMMARY|artifact)' || true
        # libFuzzer's final line: "Done N runs in S second(s)".
        grep -E '^Done [0-9]+ runs' "/tmp/hexbake-fuzz-$t.log" || { echo "fuzz.sh: $t did not finish cleanly"; exit 1; }
    done
else
    echo "fuzz.sh: cargo fuzz or nightly missing: stable fallback driver (format/examples/fuzz_packs.rs)"
    cargo build -q -p format --example fuzz_packs && cargo build -q -p scene --example fuzz_gltf
    if [ "$arg" = "--build-only" ]; then
        exit 0
    fi
    for i in 0 1 2; do
        cargo run -q -p format --example fuzz_packs -- "$arg" "$((i + 1))"
    done
    cargo run -q -p scene --example fuzz_gltf -- "$arg" 1
    cargo run -q -p scene --example fuzz_gltf -- "$arg" 1 graph
fi
