//! Tests of the weighted half-edge collapse (paper 000 §3.1.3.3, §3.1.4).
//! Every output goes through `validate()`.

mod common;
use glam::Vec2;
use glam::Vec3;
use proptest::prelude::*;
use std::f32::consts::PI;
use worker::grid::Prism;
use worker::simplify::{
    pixels_per_radian, point_triangle_distance_squared, simplify, simplify_seeded, simplify_with,
    validate, validate_view_masks, DeviationBound, ProjectedLength, Simplified, SimplifyError,
    SimplifyInput, SimplifyParams, ValidationError,
};

// ---------------------------------------------------------------- mesh helpers

#[derive(Clone, Debug)]
struct TestMesh {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
}

/// Area-weighted smooth vertex normals (unit; +y for vertices without area).
fn smooth_normals(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Vec3> {
    let mut normals = vec![Vec3::ZERO; positions.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let n = (b - a).cross(c - a);
        for &i in t {
            normals[i as usize] += n;
        }
    }
    normals
        .into_iter()
        .map(|n| n.try_normalize().unwrap_or(Vec3::Y))
        .collect()
}

/// A `w`×`h` grid over x–z with height and in-plane jitter, each quad split along a
/// random diagonal, counter-clockwise seen from +y.
fn perturbed_grid(w: usize, h: usize, jitter: &[f32], flips: &[bool]) -> TestMesh {
    let mut positions = Vec::new();
    for j in 0..=h {
        for i in 0..=w {
            let k = j * (w + 1) + i;
            let r = |o: usize| jitter[(3 * k + o) % jitter.len()];
            positions.push(Vec3::new(
                i as f32 + 0.3 * r(0),
                0.5 * r(1),
                j as f32 + 0.3 * r(2),
            ));
        }
    }
    let mut triangles = Vec::new();
    for j in 0..h {
        for i in 0..w {
            let v = |di: usize, dj: usize| ((j + dj) * (w + 1) + i + di) as u32;
            let (a, b, c, d) = (v(0, 0), v(1, 0), v(1, 1), v(0, 1));
            // ccw seen from +y: a → d → c → b.
            if flips[(j * w + i) % flips.len()] {
                triangles.push([a, d, c]);
                triangles.push([a, c, b]);
            } else {
                triangles.push([a, d, b]);
                triangles.push([b, d, c]);
            }
        }
    }
    let normals = smooth_normals(&positions, &triangles);
    TestMesh {
        positions,
        normals,
        triangles,
    }
}

/// An icosphere of radius `radius` at `centre`, `levels` times subdivided, with its
/// vertices pushed in or out by `bumps` (closed, manifold, outward ccw).
fn icosphere(levels: u32, centre: Vec3, radius: f32, bumps: &[f32]) -> TestMesh {
    let (unit, triangles) = scene::procedural::unit_icosphere(levels);
    let positions: Vec<Vec3> = unit.into_iter().map(Vec3::from).collect();
    let positions: Vec<Vec3> = positions
        .iter()
        .enumerate()
        .map(|(i, p)| centre + *p * radius * (1.0 + 0.15 * bumps[i % bumps.len()]))
        .collect();
    let normals = smooth_normals(&positions, &triangles);
    TestMesh {
        positions,
        normals,
        triangles,
    }
}

/// The whole of `mesh` with weights `w`, no view sets.
fn input_of<'a>(mesh: &'a TestMesh, w: &'a [f32]) -> SimplifyInput<'a> {
    SimplifyInput {
        positions: &mesh.positions,
        normals: &mesh.normals,
        triangles: &mesh.triangles,
        weights: w,
        view_sets: None,
        locked: None,
    }
}

fn sv_params(eye: Vec3, tolerance: f32) -> SimplifyParams {
    SimplifyParams {
        edge_length_tolerance_px: tolerance,
        length: ProjectedLength::FromPoint {
            eye,
            pixels_per_radian: pixels_per_radian(1024),
        },
        deviation: None,
    }
}

/// Replays the collapse log on the input: every vertex renamed to where its chain
/// of collapses ends, triangles that lose a corner dropped. Must give the output.
fn replay(input: &[[u32; 3]], vertex_count: usize, out: &Simplified) -> Vec<[u32; 3]> {
    let mut into: Vec<u32> = (0..vertex_count as u32).collect();
    for c in &out.log {
        into[c.from as usize] = c.into;
    }
    let find = |mut v: u32| {
        let mut steps = 0;
        while into[v as usize] != v {
            v = into[v as usize];
            steps += 1;
            assert!(steps <= vertex_count, "collapse chain loops");
        }
        v
    };
    input
        .iter()
        .map(|t| t.map(find))
        .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
        .collect()
}

/// Checks everything the log promises: valid output, the output is the replayed
/// log, costs below T_l, the lower weight collapses, every
/// removed vertex is removed once and never used again.
fn check_log(mesh: &TestMesh, weights: &[f32], tolerance: f32, out: &Simplified) {
    validate(mesh.positions.len(), &mesh.triangles, out).unwrap();
    assert_eq!(out.dropped_input_triangles, 0);
    assert_eq!(
        replay(&mesh.triangles, mesh.positions.len(), out),
        out.triangles
    );
    let mut removed = vec![false; mesh.positions.len()];
    for c in &out.log {
        assert!(c.cost < tolerance, "cost {c:?}");
        assert!(
            weights[c.from as usize] <= weights[c.into as usize],
            "{c:?}"
        );
        assert!(
            !removed[c.from as usize] && !removed[c.into as usize],
            "{c:?}"
        );
        removed[c.from as usize] = true;
    }
    for t in &out.triangles {
        assert!(t.iter().all(|&v| !removed[v as usize]));
    }
}

/// Replays the log one collapse at a time: no collapse turns any triangle's normal
/// by 90° or more, or leaves it with zero area.
fn check_no_fold(mesh: &TestMesh, out: &Simplified) {
    let cross = |tri: [u32; 3]| {
        let [a, b, c] = tri.map(|i| mesh.positions[i as usize]);
        (b - a).cross(c - a)
    };
    let mut current = mesh.triangles.clone();
    for c in &out.log {
        current.retain(|t| !(t.contains(&c.from) && t.contains(&c.into)));
        for t in current.iter_mut().filter(|t| t.contains(&c.from)) {
            let moved = t.map(|x| if x == c.from { c.into } else { x });
            let (before, after) = (cross(*t), cross(moved));
            assert!(after.length_squared() > 0.0, "{c:?} degenerates {t:?}");
            assert!(before.dot(after) > 0.0, "{c:?} folds {t:?}");
            *t = moved;
        }
    }
    assert_eq!(current, out.triangles);
}

// ---------------------------------------------------------------- strategies

/// A random mesh: a perturbed grid (open, with a random subset of its triangles,
/// so boundaries are ragged and bow-tie vertices appear) or a bumpy icosphere.
fn arb_mesh() -> impl Strategy<Value = TestMesh> {
    let grid = (
        2usize..12,
        2usize..12,
        prop::collection::vec(-1.0f32..1.0, 16..64),
        prop::collection::vec(any::<bool>(), 1..32),
        prop::collection::vec(any::<bool>(), 1..64),
    )
        .prop_map(|(w, h, jitter, flips, keep)| {
            let mut m = perturbed_grid(w, h, &jitter, &flips);
            // Drop about one triangle in 8.
            let mut i = 0;
            m.triangles.retain(|_| {
                i += 1;
                keep[i % keep.len()] || i % 8 != 0
            });
            m
        });
    let sphere = (0u32..3, prop::collection::vec(-1.0f32..1.0, 8..64))
        .prop_map(|(l, bumps)| icosphere(l, Vec3::new(0.0, 5.0, 0.0), 4.0, &bumps));
    prop_oneof![grid, sphere]
}

fn arb_eye() -> impl Strategy<Value = Vec3> {
    (0.0f32..2.0 * PI, 10.0f32..60.0, 1.0f32..20.0)
        .prop_map(|(a, d, y)| Vec3::new(d * a.cos(), y, d * a.sin()))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    /// The output references only vertices of the model (and of the input subset),
    /// is manifold and the replayed log; costs below T_l.
    #[test]
    fn simplified_mesh_stays_inside_model(
        mesh in arb_mesh(),
        weights in prop::collection::vec(prop::sample::select(vec![0.05f32, 0.125, 0.25, 0.4, 0.5]), 1..16),
        eye in arb_eye(),
        tolerance in prop_oneof![0.0f32..5.0, 5.0f32..500.0],
    ) {
        let w: Vec<f32> = (0..mesh.positions.len()).map(|i| weights[i % weights.len()]).collect();
        let input = input_of(&mesh, &w);
        let out = simplify(&input, &sv_params(eye, tolerance)).unwrap();
        check_log(&mesh, &w, tolerance, &out);
        check_no_fold(&mesh, &out);
        prop_assert!(out.view_masks.is_empty());
        prop_assert!(out.triangles.len() <= mesh.triangles.len());
    }

    /// With T_l = 0 the mesh is exactly the input.
    #[test]
    fn zero_tolerance_leaves_mesh_unchanged(
        mesh in arb_mesh(),
        weights in prop::collection::vec(0.0f32..1.0, 1..16),
        eye in arb_eye(),
    ) {
        let w: Vec<f32> = (0..mesh.positions.len()).map(|i| weights[i % weights.len()]).collect();
        let input = input_of(&mesh, &w);
        let out = simplify(&input, &sv_params(eye, 0.0)).unwrap();
        validate(mesh.positions.len(), &mesh.triangles, &out).unwrap();
        prop_assert_eq!(&out.triangles, &mesh.triangles);
        prop_assert_eq!(out.collapses, 0);
    }

    /// Same input twice gives the same output, and the closure entry point with the
    /// same projected length agrees with the built-in one.
    #[test]
    fn output_is_deterministic(
        mesh in arb_mesh(),
        weights in prop::collection::vec(prop::sample::select(vec![0.05f32, 0.125, 0.5]), 1..8),
        eye in arb_eye(),
        tolerance in 0.0f32..200.0,
    ) {
        let w: Vec<f32> = (0..mesh.positions.len()).map(|i| weights[i % weights.len()]).collect();
        let input = input_of(&mesh, &w);
        let params = sv_params(eye, tolerance);
        let first = simplify(&input, &params).unwrap();
        let second = simplify(&input, &params).unwrap();
        validate(mesh.positions.len(), &mesh.triangles, &first).unwrap();
        validate(mesh.positions.len(), &mesh.triangles, &second).unwrap();
        prop_assert_eq!(&first, &second);
        let length = &params.length;
        let third = simplify_with(&input, tolerance, |a, b| {
            length.pixels(mesh.positions[a as usize], mesh.positions[b as usize])
        })
        .unwrap();
        validate(mesh.positions.len(), &mesh.triangles, &third).unwrap();
        prop_assert_eq!(&first, &third);
    }

    /// MV: per-triangle masks are the AND of the vertices' view sets, and every
    /// collapse obeyed §3.1.4 (w_u ≤ w_v, and a common view or both sets empty).
    #[test]
    fn mv_masks_and_collapse_constraint(
        mesh in arb_mesh(),
        weights in prop::collection::vec(prop::sample::select(vec![0.05f32, 0.125, 0.25, 0.5]), 1..16),
        sets in prop::collection::vec(prop_oneof![Just(0u8), 0u8..128, Just(127u8)], 1..16),
        eyes in prop::collection::vec(arb_eye(), 1..12),
        tolerance in 0.0f32..300.0,
    ) {
        let n = mesh.positions.len();
        let w: Vec<f32> = (0..n).map(|i| weights[i % weights.len()]).collect();
        let s: Vec<u8> = (0..n).map(|i| sets[(i * 7 + i / 3) % sets.len()]).collect();
        let input = SimplifyInput {
            positions: &mesh.positions,
            normals: &mesh.normals,
            triangles: &mesh.triangles,
            weights: &w,
            view_sets: Some(&s),
            locked: None,
        };
        let params = SimplifyParams {
            edge_length_tolerance_px: tolerance,
            length: ProjectedLength::MaxOverPoints { eyes, pixels_per_radian: pixels_per_radian(1024) },
            deviation: None,
        };
        let out = simplify(&input, &params).unwrap();
        check_log(&mesh, &w, tolerance, &out);
        validate_view_masks(&s, &out).unwrap();
        for c in &out.log {
            let (su, sv) = (s[c.from as usize], s[c.into as usize]);
            prop_assert!(su & sv != 0 || (su == 0 && sv == 0), "{:?} sets {:#x} {:#x}", c, su, sv);
        }
    }

    /// Issue 29: a locked vertex (a chunk's cut border) is never removed, so every
    /// locked position the input uses is still used by the output; the collapse
    /// keeps every other rule.
    #[test]
    fn locked_vertices_are_never_removed(
        mesh in arb_mesh(),
        weights in prop::collection::vec(prop::sample::select(vec![0.05f32, 0.125, 0.5]), 1..8),
        lock in prop::collection::vec(any::<bool>(), 1..16),
        eye in arb_eye(),
        tolerance in 0.0f32..300.0,
    ) {
        let n = mesh.positions.len();
        let w: Vec<f32> = (0..n).map(|i| weights[i % weights.len()]).collect();
        let locked: Vec<bool> = (0..n).map(|i| lock[(i * 5 + i / 3) % lock.len()]).collect();
        let input = SimplifyInput { locked: Some(&locked), ..input_of(&mesh, &w) };
        let out = simplify(&input, &sv_params(eye, tolerance)).unwrap();
        check_log(&mesh, &w, tolerance, &out);
        for c in &out.log {
            prop_assert!(!locked[c.from as usize], "{:?} removes a locked vertex", c);
        }
        let key = |v: u32| mesh.positions[v as usize].to_array().map(f32::to_bits);
        let kept: std::collections::HashSet<[u32; 3]> =
            out.triangles.iter().flatten().map(|&v| key(v)).collect();
        for &v in mesh.triangles.iter().flatten().filter(|&&v| locked[v as usize]) {
            prop_assert!(kept.contains(&key(v)), "locked vertex {} is gone", v);
        }
    }
}

// ---------------------------------------------------------------- deviation bound

/// Distance from `p` to the nearest triangle of `triangles`.
fn distance_to_surface(positions: &[Vec3], triangles: &[[u32; 3]], p: Vec3) -> f32 {
    triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| positions[i as usize]);
            point_triangle_distance_squared(p, a, b, c)
        })
        .fold(f32::INFINITY, f32::min)
        .sqrt()
}

