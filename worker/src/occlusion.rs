//! Regional conservative occlusion culling (paper 000 §3.1.7, "regional occlusion
//! culling"; 003): an object hidden from *every* point of a cell's prism is culled
//! from that cell.
//!
//! Method: Wonka, Wimmer & Schmalstieg 2000, *Visibility preprocessing with occluder
//! fusion for urban walkthroughs* (EGWR 2000) — occluder shrinking plus point
//! sampling. Its theorem, and why it makes the result conservative:
//!
//! > Let every occluder be shrunk by ε (the shrunk occluder holds the points whose
//! > ε-ball lies in the occluder). If a point q is hidden from a sample point p by
//! > the shrunk occluders, it is hidden by the real occluders from every point p′
//! > with |p′ − p| ≤ ε.
//!
//! Proof: the segment p→q passes through x = p + t(q − p) in a shrunk occluder;
//! the segment p′→q passes through x′ = x + (1 − t)(p′ − p), |x′ − x| ≤ ε, so x′ lies
//! in the real occluder, between p′ and q. This holds ray by ray, so *occluder
//! fusion* is free: different rays may be blocked by different occluders. With
//! sample points whose ε-balls cover the prism ([`sample_points`]), an object hidden
//! from every sample is hidden from every point of the prism.
//!
//! What hexbake adds to make each step provable for any closed mesh a user brings:
//!
//! 1. **Occluders are volumes inside real solids** ([`inscribed_boxes`]): for a model
//!    whose mesh is closed, 2-manifold and consistently wound, up to
//!    [`MAX_BOXES_PER_MODEL`] axis-aligned boxes (in model space) grown from seed
//!    points on the model's vertical centre line, each face pushed out by binary
//!    search while no triangle touches the box (exact triangle–box separating-axis
//!    test in f64, through an obvhs BVH). A box that no triangle touches and whose
//!    centre is inside the solid (odd crossing count along [`PARITY_RAYS`]
//!    directions, all of which must agree) lies wholly inside the solid. An open
//!    mesh gets no occluder. Boxes are computed once per model (cached by content
//!    hash).
//! 2. **Only solids the viewer cannot be in**: an instance occludes for a prism only
//!    if its world bounding box is disjoint from the prism, so every p′ of the
//!    prism is outside the solid, and the surface crossing before x′ is an entry —
//!    a front face, drawn by back-face-culling renderers too.
//! 3. **Shrinking** a box by ε in world space: the model-space box is shrunk by
//!    ε·‖A⁻¹‖ (A the instance's linear part, norm bounded by √(‖·‖₁‖·‖∞)), so the
//!    world ε-ball of every point of the shrunk box lies in the box.
//! 4. **Point visibility, decided conservatively**: from sample p the occludee's
//!    world box Q is projected onto the six faces of a cube around p; each face's
//!    window over Q is split recursively (at most [`OcclusionSettings::max_depth`]
//!    levels) into pyramids with apex p. A pyramid is *blocked* by a shrunk box B
//!    when its four corner rays, parametrised by depth along the face axis, are
//!    inside B over a common depth z* nearer than Q's nearest point: the pyramid's
//!    cross-section at z* is the convex hull of the four corner points, so it lies
//!    in B (convex), and every ray of the pyramid meets B before reaching Q. A
//!    pyramid that misses Q (Q's corners all outside one of its side planes) needs
//!    no blocking. Q is hidden from p when every pyramid is blocked or misses Q;
//!    a pyramid neither blocked nor split further makes Q (conservatively) visible.
//!    Slab tests run in f64 and each shrunk box loses a further 10⁻⁵ of its size, so
//!    rounding can only make a box smaller.
//!
//! 5. **The floor rule.** Every segment from the prism (eyes at y ≥ min_y > 0) to an
//!    occludee standing on or above the ground (y ≥ 0) stays at y > 0 before its
//!    end, so the x′ of the theorem has y > 0: a box whose bottom face is horizontal
//!    and at y ≤ 0 in the world (a building's base) needs no shrinking at the
//!    bottom. Without it, rays to the foot of a statue would pass under every
//!    shrunk wall.
//!
//! The occludee is its instance's world bounding box, so every triangle of it is
//! covered. Deterministic and thread-count independent: a candidate's answer is the
//! AND over samples of a pure function of (sample, candidate).
//!
//! Limits, written down: the guarantee is geometric (for rays); a renderer whose
//! near plane clips an occluding wall (an eye nearer to a wall than `near`) sees
//! through it in the reference frame as well. Occluders that the prism touches
//! (the buildings along a cell's own street) are not used, so what they hide is only
//! culled when farther occluders hide it too.

