//! Procedural models (for `manifests/demo.ron`, no download needed); their albedo is
//! the procedural pattern of [`crate::pattern`].
//!
//! **Models.** [`build`] makes every name in [`NAMES`]: each is closed, 2-manifold and
//! wound counter-clockwise seen from outside (the tests check it), in arbitrary units
//! (scenes normalise them), y up.

use crate::cleanup::{finish_mesh, RawMesh};
use crate::pattern::apply_albedo;
use format::mesh::Mesh;
use std::f64::consts::PI;

pub use format::model_source::PROCEDURAL_NAMES as NAMES;

/// Builds the procedural model `name` (one of [`NAMES`]); `None` for other names.
pub fn build(name: &str) -> Option<Mesh> {
    let raw = match name {
        "torus_knot" => torus_knot(2, 3, 384, 16),
        "sphere" => icosphere(5),
        "box" => subdivided_box(40),
        "column" => lathe(&column_profile(), 64),
        "vase" => lathe(&vase_profile(), 64),
        "torus" => torus(128, 48, 1.0, 0.4),
        _ => return None,
    };
    let raw = oriented_outward(raw);
    let (mut mesh, _) = finish_mesh(raw).ok()?;
    apply_albedo(&mut mesh, name_seed(name));
    Some(mesh)
}

/// A stable seed for a name (FNV-1a 64).
fn name_seed(name: &str) -> u64 {
    name.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// Flips every triangle when the mesh's signed volume is negative.
fn oriented_outward(mut raw: RawMesh) -> RawMesh {
    let volume: f64 = raw
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| raw.positions[i as usize].map(f64::from));
            a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                + a[2] * (b[0] * c[1] - b[1] * c[0])
        })
        .sum();
    if volume < 0.0 {
        for t in &mut raw.triangles {
            t.swap(1, 2);
        }
    }
    raw
}

fn to_f32(p: [f64; 3]) -> [f32; 3] {
    p.map(|x| x as f32)
}

/// Triangles of a `rows × cols` grid of vertices `index(r, c)`, wrapping in columns
/// always and in rows when `wrap_rows`.
fn grid_triangles(
    rows: usize,
    cols: usize,
    wrap_rows: bool,
    index: impl Fn(usize, usize) -> u32,
) -> Vec<[u32; 3]> {
    let mut tris = Vec::new();
    let row_quads = if wrap_rows { rows } else { rows - 1 };
    for r in 0..row_quads {
        let r1 = (r + 1) % rows;
        for c in 0..cols {
            let c1 = (c + 1) % cols;
            let (a, b, cc, d) = (index(r, c), index(r, c1), index(r1, c1), index(r1, c));
            tris.push([a, b, cc]);
            tris.push([a, cc, d]);
        }
    }
    tris
}