/// The first vertex the mesh's triangles use that lies farther from `surface` than
/// the bound allows: (vertex, distance, tolerance).
fn bound_violation(
    mesh: &TestMesh,
    surface: &[[u32; 3]],
    bound: &DeviationBound,
    ppr: f32,
) -> Option<(u32, f32, f32)> {
    let mut used: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    used.sort_unstable();
    used.dedup();
    used.into_iter().find_map(|v| {
        let p = mesh.positions[v as usize];
        let tolerance = bound.world_tolerance(p, ppr);
        let d = distance_to_surface(&mesh.positions, surface, p);
        (d > tolerance * 1.0001 + 1e-5).then_some((v, d, tolerance))
    })
}

fn arb_prism() -> impl Strategy<Value = Prism> {
    (
        -30.0f32..30.0,
        -30.0f32..30.0,
        2.0f32..15.0,
        0.0f32..4.0,
        0.5f32..6.0,
    )
        .prop_map(|(x, z, size, y0, dy)| Prism {
            centre: Vec2::new(x, z),
            cell_size: size,
            min_y: y0,
            max_y: y0 + dy,
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// The bound's promise: every vertex the input used lies within
    /// `max_px / ppr × (its distance from the prism)` of the simplified surface, even
    /// with a T_l so large that only the bound stops the collapse; and the bounded
    /// output is still a valid simplification of the input.
    #[test]
    fn deviation_bound_holds_for_every_input_vertex(
        mesh in arb_mesh(),
        weights in prop::collection::vec(prop::sample::select(vec![0.05f32, 0.125, 0.25, 0.5]), 1..8),
        prism in arb_prism(),
        max_px in prop_oneof![0.25f32..2.0, 2.0f32..200.0],
    ) {
        let w: Vec<f32> = (0..mesh.positions.len()).map(|i| weights[i % weights.len()]).collect();
        let input = input_of(&mesh, &w);
        let ppr = pixels_per_radian(1024);
        let bound = DeviationBound { max_px, region: prism };
        let params = SimplifyParams {
            edge_length_tolerance_px: 1e6,
            length: ProjectedLength::MaxOverPrism { prism, pixels_per_radian: ppr },
            deviation: Some(bound),
        };
        let out = simplify(&input, &params).unwrap();
        validate(mesh.positions.len(), &mesh.triangles, &out).unwrap();
        check_no_fold(&mesh, &out);
        prop_assert_eq!(bound_violation(&mesh, &out.triangles, &bound, ppr), None);
    }

    /// The closest-point distance is never more than the distance to any point of
    /// the triangle, and a fine barycentric grid gets within its spacing of it.
    #[test]
    fn point_triangle_distance_is_the_minimum(
        p in prop::array::uniform3(-10.0f32..10.0),
        a in prop::array::uniform3(-5.0f32..5.0),
        b in prop::array::uniform3(-5.0f32..5.0),
        c in prop::array::uniform3(-5.0f32..5.0),
    ) {
        let [p, a, b, c] = [p, a, b, c].map(Vec3::from_array);
        let d = point_triangle_distance_squared(p, a, b, c).sqrt();
        let n = 60;
        let mut best = f32::INFINITY;
        for i in 0..=n {
            for j in 0..=(n - i) {
                let (u, v) = (i as f32 / n as f32, j as f32 / n as f32);
                let q = a + u * (b - a) + v * (c - a);
                let e = p.distance(q);
                prop_assert!(d <= e + 1e-3, "closest {} but a point of the triangle is {}", d, e);
                best = best.min(e);
            }
        }
        let spacing = (b - a).length().max((c - a).length()).max((c - b).length()) / n as f32;
        prop_assert!(best <= d + spacing + 1e-3, "closest {} but the grid's best is {}", d, best);
    }
}

#[test]
fn deviation_bound_rejects_bad_values_and_only_adds_triangles_on_a_sphere() {
    let mesh = icosphere(3, Vec3::new(0.0, 5.0, 60.0), 4.0, &[0.3, -0.2, 0.1]);
    let w = vec![0.125f32; mesh.positions.len()];
    let input = input_of(&mesh, &w);
    let prism = Prism {
        centre: Vec2::ZERO,
        cell_size: 10.0,
        min_y: 2.0,
        max_y: 8.0,
    };
    let ppr = pixels_per_radian(1024);
    let with = |max_px: Option<f32>| SimplifyParams {
        edge_length_tolerance_px: 4.5,
        length: ProjectedLength::MaxOverPrism {
            prism,
            pixels_per_radian: ppr,
        },
        deviation: max_px.map(|max_px| DeviationBound {
            max_px,
            region: prism,
        }),
    };
    for bad in [0.0, -1.0, f32::NAN, f32::INFINITY] {
        assert!(matches!(
            simplify(&input, &with(Some(bad))),
            Err(SimplifyError::BadDeviation(_))
        ));
    }
    // Tighter bounds keep more of the sphere; the paper's rule alone keeps least.
    let counts: Vec<usize> = [Some(0.25), Some(1.0), Some(4.0), None]
        .iter()
        .map(|&d| {
            let out = simplify(&input, &with(d)).unwrap();
            validate(mesh.positions.len(), &mesh.triangles, &out).unwrap();
            out.triangles.len()
        })
        .collect();
    assert!(
        counts.windows(2).all(|w| w[0] >= w[1]) && counts[0] > counts[3],
        "triangles at 0.25 / 1 / 4 px / unbounded: {counts:?}"
    );
}

// ---------------------------------------------------------------- unit tests

#[test]
fn projected_length_is_angle_times_pixels_per_radian() {
    let ppr = pixels_per_radian(1024);
    assert!((ppr - 1024.0 / (PI / 3.0)).abs() < 1e-3);
    // An edge of length 1 across the view axis at distance 100: angle 2·atan(0.005).
    let eye = Vec3::ZERO;
    let (a, b) = (Vec3::new(-0.5, 0.0, 100.0), Vec3::new(0.5, 0.0, 100.0));
    let from_point = ProjectedLength::FromPoint {
        eye,
        pixels_per_radian: ppr,
    };
    let expected = 2.0 * (0.005f32).atan() * ppr;
    assert!((from_point.pixels(a, b) - expected).abs() < 1e-3 * expected);
    // Seen end-on it has no length; l′ takes the largest over the eyes.
    let end_on = ProjectedLength::FromPoint {
        eye: Vec3::new(-10.0, 0.0, 100.0),
        pixels_per_radian: ppr,
    };
    assert!(end_on.pixels(a, b) < 1e-3);
    let max = ProjectedLength::MaxOverPoints {
        eyes: vec![Vec3::new(-10.0, 0.0, 100.0), eye, Vec3::new(0.0, 0.0, 50.0)],
        pixels_per_radian: ppr,
    };
    let near = 2.0 * (0.01f32).atan() * ppr;
    assert!((max.pixels(a, b) - near).abs() < 1e-3 * near);
    // An endpoint on an eye: infinitely long.
    assert_eq!(
        ProjectedLength::FromPoint {
            eye: a,
            pixels_per_radian: ppr
        }
        .pixels(a, b),
        f32::INFINITY
    );
}

/// l′ "with respect to the cell" (000 §3.1.4) looks from the prism's point nearest
/// the edge too: an edge 5 units outside the middle of a side face of a 50-unit
/// cell is ~5× longer from there than from the nearest corner.
#[test]
fn cell_length_sees_the_middle_of_the_nearest_face() {
    let ppr = pixels_per_radian(1024);
    let prism = worker::grid::Prism {
        centre: glam::Vec2::ZERO,
        cell_size: 50.0,
        min_y: 5.0,
        max_y: 12.0,
    };
    // The face between corners 0 (50, 0) and 1 (25, 43.3): its middle and normal.
    let mid = glam::Vec2::new(37.5, 21.65);
    let normal = mid.normalize();
    let p = mid + 5.0 * normal;
    let along = glam::Vec2::new(-normal.y, normal.x) * 0.5;
    let (a, b) = (
        Vec3::new(p.x - along.x, 8.0, p.y - along.y),
        Vec3::new(p.x + along.x, 8.0, p.y + along.y),
    );
    let corners = ProjectedLength::MaxOverPoints {
        eyes: prism.corners().to_vec(),
        pixels_per_radian: ppr,
    };
    let cell = ProjectedLength::MaxOverPrism {
        prism,
        pixels_per_radian: ppr,
    };
    let from_face = 2.0 * (0.5f32 / 5.0).atan() * ppr;
    assert!((cell.pixels(a, b) - from_face).abs() < 1e-2 * from_face);
    assert!(cell.pixels(a, b) > 4.0 * corners.pixels(a, b));
    // Never below the corners' maximum; far away the two agree.
    let far = Vec3::new(400.0, 8.0, 300.0);
    let (fa, fb) = (far, far + Vec3::new(0.0, 1.0, 1.0));
    let (c, l) = (corners.pixels(fa, fb), cell.pixels(fa, fb));
    assert!(l >= c && l < 1.1 * c, "far edge: corners {c}, cell {l}");
}

#[test]
fn cost_follows_the_paper() {
    // One edge of a two-triangle strip, everything else locked out by a huge cost:
    // make a square whose diagonal vertices have different normals and check the
    // first collapse's recorded cost against (1.5 − n_i·n_j)² · l · (w_i + w_j).
    let m = perturbed_grid(1, 1, &[0.0], &[false]);
    let normals = vec![
        Vec3::Y,
        Vec3::new(0.0, 1.0, 1.0).normalize(),
        Vec3::Y,
        Vec3::Y,
    ];
    let weights = [0.125, 0.4, 0.25, 0.5];
    let eye = Vec3::new(0.5, 30.0, 0.5);
    let input = SimplifyInput {
        positions: &m.positions,
        normals: &normals,
        triangles: &m.triangles,
        weights: &weights,
        view_sets: None,
        locked: None,
    };
    let params = sv_params(eye, 1e9);
    let out = simplify(&input, &params).unwrap();
    validate(4, &m.triangles, &out).unwrap();
    let first = out.log[0];
    let (i, j) = (first.from as usize, first.into as usize);
    let l = params.length.pixels(m.positions[i], m.positions[j]);
    let bend = 1.5 - normals[i].dot(normals[j]);
    let expected = bend * bend * l * (weights[i] + weights[j]);
    assert!(
        (first.cost - expected).abs() <= 1e-5 * expected,
        "{first:?} vs {expected}"
    );
    assert!(weights[i] <= weights[j]);
    // The cheapest edge of the square is the one with the lowest cost of all five.
    let mut costs = Vec::new();
    for t in &m.triangles {
        for k in 0..3 {
            let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
            let bend = 1.5 - normals[a].dot(normals[b]);
            costs.push(
                bend * bend
                    * params.length.pixels(m.positions[a], m.positions[b])
                    * (weights[a] + weights[b]),
            );
        }
    }
    let min = costs.iter().copied().fold(f32::INFINITY, f32::min);
    assert_eq!(first.cost, min);
}

#[test]
fn closed_sphere_simplifies_to_a_valid_closed_mesh() {
    let mesh = icosphere(3, Vec3::new(0.0, 5.0, 0.0), 4.0, &[0.0]);
    let weights = vec![0.125; mesh.positions.len()];
    let input = input_of(&mesh, &weights);
    let out = simplify(&input, &sv_params(Vec3::new(0.0, 5.0, 40.0), 1e9)).unwrap();
    check_log(&mesh, &weights, 1e9, &out);
    // Closed and manifold still: every edge used exactly twice.
    let mut edges: Vec<(u32, u32)> = out
        .triangles
        .iter()
        .flat_map(|t| (0..3).map(move |k| (t[k], t[(k + 1) % 3])))
        .collect();
    edges.sort_unstable();
    for &(a, b) in &edges {
        assert!(edges.binary_search(&(b, a)).is_ok(), "open edge {a}-{b}");
    }
    assert!(out.triangles.len() >= 4 && out.triangles.len() < mesh.triangles.len() / 10);
}

/// With the capture's weights (0.5 on the exterior silhouette, here the border of
/// a grid; 0.125 inside) the border only slides along itself: a lower weight never
/// goes into a higher one, and two border vertices merge only along a border edge.
#[test]
fn heavy_border_vertices_only_slide_along_the_border() {
    let mesh = perturbed_grid(10, 10, &[0.3, -0.2, 0.5, 0.1, -0.6], &[false, true]);
    let on_border = |v: u32| {
        let (i, j) = (v % 11, v / 11);
        i == 0 || j == 0 || i == 10 || j == 10
    };
    let weights: Vec<f32> = (0..mesh.positions.len() as u32)
        .map(|v| if on_border(v) { 0.5 } else { 0.125 })
        .collect();
    let input = input_of(&mesh, &weights);
    let out = simplify(&input, &sv_params(Vec3::new(5.0, 40.0, 5.0), 1e9)).unwrap();
    check_log(&mesh, &weights, 1e9, &out);
    check_no_fold(&mesh, &out);
    for c in &out.log {
        if on_border(c.from) {
            assert!(on_border(c.into), "{c:?} pulled the border inwards");
        }
    }
    // With no limit on the cost everything inside goes.
    let used: Vec<u32> = out.triangles.iter().flatten().copied().collect();
    assert!(used.iter().all(|&v| on_border(v)), "{:?}", out.triangles);
    assert!(!out.triangles.is_empty());
}

/// Non-manifold input (a fin on an interior edge, a flipped triangle, two sheets
/// touching at a vertex) simplifies without making anything else non-manifold.
#[test]
fn non_manifold_input_stays_valid() {
    let mut mesh = perturbed_grid(8, 8, &[0.1, -0.3, 0.2, 0.4], &[false, true, true]);
    let n0 = mesh.positions.len() as u32;
    // A fin: a third triangle on the edge of triangle 40, pointing up.
    let [a, b, _] = mesh.triangles[40];
    mesh.positions
        .push((mesh.positions[a as usize] + mesh.positions[b as usize]) / 2.0 + Vec3::Y);
    mesh.triangles.push([a, b, n0]);
    // A flipped triangle: the edges it shares run the same way as its neighbours'.
    let [p, q, r] = mesh.triangles[70];
    mesh.triangles[70] = [p, r, q];
    // A second sheet touching the grid at vertex 0 only.
    for d in [Vec3::new(-1.0, 0.0, 0.0), Vec3::new(-1.0, 0.0, -1.0)] {
        mesh.positions.push(mesh.positions[0] + d);
    }
    mesh.triangles.push([0, n0 + 2, n0 + 1]);
    mesh.normals = smooth_normals(&mesh.positions, &mesh.triangles);
    let weights = vec![0.125; mesh.positions.len()];
    for tolerance in [4.5, 1e3, 1e9] {
        let input = input_of(&mesh, &weights);
        let out = simplify(&input, &sv_params(Vec3::new(4.0, 30.0, 4.0), tolerance)).unwrap();
        check_log(&mesh, &weights, tolerance, &out);
        check_no_fold(&mesh, &out);
        if tolerance > 1e8 {
            assert!(
                out.triangles.len() * 4 < mesh.triangles.len(),
                "{}",
                out.triangles.len()
            );
        }
    }
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let m = perturbed_grid(2, 2, &[0.0], &[false]);
    let n = m.positions.len();
    let w = vec![0.125; n];
    let ok = SimplifyInput {
        positions: &m.positions,
        normals: &m.normals,
        triangles: &m.triangles,
        weights: &w,
        view_sets: None,
        locked: None,
    };
    let params = sv_params(Vec3::new(0.0, 10.0, 0.0), 4.5);
    let short = vec![0.125; n - 1];
    assert!(matches!(
        simplify(
            &SimplifyInput {
                weights: &short,
                ..ok
            },
            &params
        ),
        Err(SimplifyError::LengthMismatch {
            what: "weights",
            ..
        })
    ));
    let bad_tris = [[0, 1, n as u32]];
    assert_eq!(
        simplify(
            &SimplifyInput {
                triangles: &bad_tris,
                ..ok
            },
            &params
        ),
        Err(SimplifyError::IndexOutOfRange {
            triangle: 0,
            vertex: n as u32,
            vertex_count: n
        })
    );
    let mut nan = w.clone();
    nan[4] = f32::NAN;
    assert!(matches!(
        simplify(
            &SimplifyInput {
                weights: &nan,
                ..ok
            },
            &params
        ),
        Err(SimplifyError::NonFinite {
            what: "weight",
            vertex: 4
        })
    ));
    let sets = vec![0x80u8; n];
    assert!(matches!(
        simplify(
            &SimplifyInput {
                view_sets: Some(&sets),
                ..ok
            },
            &params
        ),
        Err(SimplifyError::ViewSetOutOfRange { .. })
    ));
    assert!(matches!(
        simplify(&ok, &sv_params(Vec3::ZERO, -1.0)),
        Err(SimplifyError::BadTolerance(_))
    ));
    let no_eyes = SimplifyParams {
        edge_length_tolerance_px: 4.5,
        length: ProjectedLength::MaxOverPoints {
            eyes: Vec::new(),
            pixels_per_radian: 100.0,
        },
        deviation: None,
    };
    assert_eq!(simplify(&ok, &no_eyes), Err(SimplifyError::NoEyes));
}

#[test]
fn degenerate_and_repeated_input_triangles_are_dropped() {
    let m = perturbed_grid(3, 3, &[0.2, -0.4, 0.7], &[false]);
    let mut tris = m.triangles.clone();
    tris.push([1, 1, 2]);
    let [a, b, c] = tris[0];
    tris.push([b, c, a]);
    let w = vec![0.125; m.positions.len()];
    let input = SimplifyInput {
        positions: &m.positions,
        normals: &m.normals,
        triangles: &tris,
        weights: &w,
        view_sets: None,
        locked: None,
    };
    let out = simplify(&input, &sv_params(Vec3::new(0.0, 10.0, 0.0), 0.0)).unwrap();
    validate(m.positions.len(), &tris, &out).unwrap();
    assert_eq!(out.dropped_input_triangles, 2);
    assert_eq!(out.triangles, m.triangles);
}

#[test]
fn validate_rejects_broken_outputs() {
    let m = perturbed_grid(2, 2, &[0.0], &[false]);
    let n = m.positions.len();
    let out = |triangles: Vec<[u32; 3]>| Simplified {
        triangles,
        ..Simplified::default()
    };
    assert!(validate(n, &m.triangles, &out(m.triangles.clone())).is_ok());
    assert!(matches!(
        validate(n, &m.triangles, &out(vec![[0, 1, n as u32]])),
        Err(ValidationError::IndexOutOfRange { .. })
    ));
    assert!(matches!(
        validate(n, &m.triangles[..1], &out(vec![m.triangles[1]])),
        Err(ValidationError::VertexNotInInput { .. })
    ));
    assert!(matches!(
        validate(n, &m.triangles, &out(vec![[0, 0, 1]])),
        Err(ValidationError::Degenerate { .. })
    ));
    let [a, b, c] = m.triangles[0];
    assert!(matches!(
        validate(n, &m.triangles, &out(vec![[a, b, c], [c, b, a]])),
        Err(ValidationError::Duplicate { .. })
    ));
    // Edge a-b used by two triangles in the same direction.
    let d = (0..n as u32).find(|v| ![a, b, c].contains(v)).unwrap();
    assert!(matches!(
        validate(n, &m.triangles, &out(vec![[a, b, c], [a, b, d]])),
        Err(ValidationError::NonManifoldEdge { .. })
    ));
    let sets = vec![0b011u8; n];
    let mut masked = out(vec![[a, b, c]]);
    masked.view_masks = vec![0b001];
    assert!(matches!(
        validate_view_masks(&sets, &masked),
        Err(ValidationError::WrongMask {
            expected: 0b011,
            found: 0b001,
            ..
        })
    ));
}

// ---------------------------------------------------------------- the bunny

/// The bunny at the paper's size: 43 units tall, base on y = 0, centred in x–z
/// (format's loader and normalisation, as the bake sees it).
fn bunny() -> Option<TestMesh> {
    let path = common::fetched_model("bunny.obj")?;
    let mut mesh = scene::load::load_model(&path).unwrap();
    scene::build::normalise(&mut mesh, [0.0; 3], 43.0).unwrap();
    Some(TestMesh {
        positions: mesh.positions.iter().map(|&p| Vec3::from(p)).collect(),
        normals: mesh.normals.iter().map(|&n| Vec3::from(n)).collect(),
        triangles: mesh.triangles,
    })
}

const CELL_SIZE: f32 = 50.0;
const EYE_HEIGHT: f32 = 10.0;
const MIN_EYE_HEIGHT: f32 = 5.0;
const MAX_EYE_HEIGHT: f32 = 15.0;

/// The centre of the cell `k` cells away from the bunny (flat-top hexagons:
/// neighbouring centres are √3·c apart), on the +z side, at eye height.
fn cell_centre(k: u32) -> Vec3 {
    Vec3::new(0.0, EYE_HEIGHT, k as f32 * 3f32.sqrt() * CELL_SIZE)
}

/// The 12 corners of the cell's view prism.
fn cell_corners(centre: Vec3) -> Vec<Vec3> {
    let mut corners = Vec::new();
    for y in [MIN_EYE_HEIGHT, MAX_EYE_HEIGHT] {
        for i in 0..6 {
            let a = i as f32 * PI / 3.0;
            corners.push(Vec3::new(
                centre.x + CELL_SIZE * a.cos(),
                y,
                centre.z + CELL_SIZE * a.sin(),
            ));
        }
    }
    corners
}

/// The centres of the cell and its 6 neighbours: the MV views (bit k = view k).
fn mv_views(centre: Vec3) -> Vec<Vec3> {
    let step = 3f32.sqrt() * CELL_SIZE;
    let mut views = vec![centre];
    for i in 0..6 {
        let a = PI / 6.0 + i as f32 * PI / 3.0;
        views.push(centre + Vec3::new(step * a.cos(), 0.0, step * a.sin()));
    }
    views
}

fn front_facing(mesh: &TestMesh, tri: &[u32; 3], eye: Vec3) -> bool {
    let [a, b, c] = tri.map(|i| mesh.positions[i as usize]);
    (b - a).cross(c - a).dot(eye - (a + b + c) / 3.0) > 0.0
}

fn write_obj(path: &std::path::Path, mesh: &TestMesh, triangles: &[[u32; 3]]) {
    use std::fmt::Write;
    let mut s = String::new();
    for p in &mesh.positions {
        writeln!(s, "v {} {} {}", p.x, p.y, p.z).unwrap();
    }
    for t in triangles {
        writeln!(s, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1).unwrap();
    }
    std::fs::write(path, s).unwrap();
}

/// The paper's weights for a vertex seen from `eye` with the capture replaced by
/// a geometric stand-in (§3.1.3.2): 0.5 if back-facing (all its triangles
/// back-facing); 0.5 on the contour (front- and back-facing triangles meet there:
/// where the exterior and interior silhouettes lie); else 0.125 (interior). The
/// real weights come from the capture's pixel classes (no occlusion test here).
/// Vertices with a triangle front-facing to `eye` (not back-facing, §3.1.3.2).
fn front_vertices(mesh: &TestMesh, eye: Vec3) -> Vec<bool> {
    let mut front = vec![false; mesh.positions.len()];
    for t in mesh.triangles.iter().filter(|t| front_facing(mesh, t, eye)) {
        for &v in t {
            front[v as usize] = true;
        }
    }
    front
}

fn standin_weights(mesh: &TestMesh, eye: Vec3) -> Vec<f32> {
    let mut front = vec![false; mesh.positions.len()];
    let mut back = vec![false; mesh.positions.len()];
    for t in &mesh.triangles {
        let side = if front_facing(mesh, t, eye) {
            &mut front
        } else {
            &mut back
        };
        for &v in t {
            side[v as usize] = true;
        }
    }
    front
        .iter()
        .zip(&back)
        .map(|(&f, &b)| if f && !b { 0.125 } else { 0.5 })
        .collect()
}

/// How the bunny runs pick their triangles and weights.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Variant {
    /// The front-facing (SV) / not regionally back-facing (MV) triangles, uniform
    /// weights 0.125.
    SubsetUniform,
    /// The whole mesh with `standin_weights`, back faces dropped afterwards.
    WholeStandin,
}

struct BunnyRun {
    input: usize,
    output: Vec<[u32; 3]>,
}

/// SVMesh of the bunny from the centre of the cell `k` cells away, its
/// front-facing triangles kept at the end.
fn bunny_sv(mesh: &TestMesh, k: u32, variant: Variant) -> BunnyRun {
    let n = mesh.positions.len();
    let centre = cell_centre(k);
    let triangles: Vec<[u32; 3]> = if variant == Variant::WholeStandin {
        mesh.triangles.clone()
    } else {
        mesh.triangles
            .iter()
            .filter(|t| front_facing(mesh, t, centre))
            .copied()
            .collect()
    };
    let weights = if variant == Variant::SubsetUniform {
        vec![0.125f32; n]
    } else {
        standin_weights(mesh, centre)
    };
    let input = SimplifyInput {
        positions: &mesh.positions,
        normals: &mesh.normals,
        triangles: &triangles,
        weights: &weights,
        view_sets: None,
        locked: None,
    };
    let out = simplify(&input, &sv_params(centre, 4.5)).unwrap();
    validate(n, &triangles, &out).unwrap();
    let output = out
        .triangles
        .into_iter()
        .filter(|t| front_facing(mesh, t, centre))
        .collect();
    BunnyRun {
        input: triangles.len(),
        output,
    }
}

/// MVMesh of the bunny for the cell `k` cells away: l′ over the 12 prism corners,
/// view k in a vertex's set when the vertex faces view k (centre + 6 neighbours; a
/// stand-in for the captures' visibility), stand-in weights maximised over the
/// views (§3.1.4); the not regionally back-facing triangles kept at the end.
fn bunny_mv(mesh: &TestMesh, k: u32, variant: Variant) -> BunnyRun {
    let n = mesh.positions.len();
    let centre = cell_centre(k);
    let corners = cell_corners(centre);
    let views = mv_views(centre);
    let regionally_front = |t: &[u32; 3]| corners.iter().any(|&c| front_facing(mesh, t, c));
    let per_view: Vec<Vec<f32>> = views.iter().map(|&e| standin_weights(mesh, e)).collect();
    let faces: Vec<Vec<bool>> = views.iter().map(|&e| front_vertices(mesh, e)).collect();
    let sets: Vec<u8> = (0..n)
        .map(|v| {
            (0..views.len())
                .filter(|&i| faces[i][v])
                .fold(0u8, |s, i| s | 1 << i)
        })
        .collect();
    let triangles: Vec<[u32; 3]> = if variant == Variant::WholeStandin {
        mesh.triangles.clone()
    } else {
        mesh.triangles
            .iter()
            .filter(|t| regionally_front(t))
            .copied()
            .collect()
    };
    let weights = if variant == Variant::SubsetUniform {
        vec![0.125f32; n]
    } else {
        (0..n)
            .map(|v| per_view.iter().map(|w| w[v]).fold(0.0, f32::max))
            .collect()
    };
    let input = SimplifyInput {
        positions: &mesh.positions,
        normals: &mesh.normals,
        triangles: &triangles,
        weights: &weights,
        view_sets: Some(&sets),
        locked: None,
    };
    let params = SimplifyParams {
        edge_length_tolerance_px: 4.5,
        length: ProjectedLength::MaxOverPoints {
            eyes: corners.clone(),
            pixels_per_radian: pixels_per_radian(1024),
        },
        deviation: None,
    };
    let out = simplify(&input, &params).unwrap();
    validate(n, &triangles, &out).unwrap();
    validate_view_masks(&sets, &out).unwrap();
    let output = out
        .triangles
        .into_iter()
        .filter(|t| regionally_front(t))
        .collect();
    BunnyRun {
        input: triangles.len(),
        output,
    }
}

/// The bunny (43 units, T_l = 4.5, 1024 pixels per 60°) next to the paper's
/// Fig. 6 (MVMesh at 1–6 cells) and Fig. 4 (SVMesh at 7–9 cells), in two
/// stand-ins for the capture's weights and triangle sets (`Variant`). Writes OBJs
/// of the MV meshes at 1 cell and the SV meshes at 7 cells to the temp dir.
#[test]
fn bunny_counts_next_to_the_paper() {
    let Some(mesh) = bunny() else { return };
    let paper = [1605, 945, 554, 392, 330, 306, 259, 254, 239];
    eprintln!(
        "cells | kind | paper | subset, uniform 0.125: in → out | whole, stand-in: in → out (front)"
    );
    let mut whole = Vec::new();
    for k in 1..=9u32 {
        let run = |variant| {
            if k <= 6 {
                bunny_mv(&mesh, k, variant)
            } else {
                bunny_sv(&mesh, k, variant)
            }
        };
        let kind = if k <= 6 { "MV" } else { "SV" };
        let runs = [run(Variant::SubsetUniform), run(Variant::WholeStandin)];
        eprintln!(
            "{k} | {kind} | {} | {} → {} | {} → {}",
            paper[k as usize - 1],
            runs[0].input,
            runs[0].output.len(),
            runs[1].input,
            runs[1].output.len(),
        );
        // Real simplification, not a handful of collapses.
        for r in &runs {
            assert!(r.output.len() * 10 < r.input, "k={k}");
        }
        if k == 1 || k == 7 {
            for (r, name) in runs.iter().zip(["subset-uniform", "whole-standin"]) {
                let path = std::env::temp_dir().join(format!(
                    "hexbake-bunny-{}-{k}cells-{name}.obj",
                    kind.to_lowercase()
                ));
                write_obj(&path, &mesh, &r.output);
                eprintln!("wrote {}", path.display());
            }
        }
        whole.push((kind, runs[1].output.len()));
    }
    // Whole-mesh runs of one kind get coarser with distance (l shrinks).
    for w in whole.windows(2).filter(|w| w[0].0 == w[1].0) {
        assert!(w[1].1 <= w[0].1, "{whole:?}");
    }
}

// ------------------------------------------------- per-model LOD chains (issue 13)

fn model_of(mesh: &TestMesh) -> format::Model {
    let m = format::Mesh {
        positions: mesh.positions.iter().map(|p| p.to_array()).collect(),
        normals: mesh.normals.iter().map(|n| n.to_array()).collect(),
        albedo: vec![[200, 200, 200, 255]; mesh.positions.len()],
        triangles: mesh.triangles.clone(),
    };
    format::Model {
        name: "test".into(),
        source: "test".into(),
        content_hash: [1; 32],
        mesh: m,
        albedo_map: None,
        locked_vertices: Vec::new(),
        chunk_cell: None,
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Each level of a model's chain is a valid simplification of the model, nested
    /// (never more triangles than the finer level), and its error bound is
    /// conservative: every vertex the model's triangles use lies within `max_error`
    /// (≤ the level's ε) of the level's surface, and its carriers say the same.
    #[test]
    fn lod_chain_levels_bound_every_original_vertex(mesh in arb_mesh()) {
        let model = model_of(&mesh);
        let chain = worker::lod_chain::LodChain::build(&model).unwrap();
        prop_assert_eq!(chain.levels.len() as u32, worker::lod_chain::CHAIN_LEVELS);
        let mut used: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
        used.sort_unstable();
        used.dedup();
        let mut finer = mesh.triangles.len();
        for (k, level) in chain.levels.iter().enumerate() {
            let tris = &level.triangles;
            prop_assert!(tris.len() <= finer, "level {} grew", k);
            finer = tris.len();
            prop_assert!(level.max_error <= level.bound * 1.0001, "level {}: {} > ε {}", k, level.max_error, level.bound);
            prop_assert_eq!(level.carried.len(), tris.len());
            let as_output = Simplified { triangles: tris.clone(), ..Simplified::default() };
            validate(mesh.positions.len(), &mesh.triangles, &as_output).unwrap();
            for &v in &used {
                let d = distance_to_surface(&mesh.positions, tris, mesh.positions[v as usize]);
                prop_assert!(d <= level.max_error * 1.0001 + 1e-5,
                    "level {}: vertex {} is {} from the surface, max_error {}", k, v, d, level.max_error);
            }
            let carried = worker::lod_chain::max_carried_distance(&mesh.positions, tris, &level.carried);
            prop_assert!(carried <= level.max_error);
            // Every original vertex is on the level or carried by exactly one triangle.
            let mut count = vec![0u32; mesh.positions.len()];
            tris.iter().flatten().for_each(|&v| count[v as usize] = 1);
            level.carried.iter().flatten().for_each(|&v| count[v as usize] += 1);
            for &v in &used {
                prop_assert_eq!(count[v as usize], 1, "level {}: vertex {}", k, v);
            }
        }
        // Issue 32 item 2: the chain, written and read back, matches its model (a
        // cached chain that failed the check would be rebuilt on every run).
        let file = format::lod::LodChainFile::decode(&chain.to_file(mesh.positions.len() as u32).encode()).unwrap();
        let back = worker::lod_chain::LodChain::from_file(file, &model);
        prop_assert_eq!(back.as_ref(), Ok(&chain));
    }

    /// End to end: a cell's bounded collapse that starts from any chain level, with
    /// the level's carriers, keeps every vertex of the *original* model within the
    /// pixel bound seen from the prism — as if it had started from the full mesh.
    #[test]
    fn deviation_bound_holds_end_to_end_from_a_chain_level(
        mesh in arb_mesh(),
        prism in arb_prism(),
        max_px in prop_oneof![0.25f32..2.0, 2.0f32..200.0],
        level in 0usize..worker::lod_chain::CHAIN_LEVELS as usize,
    ) {
        let model = model_of(&mesh);
        let chain = worker::lod_chain::LodChain::build(&model).unwrap();
        let start = &chain.levels[level];
        // Only a level whose own error the bound allows can be a start (LodChain::start_for).
        let ppr = pixels_per_radian(1024);
        let bound = DeviationBound { max_px, region: prism };
        let allowed = mesh.triangles.iter().flatten().all(|&v| {
            let p = mesh.positions[v as usize];
            let d = distance_to_surface(&mesh.positions, &start.triangles, p);
            d <= bound.world_tolerance(p, ppr)
        });
        prop_assume!(allowed);
        {
            let mut count = vec![0u32; mesh.positions.len()];
            start.triangles.iter().flatten().for_each(|&v| count[v as usize] = 1);
            start.carried.iter().flatten().for_each(|&v| count[v as usize] += 1);
            for &v in mesh.triangles.iter().flatten() {
                prop_assert_eq!(count[v as usize], 1, "vertex {}", v);
            }
        }
        let w = vec![0.25f32; mesh.positions.len()];
        let input = SimplifyInput { triangles: &start.triangles, ..input_of(&mesh, &w) };
        let params = SimplifyParams {
            edge_length_tolerance_px: 1e6,
            length: ProjectedLength::MaxOverPrism { prism, pixels_per_radian: ppr },
            deviation: Some(bound),
        };
        let out = simplify_seeded(&input, &params, Some(start.carried.clone())).unwrap();
        validate(mesh.positions.len(), &start.triangles, &out).unwrap();
        prop_assert_eq!(bound_violation(&mesh, &out.triangles, &bound, ppr), None);
    }

    /// The transform's largest stretch is never below what it does to any vector.
    #[test]
    fn max_stretch_bounds_every_vector(
        cols in prop::array::uniform9(-3.0f32..3.0),
        v in prop::array::uniform3(-1.0f32..1.0),
    ) {
        let m = glam::Mat3::from_cols_array(&cols);
        let t = glam::Mat4::from_mat3(m);
        let v = Vec3::from_array(v);
        prop_assert!((m * v).length() <= worker::lod_chain::max_stretch(t) * v.length() * 1.0001 + 1e-6);
    }
}

/// A chain file round-trips and is refused once damaged, or when made for another
/// model.
#[test]
fn lod_chain_file_round_trips_and_refuses_damage() {
    let mesh = icosphere(2, Vec3::ZERO, 3.0, &[0.3, -0.2, 0.1]);
    let model = model_of(&mesh);
    let chain = worker::lod_chain::LodChain::build(&model).unwrap();
    assert!(chain.levels.last().unwrap().triangles.len() < mesh.triangles.len());
    let bytes = chain.to_file(mesh.positions.len() as u32).encode();
    let file = format::lod::LodChainFile::decode(&bytes).unwrap();
    let back = worker::lod_chain::LodChain::from_file(file.clone(), &model).unwrap();
    assert_eq!(back, chain);
    let other = format::Model {
        content_hash: [2; 32],
        ..model.clone()
    };
    assert!(worker::lod_chain::LodChain::from_file(file, &other).is_err());
    for cut in [0, 10, 95, bytes.len() - 1] {
        assert!(
            format::lod::LodChainFile::decode(&bytes[..cut]).is_err(),
            "cut {cut}"
        );
    }
    let mut flipped = bytes.clone();
    let last = flipped.len() - 1;
    flipped[last] ^= 1;
    assert!(format::lod::LodChainFile::decode(&flipped).is_err());
}

/// Issue 32 item 2: a chain file whose seal is valid but whose content is not the
/// chain of the model it names is refused by [`LodChain::from_file`], saying which
/// level breaks which rule: each forgery below keeps every vertex id valid.
#[test]
fn issue32_lod_chain_files_that_do_not_match_their_model_are_refused() {
    use worker::lod_chain::{ChainMismatch, LodChain};
    let mesh = icosphere(3, Vec3::ZERO, 3.0, &[0.3, -0.2, 0.1, 0.05]);
    let model = model_of(&mesh);
    let chain = LodChain::build(&model).unwrap();
    let file = chain.to_file(mesh.positions.len() as u32);
    let refused = |edit: &dyn Fn(&mut format::lod::LodChainFile)| -> ChainMismatch {
        let mut forged = file.clone();
        edit(&mut forged);
        // Sealed anew: the forgery decodes.
        let forged = format::lod::LodChainFile::decode(&forged.encode()).unwrap();
        LodChain::from_file(forged, &model).unwrap_err()
    };
    let level = |e: &ChainMismatch| match e {
        ChainMismatch::Level { level, what } => (*level, what.clone()),
        other => panic!("not a level's mismatch: {other}"),
    };
    // A triangle of level 3 wound the other way.
    let e = refused(&|f| f.levels[2].triangles[0].swap(1, 2));
    let (k, what) = level(&e);
    assert!(k == 3 && what.contains("not a simplification"), "{e}");
    // One corner moved to another vertex of the level.
    let e = refused(&|f| {
        let t = &mut f.levels[5].triangles;
        let other = t
            .iter()
            .flatten()
            .copied()
            .find(|v| !t[0].contains(v))
            .unwrap();
        t[0][0] = other;
    });
    assert_eq!(level(&e).0, 6, "{e}");
    // The coarsest level replaced by a finer one (its own carriers and error, all
    // consistent) under the coarse bound: not nested below level 11.
    let e = refused(&|f| {
        let bound = f.levels[11].bound;
        f.levels[11] = format::lod::LodLevelData {
            bound,
            ..f.levels[0].clone()
        };
    });
    let (k, what) = level(&e);
    assert!(k == 12 && what.contains("triangles, more than"), "{e}");
    // A recorded error smaller than the carriers' distance.
    let e = refused(&|f| f.levels[4].max_error *= 0.5);
    let (k, what) = level(&e);
    assert!(k == 5 && what.contains("max_error"), "{e}");
    // A carried vertex dropped, and one carried twice.
    let carrier = |f: &format::lod::LodChainFile| {
        f.levels[7]
            .carried
            .iter()
            .position(|c| !c.is_empty())
            .unwrap()
    };
    let e = refused(&|f| {
        let c = carrier(f);
        f.levels[7].carried[c].pop();
    });
    let (k, what) = level(&e);
    assert!(
        k == 8 && what.contains("neither on the level nor carried"),
        "{e}"
    );
    let e = refused(&|f| {
        let c = carrier(f);
        let v = f.levels[7].carried[c][0];
        f.levels[7].carried[c].push(v);
    });
    assert!(level(&e).1.contains("carried twice"), "{e}");
    // A bound that is not the builder's, and a level missing.
    let e = refused(&|f| f.levels[0].bound *= 1.5);
    assert!(level(&e).1.contains("bound"), "{e}");
    let e = refused(&|f| {
        f.levels.pop();
    });
    assert_eq!(
        e,
        ChainMismatch::LevelCount {
            expected: 12,
            found: 11
        }
    );
}

// ---------------------------------------------------------------- UV seams (issue 18)

/// `mesh` with every vertex split per chart that uses it, as a textured model's
/// vertices are along its UV seams: `chart[t]` is triangle t's chart. Positions and
/// normals are copied bit for bit.
fn split_into_charts(mesh: &TestMesh, chart: impl Fn(usize) -> u32) -> TestMesh {
    let mut ids = std::collections::BTreeMap::new();
    let mut out = TestMesh {
        positions: Vec::new(),
        normals: Vec::new(),
        triangles: Vec::new(),
    };
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let c = chart(t);
        out.triangles.push(tri.map(|v| {
            *ids.entry((c, v)).or_insert_with(|| {
                out.positions.push(mesh.positions[v as usize]);
                out.normals.push(mesh.normals[v as usize]);
                out.positions.len() as u32 - 1
            })
        }));
    }
    out
}

/// A cube of half-size `h` at `centre`, each face an `n`×`n` grid with its own
/// vertices and its own (flat) normal, as a textured box has: 24 corners' copies
/// for 8 corners, 6 charts. Shared edges are bit-equal. Face f's triangles are
/// `2n²·f .. 2n²·(f+1)`.
fn seamed_cube(n: u32, centre: Vec3, h: f32) -> TestMesh {
    let coord = |i: u32| -h + 2.0 * h * i as f32 / n as f32;
    let mut mesh = TestMesh {
        positions: Vec::new(),
        normals: Vec::new(),
        triangles: Vec::new(),
    };
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let normal =
                Vec3::from_array(std::array::from_fn(|k| if k == axis { sign } else { 0.0 }));
            // (u, v) axes with u × v = normal.
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let (u, v) = if sign > 0.0 { (u, v) } else { (v, u) };
            let base = mesh.positions.len() as u32;
            for j in 0..=n {
                for i in 0..=n {
                    let mut p = [0.0f32; 3];
                    p[axis] = sign * h;
                    p[u] = coord(i);
                    p[v] = coord(j);
                    mesh.positions.push(centre + Vec3::from_array(p));
                    mesh.normals.push(normal);
                }
            }
            for j in 0..n {
                for i in 0..n {
                    let at = |di: u32, dj: u32| base + (j + dj) * (n + 1) + i + di;
                    mesh.triangles.push([at(0, 0), at(1, 0), at(1, 1)]);
                    mesh.triangles.push([at(0, 0), at(1, 1), at(0, 1)]);
                }
            }
        }
    }
    mesh
}