use crate::grid::Prism;
use format::mesh::Mesh;
use format::Scene;
use glam::{DMat4, DVec3, Vec3, Vec3A};
use obvhs::{
    aabb::Aabb,
    bvh2::{builder::build_bvh2_from_tris, Bvh2},
    ray::Ray,
    triangle::Triangle,
    BvhBuildParams,
};
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Duration;

/// Most occluder boxes kept per model.
pub const MAX_BOXES_PER_MODEL: usize = 4;

/// Directions of the parity rays of the inside test (irrational-looking, so a ray
/// rarely meets an edge or vertex); all must see an odd number of crossings.
pub const PARITY_RAYS: [[f64; 3]; 5] = [
    [0.5773, 0.6211, 0.5301],
    [-0.7072, 0.1913, 0.6803],
    [0.1303, -0.9217, 0.3652],
    [-0.3817, -0.2236, -0.8968],
    [0.8911, 0.3090, -0.3323],
];

/// An axis-aligned box in a model's object space that lies inside the model's solid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OccluderBox {
    pub min: Vec3,
    pub max: Vec3,
}

/// Settings of [`occluded_instances`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OcclusionSettings {
    /// Occluder shrinking and sample-ball radius ε, world units.
    pub epsilon: f32,
    /// Subdivision levels of a cube face's window over the occludee.
    pub max_depth: u32,
}

impl OcclusionSettings {
    /// ε = cell size / 8 (2.5 units for a 20-unit cell), 6 subdivision levels.
    pub fn for_prism(prism: &Prism) -> OcclusionSettings {
        OcclusionSettings {
            epsilon: prism.cell_size / 8.0,
            max_depth: 6,
        }
    }
}

// -------------------------------------------------------------------------------
// Occluders inside closed meshes.

/// The occluder boxes of `mesh` (module docs, step 1); empty for a mesh that is not
/// closed, or whose centre line never lies inside it.
pub fn inscribed_boxes(mesh: &Mesh) -> Vec<OccluderBox> {
    let Some((lo, hi)) = mesh.bounds() else {
        return Vec::new();
    };
    if mesh.triangles.is_empty() || !mesh.edge_topology().is_closed_manifold() {
        return Vec::new();
    }
    let solid = Solid::new(mesh);
    let (lo, hi) = (Vec3::from(lo).as_dvec3(), Vec3::from(hi).as_dvec3());
    let size = hi - lo;
    let diag = size.length();
    if !(diag > 0.0 && diag.is_finite()) {
        return Vec::new();
    }
    let cx = 0.5 * (lo.x + hi.x);
    let cz = 0.5 * (lo.z + hi.z);
    let mut boxes: Vec<(DVec3, DVec3)> = Vec::new();
    let mut y = lo.y + 0.02 * size.y;
    while boxes.len() < MAX_BOXES_PER_MODEL && y < hi.y {
        let seed = DVec3::new(cx, y, cz);
        let in_a_box = boxes
            .iter()
            .any(|(a, b)| seed.cmpge(*a).all() && seed.cmple(*b).all());
        if in_a_box || !solid.inside(seed) {
            y += 0.05 * size.y;
            continue;
        }
        match solid.grow(seed, lo, hi, diag) {
            Some((a, b)) => {
                y = b.y + 0.02 * size.y;
                // Keep boxes that are not slivers (a fortieth of the model's size).
                if (b - a).min_element() > diag / 40.0 {
                    boxes.push((a, b));
                }
            }
            None => y += 0.05 * size.y,
        }
    }
    boxes
        .into_iter()
        .map(|(a, b)| OccluderBox {
            min: a.as_vec3(),
            max: b.as_vec3(),
        })
        .filter(|b| b.min.cmplt(b.max).all())
        .collect()
}

/// A closed mesh with a BVH, for the inside test and triangle–box queries.
struct Solid {
    bvh: Bvh2,
    triangles: Vec<Triangle>,
    exact: Vec<[DVec3; 3]>,
}

