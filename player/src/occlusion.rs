//! Run-time occlusion culling of proxy tiles (000 §3.2, run-time step (3): "a
//! run-time occlusion culling for all meshes", there left optional and off in the
//! paper's configuration C; here on by default, `--no-occlusion` turns it off).
//!
//! The method is a masked software depth buffer in the spirit of the hierarchical
//! Z-buffer (000 ref. [5]) and masked occlusion culling: the frame's original
//! triangles (the occluders: opaque, drawn before the proxies) are rasterised on the
//! CPU at the frame's own resolution into 8×8-pixel tiles, each keeping a 64-bit mask
//! of the pixel centres covered and the farthest depth over them; a proxy tile's box
//! is hidden when every pixel of its projected rectangle (widened by one pixel) is
//! covered by occluders all nearer than the box's nearest corner.
//!
//! It is conservative at the frame's resolution: coverage is tested at the same pixel
//! centres the GPU samples, only front faces (the GPU culls back faces) and only the
//! parts in front of the near plane and within the far plane count, depth is bounded
//! from above per tile (depth is affine in screen space, so its maximum over a tile
//! lies at a corner or a vertex), and the depth comparison keeps a margin. What it
//! does not reproduce exactly is the GPU's sub-pixel snapping on a silhouette edge;
//! the one-pixel widening means such a pixel only matters where other occluders
//! surround it, i.e. at a crack between two occluders (documented in the player
//! README, "Occlusion culling").

use crate::camera::{Aabb, Camera};
use glam::{Mat4, Vec3, Vec4};

/// Pixels on a side of one tile (a tile's coverage is one `u64`).
const TILE: usize = 8;

/// Depth margin (NDC depth, Depth32Float) below a box's nearest depth that the
/// occluders must keep to hide it: about 16 float steps at depth 1, more than the
/// GPU's interpolation error, so equal depths never count as hidden.
const DEPTH_MARGIN: f32 = 2e-6;

/// The frame's occluders, rasterised (see the module comment).
#[derive(Clone)]
pub struct OcclusionMap {
    clip: Mat4,
    width: usize,
    height: usize,
    tiles_x: usize,
    /// Per tile: pixel centres covered (bit `row * 8 + column`).
    mask: Vec<u64>,
    /// Per tile: the farthest NDC depth of the occluders over its covered pixels.
    zmax: Vec<f32>,
}

/// A clipped vertex in pixel coordinates (y down) with its NDC depth.
#[derive(Clone, Copy, Debug)]
struct Screen {
    x: f32,
    y: f32,
    z: f32,
}

impl OcclusionMap {
    /// An empty map for `camera`'s frame (nothing hides anything yet).
    pub fn new(camera: &Camera) -> OcclusionMap {
        let (width, height) = (camera.width.max(1) as usize, camera.height.max(1) as usize);
        let (tiles_x, tiles_y) = (width.div_ceil(TILE), height.div_ceil(TILE));
        OcclusionMap {
            clip: camera.clip_from_world_wgpu(),
            width,
            height,
            tiles_x,
            mask: vec![0; tiles_x * tiles_y],
            zmax: vec![0.0; tiles_x * tiles_y],
        }
    }