/// Whether `triangles` close up once vertices at one position count as one: every
/// directed edge has its reverse, and no triangle is degenerate in positions.
fn closed_by_position(positions: &[Vec3], triangles: &[[u32; 3]]) -> Result<(), String> {
    let key = |v: u32| positions[v as usize].to_array().map(f32::to_bits);
    let mut edges: Vec<_> = triangles
        .iter()
        .flat_map(|t| (0..3).map(move |k| (key(t[k]), key(t[(k + 1) % 3]))))
        .collect();
    edges.sort_unstable();
    if let Some(w) = edges.windows(2).find(|w| w[0] == w[1]) {
        return Err(format!("edge {:?} used twice in one direction", w[0]));
    }
    for &(a, b) in &edges {
        if a == b {
            return Err(format!("degenerate edge at {a:?}"));
        }
        if edges.binary_search(&(b, a)).is_err() {
            return Err(format!("open edge {a:?} -> {b:?}"));
        }
    }
    Ok(())
}

/// SV parameters with a huge T_l and a 0.5 px deviation bound from a prism `eye`
/// distance away, so only the bound and the topology rules stop the collapse.
fn bounded_params(prism: Prism) -> (SimplifyParams, DeviationBound) {
    let bound = DeviationBound {
        max_px: 0.5,
        region: prism,
    };
    let params = SimplifyParams {
        edge_length_tolerance_px: 1e9,
        length: ProjectedLength::MaxOverPrism {
            prism,
            pixels_per_radian: pixels_per_radian(256),
        },
        deviation: Some(bound),
    };
    (params, bound)
}