impl Solid {
    fn new(mesh: &Mesh) -> Solid {
        let at = |i: u32| Vec3::from(mesh.positions[i as usize]);
        let exact: Vec<[DVec3; 3]> = mesh
            .triangles
            .iter()
            .map(|t| t.map(|i| at(i).as_dvec3()))
            .collect();
        let triangles: Vec<Triangle> = mesh
            .triangles
            .iter()
            .map(|t| Triangle {
                v0: Vec3A::from(at(t[0])),
                v1: Vec3A::from(at(t[1])),
                v2: Vec3A::from(at(t[2])),
            })
            .collect();
        let bvh = build_bvh2_from_tris(
            &triangles,
            BvhBuildParams::fast_build(),
            &mut Duration::default(),
        );
        Solid {
            bvh,
            triangles,
            exact,
        }
    }

    /// Odd crossing count along every parity ray.
    fn inside(&self, p: DVec3) -> bool {
        PARITY_RAYS.iter().all(|d| {
            let dir = Vec3A::from(DVec3::from(*d).normalize().as_vec3());
            let ray = Ray::new_inf(Vec3A::from(p.as_vec3()), dir);
            let mut crossings = 0u32;
            self.bvh.ray_traverse_anyhit(ray, |ray, id| {
                let t = self.bvh.primitive_indices[id] as usize;
                if self.triangles[t].intersect(ray) < f32::INFINITY {
                    crossings += 1;
                }
            });
            crossings % 2 == 1
        })
    }

    /// Whether any triangle meets the interior of the box `(a, b)`.
    fn touches(&self, a: DVec3, b: DVec3) -> bool {
        let query = Aabb {
            min: Vec3A::from(a.as_vec3()) - Vec3A::splat(1e-3),
            max: Vec3A::from(b.as_vec3()) + Vec3A::splat(1e-3),
        };
        let mut hit = false;
        self.bvh.aabb_traverse(query, |bvh, node_index| {
            let node = &bvh.nodes[node_index as usize];
            for k in node.first_index..node.first_index + node.prim_count {
                let t = bvh.primitive_indices[k as usize] as usize;
                if triangle_meets_open_box(&self.exact[t], a, b) {
                    hit = true;
                    return false;
                }
            }
            true
        });
        hit
    }

    /// The box grown from `seed` (module docs, step 1), within the bounds `[lo, hi]`.
    fn grow(&self, seed: DVec3, lo: DVec3, hi: DVec3, diag: f64) -> Option<(DVec3, DVec3)> {
        let start = diag * 1e-4;
        let (mut a, mut b) = (seed - DVec3::splat(start), seed + DVec3::splat(start));
        if self.touches(a, b) {
            return None;
        }
        // Uniform growth first (a cube-like start), then each face on its own.
        let free = |a: DVec3, b: DVec3| !self.touches(a, b);
        // The largest s in [0, 1] (to 2⁻²⁴) whose box f(s) is free (f(0) is).
        let grow_by = |f: &dyn Fn(f64) -> (DVec3, DVec3)| -> (DVec3, DVec3) {
            let (mut ok, mut bad) = (0.0f64, 1.0f64);
            if free(f(1.0).0, f(1.0).1) {
                return f(1.0);
            }
            for _ in 0..24 {
                let mid = 0.5 * (ok + bad);
                let (x, y) = f(mid);
                if free(x, y) {
                    ok = mid;
                } else {
                    bad = mid;
                }
            }
            f(ok)
        };
        let reach = (seed - lo).min(hi - seed).min_element();
        (a, b) = grow_by(&|s: f64| {
            let r = start + s * (reach - start).max(0.0);
            (seed - DVec3::splat(r), seed + DVec3::splat(r))
        });
        for _round in 0..2 {
            for axis in 0..3 {
                for upper in [false, true] {
                    let (a0, b0) = (a, b);
                    (a, b) = grow_by(&|s: f64| {
                        let (mut x, mut y) = (a0, b0);
                        if upper {
                            y[axis] = b0[axis] + s * (hi[axis] - b0[axis]).max(0.0);
                        } else {
                            x[axis] = a0[axis] - s * (a0[axis] - lo[axis]).max(0.0);
                        }
                        (x, y)
                    });
                }
            }
        }
        // No triangle meets the open box, which is connected: it is inside the
        // solid if its centre is (and its closure inside the closed solid).
        if !self.inside(0.5 * (a + b)) {
            return None;
        }
        Some((a, b))
    }
}