    /// Rasterises the triangles `tris` of `positions` (object space) placed by
    /// `model` (object → world).
    pub fn add_mesh<'t>(
        &mut self,
        model: &Mat4,
        positions: &[[f32; 3]],
        tris: impl Iterator<Item = &'t [u32; 3]>,
    ) {
        let m = self.clip * *model;
        for t in tris {
            let mut clip = [Vec4::ZERO; 3];
            let mut ok = true;
            for (c, &i) in clip.iter_mut().zip(t) {
                match positions.get(i as usize) {
                    Some(p) => *c = m * Vec3::from(*p).extend(1.0),
                    None => ok = false,
                }
            }
            if ok {
                self.add_clip_triangle(clip);
            }
        }
    }

    /// Rasterises the triangles of `ranges` (vertex ranges [start, end), three
    /// vertices per triangle) of the world-space `positions`.
    pub fn add_world(&mut self, positions: &[[f32; 3]], ranges: &[(u32, u32)]) {
        for &(s, e) in ranges {
            let Some(run) = positions.get(s as usize..e as usize) else {
                continue;
            };
            for t in run.chunks_exact(3) {
                let v = |i: usize| self.clip * Vec3::from(t[i]).extend(1.0);
                self.add_clip_triangle([v(0), v(1), v(2)]);
            }
        }
    }

    /// Clips a triangle (wgpu clip space) to 0 ≤ z ≤ w and rasterises what is left.
    fn add_clip_triangle(&mut self, tri: [Vec4; 3]) {
        if tri.iter().all(|v| v.z >= 0.0 && v.z <= v.w) {
            self.add_screen_triangle(tri.map(|v| self.to_screen(v)));
            return;
        }
        let near = clip_polygon(&tri, |v| v.z);
        let poly = clip_polygon(&near, |v| v.w - v.z);
        if poly.len() < 3 {
            return;
        }
        let s: Vec<Screen> = poly.iter().map(|v| self.to_screen(*v)).collect();
        for k in 1..s.len() - 1 {
            self.add_screen_triangle([s[0], s[k], s[k + 1]]);
        }
    }

    fn to_screen(&self, v: Vec4) -> Screen {
        let inv = 1.0 / v.w;
        Screen {
            x: (v.x * inv * 0.5 + 0.5) * self.width as f32,
            y: (0.5 - v.y * inv * 0.5) * self.height as f32,
            z: v.z * inv,
        }
    }

    /// Rasterises one triangle in pixel coordinates if it faces the eye
    /// (counter-clockwise in NDC, i.e. clockwise with y down).
    fn add_screen_triangle(&mut self, [a, b, c]: [Screen; 3]) {
        let area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
        if area.is_nan() || area >= 0.0 {
            return; // back-facing or degenerate: the GPU draws nothing
        }
        if ![a, b, c]
            .iter()
            .all(|v| v.x.is_finite() && v.y.is_finite() && v.z.is_finite())
        {
            return;
        }
        let (minx, maxx) = (a.x.min(b.x).min(c.x), a.x.max(b.x).max(c.x));
        let (miny, maxy) = (a.y.min(b.y).min(c.y), a.y.max(b.y).max(c.y));
        let Some((px0, px1)) = pixel_span(minx, maxx, self.width) else {
            return; // between pixel columns or off the frame
        };
        let Some((py0, py1)) = pixel_span(miny, maxy, self.height) else {
            return;
        };
        // Edge functions e(x, y) = ex·x + ey·y + e0, ≥ 0 inside (clockwise, y down).
        let edge = |p: Screen, q: Screen| {
            let (ex, ey) = (q.y - p.y, p.x - q.x);
            let inv = if ex != 0.0 { 1.0 / ex } else { 0.0 };
            (ex, ey, -(ex * p.x + ey * p.y), inv)
        };
        let edges = [edge(a, b), edge(b, c), edge(c, a)];
        // Depth plane z = zx·x + zy·y + z0 (affine in screen space).
        let inv = 1.0 / area;
        let zx = ((b.z - a.z) * (c.y - a.y) - (c.z - a.z) * (b.y - a.y)) * inv;
        let zy = ((c.z - a.z) * (b.x - a.x) - (b.z - a.z) * (c.x - a.x)) * inv;
        let z0 = a.z - zx * a.x - zy * a.y;
        let z_top = a.z.max(b.z).max(c.z);
        for ty in py0 / TILE..=py1 / TILE {
            let y0 = ty * TILE;
            let (cy0, cy1) = (y0 as f32 + 0.5, (y0 + TILE - 1) as f32 + 0.5);
            // The columns the triangle may cover in this band of rows: each edge
            // bounds x on one side, linearly in y, so by its looser end.
            let (mut blo, mut bhi) = (px0 as f32 + 0.5, px1 as f32 + 0.5);
            for &(ex, ey, e0, inv) in &edges {
                let (k0, k1) = (
                    ey * cy0.max(py0 as f32 + 0.5) + e0,
                    ey * cy1.min(py1 as f32 + 0.5) + e0,
                );
                if ex > 0.0 {
                    blo = blo.max((-k0 * inv).min(-k1 * inv));
                } else if ex < 0.0 {
                    bhi = bhi.min((-k0 * inv).max(-k1 * inv));
                }
            }
            let Some((bx0, bx1)) = pixel_span(blo - 1.0, bhi + 1.0, self.width) else {
                continue;
            };
            for tx in bx0.max(px0) / TILE..=bx1.min(px1) / TILE {
                let x0 = tx * TILE;
                let (cx0, cx1) = (x0 as f32 + 0.5, (x0 + TILE - 1) as f32 + 0.5);
                // The farthest depth over the tile's pixel centres: a corner of
                // the plane, at most the triangle's farthest vertex.
                let corner = (z0 + zx * if zx > 0.0 { cx1 } else { cx0 })
                    + zy * if zy > 0.0 { cy1 } else { cy0 };
                let far = corner.min(z_top);
                let t = ty * self.tiles_x + tx;
                let (old, full) = (self.mask[t], self.inside(tx, ty));
                if old == full && far >= self.zmax[t] {
                    continue; // covered by nearer occluders already
                }
                // Each edge at the tile's pixel centres: its least and greatest
                // values lie at corners (it is affine).
                let mut inside_all = true;
                let mut outside = false;
                for &(ex, ey, e0, _) in &edges {
                    let lo = e0
                        + ex * if ex > 0.0 { cx0 } else { cx1 }
                        + ey * if ey > 0.0 { cy0 } else { cy1 };
                    let hi = e0
                        + ex * if ex > 0.0 { cx1 } else { cx0 }
                        + ey * if ey > 0.0 { cy1 } else { cy0 };
                    outside |= hi < 0.0;
                    inside_all &= lo >= 0.0;
                }
                if outside {
                    continue;
                }
                // Each covered pixel keeps an occluder no farther than zmax there.
                if old == full {
                    // Only a whole-tile triangle nearer helps.
                    if inside_all {
                        self.zmax[t] = far;
                    }
                    continue;
                }
                let bits = if inside_all {
                    full
                } else {
                    row_coverage(&edges, x0, y0, (py0.max(y0), py1.min(y0 + TILE - 1)))
                };
                if bits == 0 {
                    continue;
                }
                if bits & old == old {
                    (self.mask[t], self.zmax[t]) = (bits, far);
                } else {
                    self.mask[t] = old | bits;
                    self.zmax[t] = self.zmax[t].max(far);
                }
            }
        }
    }

    /// The pixels of tile (tx, ty) inside the frame.
    fn inside(&self, tx: usize, ty: usize) -> u64 {
        if (tx + 1) * TILE <= self.width && (ty + 1) * TILE <= self.height {
            return u64::MAX;
        }
        let cols = span_bits(0, self.width - 1, tx * TILE);
        let rows = span_bits(0, self.height - 1, ty * TILE);
        rect_bits(cols, rows)
    }

    /// Whether every pixel `bounds` (world) may cover is covered by occluders
    /// nearer than all of it. `false` when any corner is behind the near plane.
    pub fn hides(&self, bounds: &Aabb) -> bool {
        self.visible_area(bounds).is_none()
    }

    /// `None` when `bounds` is hidden ([`OcclusionMap::hides`]); else the area of
    /// its projection's bounding rectangle within the frame, in pixels (infinite
    /// when a corner is behind the near plane).
    pub fn visible_area(&self, bounds: &Aabb) -> Option<f32> {
        if bounds.is_empty() {
            return Some(0.0);
        }
        let (mut minx, mut maxx) = (f32::INFINITY, f32::NEG_INFINITY);
        let (mut miny, mut maxy) = (f32::INFINITY, f32::NEG_INFINITY);
        let mut zmin = f32::INFINITY;
        for k in 0..8 {
            let p = Vec3::new(
                if k & 1 == 0 {
                    bounds.min.x
                } else {
                    bounds.max.x
                },
                if k & 2 == 0 {
                    bounds.min.y
                } else {
                    bounds.max.y
                },
                if k & 4 == 0 {
                    bounds.min.z
                } else {
                    bounds.max.z
                },
            );
            let v = self.clip * p.extend(1.0);
            if !(v.w > 0.0 && v.z >= 0.0) {
                return Some(f32::INFINITY);
            }
            let s = self.to_screen(v);
            minx = minx.min(s.x);
            maxx = maxx.max(s.x);
            miny = miny.min(s.y);
            maxy = maxy.max(s.y);
            zmin = zmin.min(s.z);
        }
        // Widened by one pixel each way (sub-pixel differences from the GPU).
        let Some((px0, px1)) = pixel_span(minx - 1.0, maxx + 1.0, self.width) else {
            return Some(0.0);
        };
        let Some((py0, py1)) = pixel_span(miny - 1.0, maxy + 1.0, self.height) else {
            return Some(0.0);
        };
        let area = ((px1 - px0 + 1) * (py1 - py0 + 1)) as f32;
        let limit = zmin - DEPTH_MARGIN;
        for ty in py0 / TILE..=py1 / TILE {
            let rows = span_bits(py0, py1, ty * TILE);
            for tx in px0 / TILE..=px1 / TILE {
                let cols = span_bits(px0, px1, tx * TILE);
                let need = rect_bits(cols, rows);
                let t = ty * self.tiles_x + tx;
                if self.mask[t] & need != need || self.zmax[t] >= limit {
                    return Some(area);
                }
            }
        }
        None
    }

    /// Pixels in the frame.
    pub fn pixels(&self) -> f32 {
        (self.width * self.height) as f32
    }

    /// Fraction of the frame's pixels covered by occluders (0–1).
    #[cfg(test)]
    fn coverage(&self) -> f64 {
        let mut n = 0u64;
        for ty in 0..self.mask.len() / self.tiles_x {
            for tx in 0..self.tiles_x {
                let covered = self.mask[ty * self.tiles_x + tx] & self.inside(tx, ty);
                n += u64::from(covered.count_ones());
            }
        }
        n as f64 / (self.width * self.height) as f64
    }
}