/// A tube around the (p, q) torus knot `((2 + cos qt) cos pt, (2 + cos qt) sin pt,
/// −sin qt)` (standing in the x–y plane), with a parallel-transport frame whose
/// closing twist is spread evenly so the tube closes seamlessly.
fn torus_knot(p: u32, q: u32, segments: usize, ring: usize) -> RawMesh {
    let (p, q) = (f64::from(p), f64::from(q));
    let tube_radius = 0.35;
    let curve = |t: f64| {
        let r = 2.0 + (q * t).cos();
        [r * (p * t).cos(), r * (p * t).sin(), -(q * t).sin()]
    };
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let norm = |a: [f64; 3]| {
        let l = dot(a, a).sqrt();
        a.map(|x| x / l)
    };
    let centres: Vec<[f64; 3]> = (0..segments)
        .map(|i| curve(2.0 * PI * i as f64 / segments as f64))
        .collect();
    let tangents: Vec<[f64; 3]> = (0..segments)
        .map(|i| {
            norm(sub(
                centres[(i + 1) % segments],
                centres[(i + segments - 1) % segments],
            ))
        })
        .collect();
    // Parallel transport of a normal along the curve.
    let mut normals = Vec::with_capacity(segments + 1);
    let t0 = tangents[0];
    let helper = if t0[2].abs() < 0.9 {
        [0.0, 0.0, 1.0]
    } else {
        [1.0, 0.0, 0.0]
    };
    let mut n = norm(cross(cross(t0, helper), t0));
    normals.push(n);
    for i in 1..=segments {
        let t = tangents[i % segments];
        let d = dot(n, t);
        n = norm([n[0] - d * t[0], n[1] - d * t[1], n[2] - d * t[2]]);
        normals.push(n);
    }
    // Closing twist: the angle from the transported normal back to the first one.
    let end = normals[segments];
    let twist = dot(cross(end, normals[0]), t0).atan2(dot(end, normals[0]));
    let mut positions = Vec::with_capacity(segments * ring);
    for i in 0..segments {
        let t = tangents[i];
        let angle = twist * i as f64 / segments as f64;
        let n0 = normals[i];
        let b0 = cross(t, n0);
        let (s, c) = angle.sin_cos();
        let nrm = [0, 1, 2].map(|k| c * n0[k] + s * b0[k]);
        let bin = cross(t, nrm);
        for j in 0..ring {
            let phi = 2.0 * PI * j as f64 / ring as f64;
            let (sp, cp) = phi.sin_cos();
            positions.push(to_f32(
                [0, 1, 2].map(|k| centres[i][k] + tube_radius * (cp * nrm[k] + sp * bin[k])),
            ));
        }
    }
    let triangles = grid_triangles(segments, ring, true, |r, c| (r * ring + c) as u32);
    RawMesh {
        positions,
        colors: None,
        triangles,
    }
}

/// A torus around +y: major radius `major`, tube radius `minor`.
fn torus(segments: usize, ring: usize, major: f64, minor: f64) -> RawMesh {
    let mut positions = Vec::with_capacity(segments * ring);
    for i in 0..segments {
        let theta = 2.0 * PI * i as f64 / segments as f64;
        for j in 0..ring {
            let phi = 2.0 * PI * j as f64 / ring as f64;
            let r = major + minor * phi.cos();
            positions.push(to_f32([
                r * theta.cos(),
                minor * phi.sin(),
                r * theta.sin(),
            ]));
        }
    }
    let triangles = grid_triangles(segments, ring, true, |r, c| (r * ring + c) as u32);
    RawMesh {
        positions,
        colors: None,
        triangles,
    }
}

/// The unit icosphere of [`icosphere`] as plain positions and counter-clockwise
/// (outward) triangles, for tests and tools that build their own meshes from it.
pub fn unit_icosphere(levels: u32) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let raw = icosphere(levels);
    (raw.positions, raw.triangles)
}

/// An icosahedron subdivided `levels` times, projected on the unit sphere.
fn icosphere(levels: u32) -> RawMesh {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut positions: Vec<[f64; 3]> = vec![
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ];
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    let unit = |p: [f64; 3]| {
        let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        p.map(|x| x / l)
    };
    for p in &mut positions {
        *p = unit(*p);
    }
    for _ in 0..levels {
        // Midpoints keyed by their (sorted) edge; BTreeMap keeps it deterministic.
        let mut midpoint: std::collections::BTreeMap<(u32, u32), u32> = Default::default();
        let mut next = Vec::with_capacity(triangles.len() * 4);
        for t in &triangles {
            let mut mid = [0u32; 3];
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                mid[k] = *midpoint.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    let (pa, pb) = (positions[a as usize], positions[b as usize]);
                    positions.push(unit([0, 1, 2].map(|i| (pa[i] + pb[i]) * 0.5)));
                    (positions.len() - 1) as u32
                });
            }
            next.push([t[0], mid[0], mid[2]]);
            next.push([t[1], mid[1], mid[0]]);
            next.push([t[2], mid[2], mid[1]]);
            next.push(mid);
        }
        triangles = next;
    }
    RawMesh {
        positions: positions.into_iter().map(to_f32).collect(),
        colors: None,
        triangles,
    }
}