/// Separating-axis test (Akenine-Möller 2001) of a closed triangle against the
/// *open* box `(a, b)`, in f64: true when the triangle meets the box's interior. A
/// triangle lying in a face's plane (a model's flat base under a box resting on it)
/// does not.
pub fn triangle_meets_open_box(t: &[DVec3; 3], a: DVec3, b: DVec3) -> bool {
    let c = 0.5 * (a + b);
    let h = 0.5 * (b - a);
    let v = t.map(|p| p - c);
    let separated = |p: [f64; 3], r: f64| {
        let lo = p[0].min(p[1]).min(p[2]);
        let hi = p[0].max(p[1]).max(p[2]);
        lo >= r || hi <= -r
    };
    // Box axes.
    for k in 0..3 {
        if separated([v[0][k], v[1][k], v[2][k]], h[k]) {
            return false;
        }
    }
    // Triangle normal, then edge × box axis.
    let e = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
    let mut axes = vec![e[0].cross(e[1])];
    for edge in e {
        for k in 0..3 {
            let mut axis = DVec3::ZERO;
            axis[k] = 1.0;
            axes.push(edge.cross(axis));
        }
    }
    for axis in axes {
        if axis.length_squared() == 0.0 {
            continue;
        }
        if separated(v.map(|x| x.dot(axis)), h.dot(axis.abs())) {
            return false;
        }
    }
    true
}

/// The occluder boxes of a model, computed once per content hash for the process.
pub fn model_occluders(model: &format::Model) -> Arc<Vec<OccluderBox>> {
    type Cache = Mutex<BTreeMap<[u8; 32], Arc<Vec<OccluderBox>>>>;
    static CACHE: OnceLock<Cache> = OnceLock::new();
    let cache = CACHE.get_or_init(|| Mutex::new(BTreeMap::new()));
    if let Some(found) = cache.lock().unwrap().get(&model.content_hash) {
        return found.clone();
    }
    let boxes = Arc::new(inscribed_boxes(&model.mesh));
    cache
        .lock()
        .unwrap()
        .entry(model.content_hash)
        .or_insert(boxes)
        .clone()
}

// -------------------------------------------------------------------------------
// Sample points.

/// Sample points whose ε-balls cover the prism (module docs): the prism's height is
/// cut into `⌈h/ε⌉` layers of half-thickness `hy ≤ ε/2`, the hexagon's bounding
/// rectangle into square columns of half-side `hx = √((ε² − hy²)/2)` (so every box
/// of half-sizes (hx, hy, hx) has half-diagonal ≤ ε), and the centre of every box
/// that meets the prism is a sample. Ordered by a fixed stride so that early
/// samples spread over the cell (visible objects are found quickly).
pub fn sample_points(prism: &Prism, epsilon: f32) -> Vec<Vec3> {
    let eps = f64::from(epsilon.max(1e-6));
    let height = f64::from(prism.max_y - prism.min_y).max(0.0);
    let layers = ((height / eps).ceil() as usize).max(1);
    let hy = height / (2.0 * layers as f64);
    let hx_max = ((eps * eps - hy * hy) / 2.0).sqrt();
    let c = f64::from(prism.cell_size);
    let (w, d) = (2.0 * c, 3f64.sqrt() * c);
    let nx = ((w / (2.0 * hx_max)).ceil() as usize).max(1);
    let nz = ((d / (2.0 * hx_max)).ceil() as usize).max(1);
    let (hx, hz) = (w / (2.0 * nx as f64), d / (2.0 * nz as f64));
    let x0 = f64::from(prism.centre.x) - c;
    let z0 = f64::from(prism.centre.y) - 0.5 * d;
    let mut points = Vec::new();
    for l in 0..layers {
        let y = f64::from(prism.min_y) + (2 * l + 1) as f64 * hy;
        for j in 0..nz {
            for i in 0..nx {
                let x = x0 + (2 * i + 1) as f64 * hx;
                let z = z0 + (2 * j + 1) as f64 * hz;
                let lo = DVec3::new(x - hx, y - hy, z - hz).as_vec3();
                let hi = DVec3::new(x + hx, y + hy, z + hz).as_vec3();
                if prism.intersects_aabb(lo, hi) {
                    points.push(DVec3::new(x, y, z).as_vec3());
                }
            }
        }
    }
    // A stride coprime with the count visits every point once, spread out.
    let n = points.len();
    let mut stride = (n as f64 * 0.618_034) as usize | 1;
    while n > 1 && gcd(stride, n) != 1 {
        stride += 2;
    }
    (0..n).map(|k| points[(k * stride) % n.max(1)]).collect()
}