/// An edge function e(x, y) = ex·x + ey·y + e0 and 1 / ex (0 when ex is 0).
type Edge = (f32, f32, f32, f32);

/// The coverage mask in the tile at (x0, y0) of the pixel centres inside all
/// `edges` (e ≥ 0), in the rows `rows` (inclusive, absolute).
fn row_coverage(edges: &[Edge; 3], x0: usize, y0: usize, rows: (usize, usize)) -> u64 {
    let mut bits = 0u64;
    for py in rows.0..=rows.1 {
        let y = py as f32 + 0.5;
        let (mut lo, mut hi) = (x0 as f32 + 0.5, (x0 + TILE - 1) as f32 + 0.5);
        for &(ex, ey, e0, inv) in edges {
            let k = ey * y + e0;
            if ex > 0.0 {
                lo = lo.max(-k * inv);
            } else if ex < 0.0 {
                hi = hi.min(-k * inv);
            } else if k < 0.0 {
                hi = f32::NEG_INFINITY;
            }
        }
        if lo.is_nan() || hi.is_nan() || lo > hi {
            continue;
        }
        // Pixel columns c with c + 0.5 in [lo, hi].
        let c0 = (lo - 0.5).ceil() as isize - x0 as isize;
        let c1 = (hi - 0.5).floor() as isize - x0 as isize;
        let (c0, c1) = (c0.max(0), c1.min(TILE as isize - 1));
        if c1 >= c0 {
            let row = (u8::MAX >> (TILE as isize - 1 - (c1 - c0))) << c0;
            bits |= u64::from(row) << ((py - y0) * TILE);
        }
    }
    bits
}