/// A unit cube whose faces are `n × n` grids. Points come from integer lattice
/// coordinates, so the shared edges of two faces get bit-identical positions and
/// welding closes the box.
fn subdivided_box(n: u32) -> RawMesh {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    let coord = |i: u32| i as f32 / n as f32 - 0.5;
    // (axis fixed, its value 0 or n, the two running axes).
    for axis in 0..3 {
        for side in [0, n] {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let base = positions.len() as u32;
            for i in 0..=n {
                for j in 0..=n {
                    let mut lattice = [0u32; 3];
                    lattice[axis] = side;
                    lattice[u] = i;
                    lattice[v] = j;
                    positions.push(lattice.map(coord));
                }
            }
            let idx = |i: u32, j: u32| base + i * (n + 1) + j;
            for i in 0..n {
                for j in 0..n {
                    let (a, b, c, d) = (idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1));
                    // u × v points along +axis: wind for the outward side.
                    if side == n {
                        triangles.push([a, b, c]);
                        triangles.push([a, c, d]);
                    } else {
                        triangles.push([a, c, b]);
                        triangles.push([a, d, c]);
                    }
                }
            }
        }
    }
    RawMesh {
        positions,
        colors: None,
        triangles,
    }
}

/// Resamples a polyline so no segment is longer than `max_step`, keeping its corners.
fn resample(points: &[[f64; 2]], max_step: f64) -> Vec<[f64; 2]> {
    let mut out = vec![points[0]];
    for w in points.windows(2) {
        let (a, b) = (w[0], w[1]);
        let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
        let steps = (len / max_step).ceil().max(1.0) as usize;
        for s in 1..=steps {
            let f = s as f64 / steps as f64;
            out.push([a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f]);
        }
    }
    out
}

/// A classical column: plinth, a shaft with entasis, a capital (radius, height).
fn column_profile() -> Vec<[f64; 2]> {
    let mut p = vec![[0.0, 0.0], [1.5, 0.0], [1.5, 0.4], [1.2, 0.5], [1.0, 0.65]];
    let shaft_steps = 40;
    for s in 1..=shaft_steps {
        let f = s as f64 / shaft_steps as f64;
        let y = 0.65 + f * (7.4 - 0.65);
        let entasis = 0.06 * (PI * f).sin();
        p.push([1.0 - 0.12 * f + entasis, y]);
    }
    p.extend([[1.15, 7.6], [1.45, 7.9], [1.6, 8.0], [1.6, 8.4], [0.0, 8.4]]);
    resample(&p, 8.4 / 80.0)
}

/// A vase with a real opening: outer wall up, over the lip, inner wall down to a floor.
fn vase_profile() -> Vec<[f64; 2]> {
    let outer = |y: f64| 0.35 + 0.45 * (PI * y / 2.4).sin().max(0.0) + 0.15 * (y / 3.0).powi(4);
    let wall = 0.06;
    let mut p = vec![[0.0, 0.0], [0.4, 0.0]];
    let steps = 60;
    for s in 1..=steps {
        let y = 3.0 * s as f64 / steps as f64;
        p.push([outer(y), y]);
    }
    p.push([outer(3.0) - wall, 3.0]);
    for s in (8..steps).rev() {
        let y = 3.0 * s as f64 / steps as f64;
        p.push([outer(y) - wall, y]);
    }
    p.push([0.0, 0.4]);
    resample(&p, 3.0 / 80.0)
}

/// Surface of revolution of `profile` (radius, height) around +y with `segments`
/// around. The profile starts and ends on the axis (radius 0): those rings collapse
/// to one point, which welding merges, closing the surface.
fn lathe(profile: &[[f64; 2]], segments: usize) -> RawMesh {
    let mut positions = Vec::with_capacity(profile.len() * segments);
    for &[r, y] in profile {
        for j in 0..segments {
            let theta = 2.0 * PI * j as f64 / segments as f64;
            if r == 0.0 {
                positions.push(to_f32([0.0, y, 0.0]));
            } else {
                positions.push(to_f32([r * theta.cos(), y, -r * theta.sin()]));
            }
        }
    }
    let triangles = grid_triangles(profile.len(), segments, false, |r, c| {
        (r * segments + c) as u32
    });
    RawMesh {
        positions,
        colors: None,
        triangles,
    }
}