fn prism_at(x: f32, z: f32) -> Prism {
    Prism {
        centre: Vec2::new(x, z),
        cell_size: 10.0,
        min_y: 1.6,
        max_y: 4.0,
    }
}

/// Issue 18: a textured box (split along its UV seams into six faces) simplifies
/// to a closed proxy of a few triangles, not to six loose faces or nothing; every
/// output triangle keeps the copies of its own face (its UVs), and every input
/// vertex stays within the bound.
#[test]
fn uv_seamed_cube_simplifies_to_a_closed_proxy() {
    let mesh = seamed_cube(8, Vec3::new(0.0, 3.0, 40.0), 2.0);
    assert_eq!(mesh.positions.len(), 6 * 81);
    let w = vec![0.125f32; mesh.positions.len()];
    let (params, bound) = bounded_params(prism_at(0.0, 0.0));
    let out = simplify(&input_of(&mesh, &w), &params).unwrap();
    validate(mesh.positions.len(), &mesh.triangles, &out).unwrap();
    closed_by_position(&mesh.positions, &out.triangles).unwrap();
    assert!(
        (12..=48).contains(&out.triangles.len()),
        "{} triangles of {}",
        out.triangles.len(),
        mesh.triangles.len()
    );
    let ppr = pixels_per_radian(256);
    assert_eq!(bound_violation(&mesh, &out.triangles, &bound, ppr), None);
    // Each output triangle's corners are copies of one face (vertex v is on face
    // v / 81).
    for t in &out.triangles {
        assert!(t.iter().all(|&v| v / 81 == t[0] / 81), "{t:?} mixes faces");
    }
}