/// The pixels whose centres lie in [lo, hi] (inclusive), clamped to `0..n`.
fn pixel_span(lo: f32, hi: f32, n: usize) -> Option<(usize, usize)> {
    if lo.is_nan() || hi.is_nan() || lo > hi || hi < 0.5 || lo > n as f32 - 0.5 {
        return None;
    }
    let a = (lo - 0.5).ceil().max(0.0) as usize;
    let b = ((hi - 0.5).floor() as usize).min(n - 1);
    (a <= b).then_some((a, b))
}

/// Bits of the 8 pixels from `base` that lie in [a, b].
fn span_bits(a: usize, b: usize, base: usize) -> u8 {
    let (lo, hi) = (a.max(base), b.min(base + TILE - 1));
    if lo > hi {
        return 0;
    }
    (u8::MAX >> (TILE - 1 - (hi - lo))) << (lo - base)
}

/// The tile mask of the columns `cols` in the rows `rows`.
fn rect_bits(cols: u8, rows: u8) -> u64 {
    let mut bits = 0u64;
    for r in 0..TILE {
        if rows & (1 << r) != 0 {
            bits |= u64::from(cols) << (r * TILE);
        }
    }
    bits
}

/// Sutherland–Hodgman: the part of the convex polygon `poly` where `d(v) ≥ 0`.
fn clip_polygon(poly: &[Vec4], d: impl Fn(Vec4) -> f32) -> Vec<Vec4> {
    let mut out = Vec::with_capacity(poly.len() + 1);
    for (k, &p) in poly.iter().enumerate() {
        let q = poly[(k + 1) % poly.len()];
        let (dp, dq) = (d(p), d(q));
        if dp >= 0.0 {
            out.push(p);
        }
        if (dp >= 0.0) != (dq >= 0.0) {
            out.push(p + (q - p) * (dp / (dp - dq)));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Looking down −z from the origin, 64 × 48 pixels.
    fn camera() -> Camera {
        Camera {
            eye: Vec3::ZERO,
            dir: Vec3::new(0.0, 0.0, -1.0),
            fov_y_deg: 60.0,
            width: 64,
            height: 48,
            near: 0.5,
            far: 500.0,
        }
    }

    /// A wall square [-s, s]² at z, facing +z (the eye) unless `back`.
    fn wall(map: &mut OcclusionMap, s: f32, z: f32, back: bool) {
        let p = [[-s, -s, z], [s, -s, z], [s, s, z], [-s, s, z]];
        let tris: [[u32; 3]; 2] = if back {
            [[0, 2, 1], [0, 3, 2]]
        } else {
            [[0, 1, 2], [0, 2, 3]]
        };
        map.add_mesh(&Mat4::IDENTITY, &p, tris.iter());
    }

    fn cube(c: Vec3, h: f32) -> Aabb {
        Aabb {
            min: c - Vec3::splat(h),
            max: c + Vec3::splat(h),
        }
    }

    #[test]
    fn a_wall_hides_what_stands_behind_it_only() {
        let mut map = OcclusionMap::new(&camera());
        wall(&mut map, 4.0, -10.0, false);
        assert!(map.coverage() > 0.05);
        assert!(map.hides(&cube(Vec3::new(0.0, 0.0, -20.0), 1.0)));
        // In front of the wall, straddling it, or reaching past its silhouette.
        assert!(!map.hides(&cube(Vec3::new(0.0, 0.0, -5.0), 1.0)));
        assert!(!map.hides(&cube(Vec3::new(0.0, 0.0, -10.0), 1.0)));
        assert!(!map.hides(&cube(Vec3::new(7.0, 0.0, -20.0), 1.0)));
        // Behind the eye's near plane: never hidden.
        assert!(!map.hides(&cube(Vec3::new(0.0, 0.0, 0.2), 1.0)));
        // A wall seen from behind is not drawn (back faces are culled): hides nothing.
        let mut back = OcclusionMap::new(&camera());
        wall(&mut back, 4.0, -10.0, true);
        assert_eq!(back.coverage(), 0.0);
        assert!(!back.hides(&cube(Vec3::new(0.0, 0.0, -20.0), 1.0)));
        // A wall through the near plane is clipped, not dropped: it still hides.
        let mut near = OcclusionMap::new(&camera());
        // z = −0.1·x − 3: 3 in front of the eye, behind it at x < −30.
        let p = [[-50.0, -50.0, 2.0], [50.0, -50.0, -8.0], [50.0, 50.0, -8.0]];
        let q = [[-50.0, -50.0, 2.0], [50.0, 50.0, -8.0], [-50.0, 50.0, 2.0]];
        near.add_mesh(&Mat4::IDENTITY, &p, [[0, 1, 2]].iter());
        near.add_mesh(&Mat4::IDENTITY, &q, [[0, 1, 2]].iter());
        assert!(near.coverage() > 0.99, "{}", near.coverage());
        assert!(near.hides(&cube(Vec3::new(0.0, 0.0, -30.0), 1.0)));
    }

    /// A tiny deterministic generator (no seed file, no dependency).
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> f32 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (self.0 >> 40) as f32 / (1u64 << 24) as f32
        }
        fn range(&mut self, lo: f32, hi: f32) -> f32 {
            lo + (hi - lo) * self.next()
        }
    }

    /// Conservative against a brute-force reference: whenever a box is reported
    /// hidden, every pixel centre of its widened projection is covered by a
    /// front-facing occluder nearer than the box's nearest point (coverage tested
    /// loosely, so rounding can only make the reference stricter).
    #[test]
    fn hidden_boxes_are_hidden_at_every_pixel_by_brute_force() {
        let cam = camera();
        let clip = cam.clip_from_world_wgpu();
        let mut rng = Lcg(7);
        let mut hidden = 0;
        for case in 0..200 {
            let mut map = OcclusionMap::new(&cam);
            let mut tris: Vec<[Vec3; 3]> = Vec::new();
            for _ in 0..1 + case % 12 {
                // In front of the near plane (the reference does not clip).
                let c = Vec3::new(
                    rng.range(-8.0, 8.0),
                    rng.range(-6.0, 6.0),
                    rng.range(-30.0, -4.0),
                );
                let v = |r: &mut Lcg| {
                    c + Vec3::new(r.range(-9.0, 9.0), r.range(-9.0, 9.0), r.range(-3.0, 3.0))
                };
                tris.push([v(&mut rng), v(&mut rng), v(&mut rng)]);
            }
            for t in &tris {
                let p = t.map(|v| v.to_array());
                map.add_mesh(&Mat4::IDENTITY, &p, [[0, 1, 2]].iter());
            }
            for _ in 0..20 {
                let c = Vec3::new(
                    rng.range(-10.0, 10.0),
                    rng.range(-8.0, 8.0),
                    rng.range(-60.0, -3.0),
                );
                let b = cube(c, rng.range(0.05, 2.0));
                if !map.hides(&b) {
                    continue;
                }
                hidden += 1;
                let mut zmin = f32::INFINITY;
                let (mut lo, mut hi) = (
                    glam::Vec2::splat(f32::INFINITY),
                    glam::Vec2::splat(f32::NEG_INFINITY),
                );
                for k in 0..8 {
                    let p = Vec3::new(
                        if k & 1 == 0 { b.min.x } else { b.max.x },
                        if k & 2 == 0 { b.min.y } else { b.max.y },
                        if k & 4 == 0 { b.min.z } else { b.max.z },
                    );
                    let s = map.to_screen(clip * p.extend(1.0));
                    zmin = zmin.min(s.z);
                    lo = lo.min(glam::Vec2::new(s.x, s.y));
                    hi = hi.max(glam::Vec2::new(s.x, s.y));
                }
                for py in 0..cam.height as usize {
                    for px in 0..cam.width as usize {
                        let (x, y) = (px as f32 + 0.5, py as f32 + 0.5);
                        if x < lo.x - 1.0 || x > hi.x + 1.0 || y < lo.y - 1.0 || y > hi.y + 1.0 {
                            continue;
                        }
                        let nearest = tris
                            .iter()
                            .filter_map(|t| {
                                let s = t.map(|v| map.to_screen(clip * v.extend(1.0)));
                                let [a, b2, c2] = s.map(|s| (s.x as f64, s.y as f64, s.z as f64));
                                let area =
                                    (b2.0 - a.0) * (c2.1 - a.1) - (b2.1 - a.1) * (c2.0 - a.0);
                                if area >= 0.0 {
                                    return None;
                                }
                                let (x, y) = (x as f64, y as f64);
                                let w = |p: (f64, f64, f64), q: (f64, f64, f64)| {
                                    ((q.0 - p.0) * (y - p.1) - (q.1 - p.1) * (x - p.0)) / area
                                };
                                let (l0, l1, l2) = (w(b2, c2), w(c2, a), w(a, b2));
                                (l0 >= -1e-4 && l1 >= -1e-4 && l2 >= -1e-4)
                                    .then_some(l0 * a.2 + l1 * b2.2 + l2 * c2.2)
                            })
                            .fold(f64::INFINITY, f64::min);
                        assert!(
                            nearest < zmin as f64,
                            "case {case}: pixel ({px}, {py}) shows the box (occluder {nearest}, box {zmin})"
                        );
                    }
                }
            }
        }
        assert!(
            hidden > 20,
            "only {hidden} boxes hidden: the test tells nothing"
        );
    }
}
