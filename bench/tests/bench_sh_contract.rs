//! The labels and sweep parameters `scripts/bench.sh` writes are the ones
//! `hexbake_bench::labels` defines (issue 14: one typed definition of the contract,
//! not format strings on both sides). Each label form is written with shell
//! variables for its parts and must appear in the script as such.

use hexbake_bench::labels::{RunLabel, SweepParam};

fn script() -> String {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../scripts/bench.sh");
    std::fs::read_to_string(path).unwrap()
}

fn assert_in(script: &str, needle: &str) {
    assert!(script.contains(needle), "scripts/bench.sh lacks {needle:?}");
}

#[test]
fn bench_sh_writes_the_labels_the_tool_reads() {
    let s = script();
    // Bakes: a whole scene and a scene along the path.
    assert_in(&s, &format!("bake \"{}\" ", RunLabel::Scene("$name")));
    assert_in(&s, &format!("bake \"{}\" ", RunLabel::PathBake("$name")));
    // The hybrid compare, the renders of both modes, the load timing.
    let hybrid = RunLabel::Hybrid("$scene").to_string();
    assert_in(&s, &format!("\"$WORK/compare-{hybrid}.json\""));
    assert_in(&s, &format!("\"{hybrid}\" \"$meta\""));
    assert_eq!(RunLabel::Frustum("$scene").to_string(), "$scene-frustum");
    assert_in(&s, "for mode in frustum hybrid; do");
    assert_in(&s, "\"$scene-$mode\" \"$mode\"");
    assert_in(
        &s,
        &format!("load \"$out\" --label \"{}\"", RunLabel::Scene("$scene")),
    );
    // The lod baseline, at the player's default and at each BENCH_LOD_ERRORS value.
    let lod = |e| RunLabel::Lod {
        scene: "$scene",
        pixel_error: e,
    };
    assert_in(&s, &format!("local label={} extra=()", lod(None)));
    assert_in(&s, &format!("label={}\n", lod(Some("$e"))));
    // Sweeps: the base bake, a point of every sweep, and one bake per other value.
    assert_in(&s, &format!("bake {} ", RunLabel::SweepBase));
    for p in SweepParam::ALL {
        assert_in(&s, &format!("\"sweep={}:$BENCH_BASE_", p.key()));
        assert_in(
            &s,
            &format!(
                "sweep_points {} {} {} ",
                p.key(),
                p.label_prefix(),
                p.set_key()
            ),
        );
        let point = RunLabel::SweepPoint {
            param: p,
            value: "$v",
        };
        assert_eq!(point.to_string(), format!("sweep-{}$v", p.label_prefix()));
    }
    assert_in(&s, "bake \"sweep-$prefix$v\" ");
    assert_in(&s, "BAKE_META=(\"sweep=$param:$v\")");
}

#[test]
fn bench_sh_calls_the_bench_tool_not_the_pipeline() {
    let s = script();
    assert!(
        !s.contains("benchmarks "),
        "old `pipeline benchmarks` call left"
    );
    for cmd in ["load", "views", "collect", "tables"] {
        assert_in(&s, &format!("\"$BENCH\" {cmd} "));
    }
    assert_in(
        &s,
        "cargo build --release -p pipeline -p player -p hexbake-bench",
    );
}