/// Issue 18: a bumpy sphere split into eight UV charts (by octant) simplifies like
/// the welded sphere: closed, much smaller, within the bound.
#[test]
fn uv_seamed_sphere_simplifies_like_the_welded_one() {
    let sphere = icosphere(3, Vec3::new(0.0, 3.0, 40.0), 3.0, &[0.3, -0.2, 0.1, 0.0]);
    let octant = |t: usize| {
        let c: Vec3 = sphere.triangles[t]
            .iter()
            .map(|&v| sphere.positions[v as usize] - Vec3::new(0.0, 3.0, 40.0))
            .sum();
        u32::from(c.x > 0.0) | u32::from(c.y > 0.0) << 1 | u32::from(c.z > 0.0) << 2
    };
    let mesh = split_into_charts(&sphere, octant);
    assert!(mesh.positions.len() > sphere.positions.len() + 50);
    let (params, bound) = bounded_params(prism_at(0.0, 0.0));
    let w = vec![0.125f32; mesh.positions.len()];
    let out = simplify(&input_of(&mesh, &w), &params).unwrap();
    validate(mesh.positions.len(), &mesh.triangles, &out).unwrap();
    closed_by_position(&mesh.positions, &out.triangles).unwrap();
    let ws = vec![0.125f32; sphere.positions.len()];
    let welded = simplify(&input_of(&sphere, &ws), &params).unwrap();
    assert!(
        out.triangles.len() <= welded.triangles.len() * 3 / 2 + 8,
        "seamed {} vs welded {} triangles",
        out.triangles.len(),
        welded.triangles.len()
    );
    assert!(!out.triangles.is_empty() && out.triangles.len() < mesh.triangles.len() / 2);
    let ppr = pixels_per_radian(256);
    assert_eq!(bound_violation(&mesh, &out.triangles, &bound, ppr), None);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Issue 18: a closed bumpy sphere cut into random charts (any triangle may be
    /// its own chart) stays closed and valid, within the bound, deterministically.
    #[test]
    fn uv_seamed_spheres_stay_closed(
        bumps in prop::collection::vec(-1.0f32..1.0, 1..16),
        charts in prop::collection::vec(0u32..4, 1..40),
        x in -20.0f32..20.0,
        z in -20.0f32..20.0,
    ) {
        let sphere = icosphere(2, Vec3::new(0.0, 3.0, 30.0), 3.0, &bumps);
        let mesh = split_into_charts(&sphere, |t| charts[t % charts.len()]);
        let (params, bound) = bounded_params(prism_at(x, z));
        let w = vec![0.125f32; mesh.positions.len()];
        let out = simplify(&input_of(&mesh, &w), &params).unwrap();
        validate(mesh.positions.len(), &mesh.triangles, &out).unwrap();
        if let Err(e) = closed_by_position(&mesh.positions, &out.triangles) {
            prop_assert!(false, "{}", e);
        }
        prop_assert!(!out.triangles.is_empty());
        let ppr = pixels_per_radian(256);
        prop_assert_eq!(bound_violation(&mesh, &out.triangles, &bound, ppr), None);
        prop_assert_eq!(simplify(&input_of(&mesh, &w), &params).unwrap(), out);
    }
}

/// Issue 18: the speck tidying of the bake (`svmesh::tidy_selection`) on the welded
/// triangles keeps a textured box whole; on its split ids every face is a piece of
/// two triangles, a "speck", and the box was unselected to nothing (the
/// 0-triangle proxies of the textured plaza).
#[test]
fn tidying_keeps_a_uv_seamed_box() {
    let mesh = seamed_cube(1, Vec3::ZERO, 1.0);
    assert_eq!((mesh.positions.len(), mesh.triangles.len()), (24, 12));
    let positions: Vec<[f32; 3]> = mesh.positions.iter().map(|p| p.to_array()).collect();
    let mut split = vec![true; 12];
    worker::svmesh::tidy_selection(&mesh.triangles, &mut split, 4);
    assert!(split.iter().all(|s| !s), "faces of split ids are specks");
    let welded = worker::simplify::welded_triangles(&positions, &mesh.triangles);
    assert!(welded.iter().flatten().all(|&v| v < 24));
    let mut selected = vec![true; 12];
    assert_eq!(worker::svmesh::tidy_selection(&welded, &mut selected, 4), 0);
    assert!(selected.iter().all(|&s| s));
}