fn gcd(a: usize, b: usize) -> usize {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

// -------------------------------------------------------------------------------
// Point visibility against shrunk boxes.

/// A shrunk occluder box placed in the world: a model-space box and the world →
/// model transform.
#[derive(Clone, Copy, Debug)]
struct WorldBox {
    to_model: DMat4,
    lo: DVec3,
    hi: DVec3,
    /// `lo` with the bottom not shrunk, for a box resting on the ground (module docs,
    /// "the floor rule"); equal to `lo` otherwise.
    lo_floor: DVec3,
    /// World-space corners of the shrunk box (with the floor rule's bottom).
    corners: [DVec3; 8],
}

impl WorldBox {
    /// The depth interval `[t_in, t_out]` of the ray `origin + t·dir` inside the box.
    fn interval(&self, origin: DVec3, dir: DVec3, floor: bool) -> (f64, f64) {
        let lo = if floor { self.lo_floor } else { self.lo };
        let o = self.to_model.transform_point3(origin);
        let d = self.to_model.transform_vector3(dir);
        let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
        for k in 0..3 {
            if d[k] == 0.0 {
                if o[k] < lo[k] || o[k] > self.hi[k] {
                    return (1.0, 0.0);
                }
                continue;
            }
            let a = (lo[k] - o[k]) / d[k];
            let b = (self.hi[k] - o[k]) / d[k];
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
        (t0, t1)
    }
}

/// `√(‖M‖₁·‖M‖∞)`, an upper bound of the spectral norm of a 3×3 matrix.
fn norm_bound(m: glam::DMat3) -> f64 {
    let cols = [m.x_axis, m.y_axis, m.z_axis];
    let one = cols
        .iter()
        .map(|c| c.abs().element_sum())
        .fold(0.0, f64::max);
    let inf = (0..3)
        .map(|r| cols.iter().map(|c| c[r].abs()).sum::<f64>())
        .fold(0.0, f64::max);
    (one * inf).sqrt()
}

/// The shrunk world boxes of every instance whose world box does not meet `prism`.
fn world_boxes(scene: &Scene, prism: &Prism, epsilon: f64) -> Vec<(u32, WorldBox)> {
    let mut out = Vec::new();
    for (i, inst) in scene.instances.iter().enumerate() {
        let Some(model) = scene.models.get(inst.model as usize) else {
            continue;
        };
        let (lo, hi) = scene.instance_bounds(i);
        if prism.intersects_aabb(lo, hi) {
            continue;
        }
        let boxes = model_occluders(model);
        if boxes.is_empty() {
            continue;
        }
        let m: DMat4 = inst.transform.as_dmat4();
        if m.determinant().abs() < 1e-12 || !m.is_finite() {
            continue;
        }
        let to_model = m.inverse();
        let linear_inverse = glam::DMat3::from_mat4(to_model);
        let shrink_model = epsilon * norm_bound(linear_inverse);
        // Model y maps to world +y and model x, z stay horizontal: a box face at
        // model y = const is horizontal in the world.
        let upright = m.x_axis.y == 0.0
            && m.z_axis.y == 0.0
            && m.y_axis.x == 0.0
            && m.y_axis.z == 0.0
            && m.y_axis.y > 0.0;
        for b in boxes.iter() {
            let (a0, c0) = (b.min.as_dvec3(), b.max.as_dvec3());
            // ε in world, then 1e-5 of the box's size against rounding.
            let s = shrink_model + 1e-5 * (c0 - a0).max_element() + 1e-9;
            let (a, c) = (a0 + DVec3::splat(s), c0 - DVec3::splat(s));
            if !(a.cmplt(c).all()) {
                continue;
            }
            let rests_on_floor = upright && m.transform_point3(a0).y <= 0.0;
            let lo_floor = if rests_on_floor {
                DVec3::new(a.x, a0.y, a.z)
            } else {
                a
            };
            let corners = std::array::from_fn(|k| {
                m.transform_point3(DVec3::new(
                    if k & 1 == 0 { lo_floor.x } else { c.x },
                    if k & 2 == 0 { lo_floor.y } else { c.y },
                    if k & 4 == 0 { lo_floor.z } else { c.z },
                ))
            });
            out.push((
                i as u32,
                WorldBox {
                    to_model,
                    lo: a,
                    hi: c,
                    lo_floor,
                    corners,
                },
            ));
        }
    }
    out
}

/// One face of the cube around a sample: axis and the two window directions.
#[derive(Clone, Copy)]
struct Face {
    axis: DVec3,
    u: DVec3,
    v: DVec3,
}

const FACES: [Face; 6] = [
    Face {
        axis: DVec3::X,
        u: DVec3::Y,
        v: DVec3::Z,
    },
    Face {
        axis: DVec3::NEG_X,
        u: DVec3::Y,
        v: DVec3::Z,
    },
    Face {
        axis: DVec3::Y,
        u: DVec3::Z,
        v: DVec3::X,
    },
    Face {
        axis: DVec3::NEG_Y,
        u: DVec3::Z,
        v: DVec3::X,
    },
    Face {
        axis: DVec3::Z,
        u: DVec3::X,
        v: DVec3::Y,
    },
    Face {
        axis: DVec3::NEG_Z,
        u: DVec3::X,
        v: DVec3::Y,
    },
];

/// A window `[u0, u1] × [v0, v1]` on a face (directions axis + u·U + v·V).
#[derive(Clone, Copy, Debug)]
struct Window {
    u0: f64,
    u1: f64,
    v0: f64,
    v1: f64,
}

/// The window and a lower bound of the depth of the convex hull of `points` seen
/// from `p` within `face`'s frustum; `None` when the hull misses the frustum. Inside
/// the frustum `|w·U| ≤ z` and `|w·V| ≤ z`, so the depth is at least the hull's
/// distance from p along U and along V, as well as its least depth. When some
/// points are behind the face's plane, the window is the whole face.
fn window_of(points: &[DVec3], p: DVec3, face: &Face) -> Option<(Window, f64)> {
    let (mut z0, mut z1) = (f64::INFINITY, f64::NEG_INFINITY);
    let (mut a0, mut a1, mut b0, mut b1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    let (mut u0, mut u1, mut v0, mut v1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    let mut behind = false;
    for &c in points {
        let w = c - p;
        let (z, a, b) = (w.dot(face.axis), w.dot(face.u), w.dot(face.v));
        z0 = z0.min(z);
        z1 = z1.max(z);
        a0 = a0.min(a);
        a1 = a1.max(a);
        b0 = b0.min(b);
        b1 = b1.max(b);
        if z <= 0.0 {
            behind = true;
            continue;
        }
        u0 = u0.min(a / z);
        u1 = u1.max(a / z);
        v0 = v0.min(b / z);
        v1 = v1.max(b / z);
    }
    let gap = |lo: f64, hi: f64| (lo.max(0.0)).max(-hi).max(0.0);
    let depth = z0.max(gap(a0, a1)).max(gap(b0, b1));
    if z1 <= 0.0 || depth > z1 {
        return None;
    }
    let window = if behind {
        Window {
            u0: -1.0,
            u1: 1.0,
            v0: -1.0,
            v1: 1.0,
        }
    } else {
        Window {
            u0: u0.max(-1.0),
            u1: u1.min(1.0),
            v0: v0.max(-1.0),
            v1: v1.min(1.0),
        }
    };
    if window.u0 > window.u1 || window.v0 > window.v1 {
        return None;
    }
    Some((window, depth))
}

fn box_corners(lo: Vec3, hi: Vec3) -> [DVec3; 8] {
    crate::view::box_corners(lo, hi).map(|c| c.as_dvec3())
}

/// Whether the box with `corners` is hidden from `p` by the shrunk boxes `boxes`
/// (module docs, step 4).
fn hidden_from(
    p: DVec3,
    corners: &[DVec3; 8],
    boxes: &[&WorldBox],
    floor: bool,
    max_depth: u32,
) -> bool {
    let lo = corners[0];
    let hi = corners[7];
    if p.cmpge(lo).all() && p.cmple(hi).all() {
        return false;
    }
    for face in &FACES {
        let Some((window, q_depth)) = window_of(corners, p, face) else {
            continue;
        };
        if q_depth <= 0.0 {
            // Q reaches the viewer's plane: nothing can be in front of all of it.
            return false;
        }
        // Boxes that can block part of this window before Q.
        let relevant: Vec<&WorldBox> = boxes
            .iter()
            .copied()
            .filter(|b| {
                window_of(&b.corners, p, face).is_some_and(|(w, d)| {
                    d < q_depth
                        && w.u0 <= window.u1
                        && w.u1 >= window.u0
                        && w.v0 <= window.v1
                        && w.v1 >= window.v0
                })
            })
            .collect();
        if relevant.is_empty() {
            return false;
        }
        let query = Query {
            p,
            face,
            q: corners,
            q_depth,
            boxes: &relevant,
            floor,
        };
        if !query.window_blocked(window, max_depth) {
            return false;
        }
    }
    true
}

/// One sample, one cube face, one occludee.
struct Query<'a> {
    p: DVec3,
    face: &'a Face,
    q: &'a [DVec3; 8],
    q_depth: f64,
    boxes: &'a [&'a WorldBox],
    /// The floor rule applies (module docs).
    floor: bool,
}

impl Query<'_> {
    /// Every ray of the pyramid (p, face, window) towards Q meets a box before depth
    /// `q_depth`, or the pyramid misses Q.
    fn window_blocked(&self, w: Window, depth_left: u32) -> bool {
        let (p, face, q, q_depth) = (self.p, self.face, self.q, self.q_depth);
        // Misses Q: every corner of Q outside one side plane of the pyramid.
        let outside = |f: &dyn Fn(DVec3) -> f64| q.iter().all(|&c| f(c - p) < 0.0);
        if outside(&|x| x.dot(face.u) - w.u0 * x.dot(face.axis))
            || outside(&|x| w.u1 * x.dot(face.axis) - x.dot(face.u))
            || outside(&|x| x.dot(face.v) - w.v0 * x.dot(face.axis))
            || outside(&|x| w.v1 * x.dot(face.axis) - x.dot(face.v))
        {
            return true;
        }
        let dirs = [
            face.axis + w.u0 * face.u + w.v0 * face.v,
            face.axis + w.u1 * face.u + w.v0 * face.v,
            face.axis + w.u1 * face.u + w.v1 * face.v,
            face.axis + w.u0 * face.u + w.v1 * face.v,
        ];
        for b in self.boxes {
            let (mut t_in, mut t_out) = (0.0f64, q_depth);
            for d in &dirs {
                let (a, c) = b.interval(p, *d, self.floor);
                t_in = t_in.max(a);
                t_out = t_out.min(c);
                if t_in >= t_out {
                    break;
                }
            }
            if t_in < t_out {
                return true;
            }
        }
        if depth_left == 0 {
            return false;
        }
        let um = 0.5 * (w.u0 + w.u1);
        let vm = 0.5 * (w.v0 + w.v1);
        let quarters = [
            Window {
                u0: w.u0,
                u1: um,
                v0: w.v0,
                v1: vm,
            },
            Window {
                u0: um,
                u1: w.u1,
                v0: w.v0,
                v1: vm,
            },
            Window {
                u0: w.u0,
                u1: um,
                v0: vm,
                v1: w.v1,
            },
            Window {
                u0: um,
                u1: w.u1,
                v0: vm,
                v1: w.v1,
            },
        ];
        quarters
            .iter()
            .all(|&sub| self.window_blocked(sub, depth_left - 1))
    }
}

/// Per candidate instance: hidden from every point of `prism` (module docs). Any
/// prism works (a cell's, or a larger one around a group of cells). Instances that
/// meet the prism are never hidden. Deterministic for any thread count.
pub fn occluded_instances(
    scene: &Scene,
    prism: &Prism,
    candidates: &[u32],
    settings: &OcclusionSettings,
) -> Vec<bool> {
    let boxes = world_boxes(scene, prism, f64::from(settings.epsilon));
    if boxes.is_empty() || candidates.is_empty() {
        return vec![false; candidates.len()];
    }
    let samples: Vec<DVec3> = sample_points(prism, settings.epsilon)
        .into_iter()
        .map(Vec3::as_dvec3)
        .collect();
    candidates
        .par_iter()
        .map(|&i| {
            let Some(_) = scene.instances.get(i as usize) else {
                return false;
            };
            let (lo, hi) = scene.instance_bounds(i as usize);
            if prism.intersects_aabb(lo, hi) || !(lo.is_finite() && hi.is_finite()) {
                return false;
            }
            let corners = box_corners(lo, hi);
            let floor = prism.min_y > 0.0 && lo.y >= 0.0;
            let others: Vec<&WorldBox> = boxes
                .iter()
                .filter(|(owner, _)| *owner != i)
                .map(|(_, b)| b)
                .collect();
            samples
                .iter()
                .all(|&p| hidden_from(p, &corners, &others, floor, settings.max_depth))
        })
        .collect()
}

/// World-space shrunk occluder boxes for `prism` as (instance, 8 corners), for
/// pictures and tests.
pub fn shrunk_occluders(scene: &Scene, prism: &Prism, epsilon: f32) -> Vec<(u32, [Vec3; 8])> {
    world_boxes(scene, prism, f64::from(epsilon))
        .into_iter()
        .map(|(i, b)| (i, b.corners.map(|c| c.as_vec3())))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use format::{Ground, Instance, Model};
    use glam::{Mat4, Vec2};

    fn cube(lo: [f32; 3], hi: [f32; 3]) -> Mesh {
        Mesh::cuboid(lo, hi, [200, 200, 200, 255])
    }

    fn model(mesh: Mesh) -> Model {
        Model::new("m".into(), "test".into(), mesh, None)
    }

    #[test]
    fn a_cube_gets_one_box_inside_it() {
        let mesh = cube([-1.0, 0.0, -2.0], [1.0, 3.0, 2.0]);
        assert!(mesh.signed_volume() > 0.0);
        let boxes = inscribed_boxes(&mesh);
        assert_eq!(boxes.len(), 1, "{boxes:?}");
        let b = boxes[0];
        assert!(b.min.cmpge(Vec3::new(-1.0, 0.0, -2.0)).all());
        assert!(b.max.cmple(Vec3::new(1.0, 3.0, 2.0)).all());
        // Nearly the whole cube.
        assert!(
            (b.max - b.min).cmpgt(Vec3::new(1.99, 2.99, 3.99)).all(),
            "{b:?}"
        );
    }

    #[test]
    fn an_open_mesh_gets_no_box() {
        let mut mesh = cube([0.0; 3], [1.0; 3]);
        mesh.triangles.pop();
        assert!(inscribed_boxes(&mesh).is_empty());
    }

    #[test]
    fn samples_cover_the_prism() {
        let prism = Prism {
            centre: Vec2::new(10.0, -4.0),
            cell_size: 20.0,
            min_y: 1.0,
            max_y: 3.0,
        };
        let eps = 2.5;
        let samples = sample_points(&prism, eps);
        assert!(
            samples.len() > 20 && samples.len() < 400,
            "{}",
            samples.len()
        );
        for k in 0..2000u32 {
            let f =
                |s: u32| ((k.wrapping_mul(2654435761).wrapping_add(s) % 10007) as f32) / 10007.0;
            let x = prism.sample(f(1), f(7919), f(104729));
            let nearest = samples
                .iter()
                .map(|s| s.distance(x))
                .fold(f32::INFINITY, f32::min);
            assert!(
                nearest <= eps * 1.0001,
                "{x} is {nearest} from every sample"
            );
        }
    }

    /// A wall between the cell and a small box hides it; without the wall, or with a
    /// wall too thin to survive shrinking, nothing is culled.
    #[test]
    fn a_wall_hides_what_is_behind_it() {
        let wall = cube([-40.0, 0.0, -3.0], [40.0, 30.0, 3.0]);
        let thin = cube([-40.0, 0.0, -0.5], [40.0, 30.0, 0.5]);
        let target = cube([-1.0, 0.0, -1.0], [1.0, 2.0, 1.0]);
        let scene_with = |wall: Mesh| Scene {
            models: vec![model(wall), model(target.clone())],
            instances: vec![
                Instance {
                    model: 0,
                    transform: Mat4::from_translation(Vec3::new(0.0, 0.0, 30.0)),
                    tint: Vec3::ONE,
                },
                Instance {
                    model: 1,
                    transform: Mat4::from_translation(Vec3::new(0.0, 0.0, 50.0)),
                    tint: Vec3::ONE,
                },
            ],
            ground: Ground {
                min: [-100.0, -100.0],
                max: [100.0, 100.0],
            },
            model_bounds: Default::default(),
            instance_labels: Default::default(),
        };
        let prism = Prism {
            centre: Vec2::new(0.0, 0.0),
            cell_size: 20.0,
            min_y: 1.0,
            max_y: 3.0,
        };
        let settings = OcclusionSettings::for_prism(&prism);
        let hidden = occluded_instances(&scene_with(wall), &prism, &[1], &settings);
        assert_eq!(hidden, vec![true]);
        let hidden = occluded_instances(&scene_with(thin), &prism, &[1], &settings);
        assert_eq!(hidden, vec![false]);
        // The wall itself is never hidden.
        let hidden = occluded_instances(
            &scene_with(cube([-40.0, 0.0, -3.0], [40.0, 30.0, 3.0])),
            &prism,
            &[0],
            &settings,
        );
        assert_eq!(hidden, vec![false]);
    }
}
