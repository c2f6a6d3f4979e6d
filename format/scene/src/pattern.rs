//! The procedural albedo pattern of DESIGN.md "Shading": what a model without
//! colours of its own is painted with (loaded files through `cleanup`, and the
//! procedural models).
//!
//! **Albedo.** [`albedo`] is a 3-D checker over object-space position in *unit-size*
//! coordinates (the model's largest bounding-box extent = 1, origin at the base
//! centre; [`apply_albedo`] does that mapping), with [`CHECKER_CELLS_PER_EXTENT`] = 16
//! cells across the model: about target_height / 16 for an upright statue. Even
//! and odd cells take neighbouring hues ([`PARITY_HUE_STEP`]) and two value levels;
//! each cell varies hue, saturation and value by a hash of its integer coordinates.
//! The pattern is evaluated per *vertex* (albedo is a vertex colour), so it is only
//! as fine as the mesh: a cell spans about five edges of the Stanford bunny's
//! 35k-vertex mesh (20% of its edges join differently coloured vertices; 24–48% on
//! the procedural models here). A simplified mesh — a proxy keeps a few hundred
//! triangles of a statue, edges spanning several cells — therefore loses the
//! pattern, which is the point: only the captured texture can keep it (000 §3.1.5).
//!
//! Until 2026-11 the checker had 40 cells per extent and complementary hues. That
//! stress pattern made every sub-pixel parallax of a proxy's projected texture a
//! full-contrast error; the paper's statues carry smooth colours. The current
//! pattern is still far finer than any proxy's geometry (DESIGN.md "Shading") but
//! its contrast is that of a painted statue (BENCHMARKS.md lists the effect on
//! PSNR: +1 dB on park-2m cell 275 — silhouettes, not texture, dominate the error).

use format::mesh::Mesh;

/// Checker cells across the model's largest extent.
pub const CHECKER_CELLS_PER_EXTENT: f32 = 16.0;

/// Hue difference between the two checker parities (a fraction of a turn).
pub const PARITY_HUE_STEP: f64 = 0.12;

/// The procedural albedo (sRGB8, alpha 255) at `p_object`, a position in unit-size
/// object coordinates (see the module docs), for a model seeded by `model_seed`.
pub fn albedo(p_object: [f32; 3], model_seed: u64) -> [u8; 4] {
    let cell = p_object.map(|x| {
        let c = (f64::from(x) * f64::from(CHECKER_CELLS_PER_EXTENT)).floor();
        // Saturating: huge or non-finite inputs still give a colour.
        c.clamp(-1e9, 1e9) as i64
    });
    let parity = (cell[0] + cell[1] + cell[2]).rem_euclid(2);
    let family_hue = (mix(model_seed, 0x0A1B_ED0C) >> 11) as f64 / (1u64 << 53) as f64;
    let hue = (family_hue + PARITY_HUE_STEP * parity as f64).fract();
    let h = mix(
        mix(mix(model_seed, cell[0] as u64), cell[1] as u64),
        cell[2] as u64,
    );
    let jitter = |shift: u32| ((h >> shift) & 0xFFFF) as f64 / 65535.0;
    let hue = (hue + 0.06 * (jitter(0) - 0.5)).rem_euclid(1.0);
    let saturation = 0.35 + 0.3 * jitter(16);
    let value = if parity == 0 { 0.80 } else { 0.62 } + 0.10 * (jitter(32) - 0.5);
    let [r, g, b] = hsv_to_rgb(hue, saturation, value);
    let to8 = |x: f64| (x.clamp(0.0, 1.0) * 255.0).round() as u8;
    [to8(r), to8(g), to8(b), 255]
}

/// Fills `mesh.albedo` with [`albedo`], mapping positions to unit-size coordinates:
/// `(p − base_centre) / largest_extent` where `base_centre` is the bounding box's
/// centre in x and z and its minimum in y.
pub fn apply_albedo(mesh: &mut Mesh, model_seed: u64) {
    let Some((lo, hi)) = mesh.bounds() else {
        mesh.albedo.clear();
        return;
    };
    let extent = (0..3).map(|k| hi[k] - lo[k]).fold(0.0f32, f32::max);
    let scale = if extent > 0.0 { 1.0 / extent } else { 1.0 };
    let base = [(lo[0] + hi[0]) * 0.5, lo[1], (lo[2] + hi[2]) * 0.5];
    mesh.albedo = mesh
        .positions
        .iter()
        .map(|p| albedo([0, 1, 2].map(|k| (p[k] - base[k]) * scale), model_seed))
        .collect();
}

/// splitmix64's finaliser over `a` combined with `b`.
fn mix(a: u64, b: u64) -> u64 {
    let mut z = a ^ b.wrapping_mul(0x9E37_79B9_7F4A_7C15).rotate_left(17);
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

fn hsv_to_rgb(h: f64, s: f64, v: f64) -> [f64; 3] {
    let h6 = h.rem_euclid(1.0) * 6.0;
    let sector = h6.floor();
    let f = h6 - sector;
    let p = v * (1.0 - s);
    let q = v * (1.0 - s * f);
    let t = v * (1.0 - s * (1.0 - f));
    match sector as i32 {
        0 => [v, t, p],
        1 => [q, v, p],
        2 => [p, v, t],
        3 => [p, q, v],
        4 => [t, p, v],
        _ => [v, p, q],
    }
}
