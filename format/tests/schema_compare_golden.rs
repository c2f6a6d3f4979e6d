//! Golden files of `player compare --json` (`format::schema::compare`, issue 14
//! item 2): real player output on the textured plaza along textured-walk.ron at
//! 32 × 32 on lavapipe (`data/schema/compare.json`: hybrid with the 4 × 4
//! anti-aliased reference and both crossing passes; `compare-lod.json`: `--mode lod
//! --lod-pixel-error 0.1 --no-crossings --reference-ss 1`), `per_frame` cut to two
//! frames (0, and one without object pixels) and, in compare.json, the no-prefetch
//! crossing ratio set to `null` (what the player writes for a NaN). Each file reads
//! and writes back line for line (same keys in the same order, the same nulls; a
//! number may move by an ulp: serde_json's default parser is not exactly rounding),
//! and its fields land where the readers look.

use format::schema::compare::CompareReport;
use std::path::PathBuf;

fn golden(name: &str) -> (String, CompareReport) {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/schema")
        .join(name);
    let text = std::fs::read_to_string(&path).unwrap();
    let report: CompareReport =
        serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    (text, report)
}

/// Writes `report` as the player does and checks it against the golden text line by
/// line: equal, or the same key with numbers within 1e-14 relative.
fn assert_writes_back(report: &CompareReport, golden: &str) {
    let text = serde_json::to_string_pretty(report).unwrap() + "\n";
    let (got, want): (Vec<&str>, Vec<&str>) = (text.lines().collect(), golden.lines().collect());
    assert_eq!(got.len(), want.len(), "written:\n{text}");
    for (g, w) in got.iter().zip(&want) {
        if g == w {
            continue;
        }
        let number = |line: &str| -> Option<(String, f64)> {
            let (key, value) = line.split_once(": ")?;
            Some((key.to_string(), value.trim_end_matches(',').parse().ok()?))
        };
        match (number(g), number(w)) {
            (Some((kg, vg)), Some((kw, vw))) if kg == kw && (vg - vw).abs() <= 1e-14 * vw.abs() => {
            }
            _ => panic!("written {g:?}, golden {w:?}"),
        }
    }
}

#[test]
fn hybrid_compare_round_trips_byte_for_byte() {
    let (text, r) = golden("compare.json");
    assert_writes_back(&r, &text);
    // Full-frame, object-pixel (flattened) and anti-aliased figures.
    assert_eq!(r.frames, 290);
    assert_eq!(r.mean_psnr_y, 51.78158214138234);
    assert_eq!(r.object.object_psnr_y_db, 23.60528752824875);
    assert_eq!(r.object.worst_object_frame, Some(143));
    assert_eq!(r.object.object_pixel_fraction, 0.09614089439655173);
    let aa = r.aa_reference.as_ref().expect("aa_reference");
    assert_eq!((aa.supersampling_factor, aa.samples_per_pixel), (4, 16));
    assert_eq!(aa.compared.mean_psnr_y_db, 30.93381390525649);
    assert_eq!(aa.full.object.worst_object_frame, Some(219));
    assert_eq!(r.reference_triangles, 111120.0);
    assert_eq!((r.width, r.height, r.mode.as_str()), (32, 32, "hybrid"));
    assert_eq!((r.lod_pixel_error, r.lod_build_ms), (None, None));
    let on = r.crossing_prefetch.as_ref().unwrap();
    assert_eq!((on.crossings, on.in_cell_median_ms), (12, 1.028104));
    let off = r.crossing_no_prefetch.as_ref().unwrap();
    assert!(off.ratio.is_nan(), "null reads as NaN");
    // Per frame: a frame with object pixels and one without.
    assert_eq!(r.per_frame.len(), 2);
    let (f0, f92) = (&r.per_frame[0], &r.per_frame[1]);
    assert_eq!((f0.frame, f92.frame, f92.cell), (0, 92, Some(11)));
    assert!(f0.object_psnr_y_db.is_some() && f0.aa_reference.is_some());
    assert_eq!((f92.object_pixels, f92.object_psnr_y_db), (0, None));
    let aa0 = f0.aa_reference.as_ref().unwrap();
    assert!(aa0.compared.psnr_y_db > 0.0 && aa0.full.ssim > 0.0);
}

#[test]
fn lod_compare_round_trips_with_its_f32_threshold() {
    let (text, r) = golden("compare-lod.json");
    assert_writes_back(&r, &text);
    assert_eq!(r.mode, "lod");
    // The player's threshold is an f32: 0.1 is written and read as 0.1f32.
    assert_eq!(r.lod_pixel_error, Some(0.1f32));
    assert!(text.contains("\"lod_pixel_error\": 0.1,"), "{text}");
    assert!((r.lod_build_ms.unwrap() - 91.190048).abs() < 1e-9);
    assert!(r.aa_reference.is_none() && r.crossing_no_prefetch.is_none());
    assert!(r.per_frame.iter().all(|f| f.aa_reference.is_none()));
}
