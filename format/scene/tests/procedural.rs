//! Procedural models and the procedural albedo (DESIGN.md "Shading").

use scene::pattern::{albedo, apply_albedo, CHECKER_CELLS_PER_EXTENT};
use scene::procedural::{build, NAMES};
use std::collections::BTreeSet;

#[test]
fn every_model_is_closed_manifold_and_outward() {
    for &name in NAMES {
        let mesh = build(name).unwrap_or_else(|| panic!("{name} builds"));
        mesh.validate().unwrap();
        let topo = mesh.edge_topology();
        assert!(topo.is_closed_manifold(), "{name}: {topo:?}");
        assert!(mesh.signed_volume() > 0.0, "{name}: CCW outward");
        assert!(
            (5_000..=40_000).contains(&mesh.triangle_count()),
            "{name}: {} triangles",
            mesh.triangle_count()
        );
        // Outward: the normal at the highest vertex points up.
        let top = (0..mesh.vertex_count())
            .max_by(|&a, &b| mesh.positions[a][1].total_cmp(&mesh.positions[b][1]))
            .unwrap();
        assert!(
            mesh.normals[top][1] > 0.0,
            "{name}: top normal {:?}",
            mesh.normals[top]
        );
        println!(
            "{name}: {} vertices, {} triangles, volume {:.3}",
            mesh.vertex_count(),
            mesh.triangle_count(),
            mesh.signed_volume()
        );
    }
    assert!(build("teapot").is_none());
}

#[test]
fn torus_knot_is_a_knot_sized_tube() {
    let mesh = build("torus_knot").unwrap();
    assert!((8_000..=20_000).contains(&mesh.triangle_count()));
    // A (2, 3) knot tube: genus 1 (a torus): V − E + F = 0.
    let e = mesh.triangle_count() * 3 / 2;
    assert_eq!(mesh.vertex_count() + mesh.triangle_count(), e);
}

#[test]
fn models_are_deterministic() {
    for &name in NAMES {
        assert_eq!(
            build(name).unwrap().content_hash(),
            build(name).unwrap().content_hash()
        );
    }
}

#[test]
fn albedo_is_deterministic_opaque_and_seeded() {
    let p = [0.123, 0.456, -0.2];
    assert_eq!(albedo(p, 42), albedo(p, 42));
    assert_eq!(albedo(p, 42)[3], 255);
    assert_ne!(albedo(p, 42), albedo(p, 43));
    // Non-finite or huge inputs still give a colour.
    assert_eq!(albedo([f32::NAN, 1e30, -1e30], 1)[3], 255);
}

#[test]
fn albedo_alternates_between_neighbouring_checker_cells() {
    // Cells of one parity share a hue family; a step of one cell along any axis
    // changes parity and so the family (hue differs by about half a turn).
    let cell = 1.0 / CHECKER_CELLS_PER_EXTENT;
    let mut changed = 0;
    for i in 0..200 {
        let p = [(i as f32 - 100.0 + 0.5) * cell, 0.5 * cell, -0.5 * cell];
        for axis in 0..3 {
            let mut q = p;
            q[axis] += cell;
            if albedo(p, 9) != albedo(q, 9) {
                changed += 1;
            }
        }
    }
    assert_eq!(changed, 600);
}

#[test]
fn pattern_is_finer_than_the_mesh_can_keep_without_texture() {
    // Per-vertex colours vary at the scale of the mesh's edges: on every procedural
    // model most edges join differently coloured vertices, and the colours are many.
    for &name in NAMES {
        let mesh = build(name).unwrap();
        let mut edges = 0usize;
        let mut differ = 0usize;
        for t in &mesh.triangles {
            for k in 0..3 {
                let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
                edges += 1;
                differ += usize::from(mesh.albedo[a] != mesh.albedo[b]);
            }
        }
        let colours: BTreeSet<[u8; 4]> = mesh.albedo.iter().copied().collect();
        println!(
            "{name}: {:.0}% of edges change colour, {} colours",
            100.0 * differ as f64 / edges as f64,
            colours.len()
        );
        assert!(
            differ * 5 > edges,
            "{name}: only {differ} of {edges} edges change colour"
        );
        assert!(colours.len() > 250, "{name}: {} colours", colours.len());
    }
}

#[test]
fn apply_albedo_is_invariant_under_uniform_scale_and_translation() {
    let mesh = build("torus_knot").unwrap();
    let mut moved = mesh.clone();
    for p in &mut moved.positions {
        *p = [p[0] * 4.0 + 100.0, p[1] * 4.0 - 3.0, p[2] * 4.0 + 0.5];
    }
    apply_albedo(&mut moved, 77);
    let mut original = mesh.clone();
    apply_albedo(&mut original, 77);
    let same = original
        .albedo
        .iter()
        .zip(&moved.albedo)
        .filter(|(a, b)| a == b)
        .count();
    // Floating-point rounding may move a vertex lying exactly on a cell boundary.
    assert!(
        same * 100 >= original.albedo.len() * 99,
        "{same} of {}",
        original.albedo.len()
    );
}
