//! Camera and view-frustum culling (paper 000 §3.2 run-time step: "view-frustum
//! culling is performed for the whole scene").
//!
//! Same conventions as the worker's views (DESIGN.md "Space"): right-handed, y up,
//! looking down −z in eye space, OpenGL-style clip space (z ∈ [−w, w]). wgpu wants
//! z ∈ [0, w], so [`Camera::clip_from_world_wgpu`] appends `z' = (z + w) / 2`; x, y and
//! the winding are unchanged (NDC y up, framebuffer row 0 at the top in both).

use glam::{Mat4, Vec3, Vec4};

/// A symmetric perspective camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub eye: Vec3,
    /// Viewing direction (need not be unit; must not be parallel to +y).
    pub dir: Vec3,
    pub fov_y_deg: f32,
    pub width: u32,
    pub height: u32,
    pub near: f32,
    pub far: f32,
}

impl Camera {
    /// World → eye.
    pub fn view(&self) -> Mat4 {
        let f = self.dir.normalize();
        let s = f.cross(Vec3::Y).normalize();
        let u = s.cross(f);
        Mat4::from_cols(
            Vec4::new(s.x, u.x, -f.x, 0.0),
            Vec4::new(s.y, u.y, -f.y, 0.0),
            Vec4::new(s.z, u.z, -f.z, 0.0),
            Vec4::new(-s.dot(self.eye), -u.dot(self.eye), f.dot(self.eye), 1.0),
        )
    }

    /// Eye → OpenGL clip.
    pub fn proj_gl(&self) -> Mat4 {
        let t = self.near * (self.fov_y_deg.to_radians() / 2.0).tan();
        let r = t * self.width as f32 / self.height as f32;
        frustum_gl(-r, r, -t, t, self.near, self.far)
    }

    /// World → OpenGL clip (the worker's `View::view_proj`).
    pub fn clip_from_world_gl(&self) -> Mat4 {
        self.proj_gl() * self.view()
    }

    /// World → wgpu clip (depth in [0, w]).
    pub fn clip_from_world_wgpu(&self) -> Mat4 {
        gl_to_wgpu_depth() * self.clip_from_world_gl()
    }

    pub fn frustum(&self) -> Frustum {
        Frustum::from_clip_gl(self.clip_from_world_gl())
    }
}

/// Off-axis OpenGL frustum matrix (glFrustum), as `worker::view::frustum`.
pub fn frustum_gl(l: f32, r: f32, b: f32, t: f32, near: f32, far: f32) -> Mat4 {
    let (rl, tb, fnr) = (r - l, t - b, far - near);
    Mat4::from_cols(
        Vec4::new(2.0 * near / rl, 0.0, 0.0, 0.0),
        Vec4::new(0.0, 2.0 * near / tb, 0.0, 0.0),
        Vec4::new((r + l) / rl, (t + b) / tb, -(far + near) / fnr, -1.0),
        Vec4::new(0.0, 0.0, -2.0 * far * near / fnr, 0.0),
    )
}

/// `z' = 0.5·z + 0.5·w`: OpenGL clip depth → wgpu clip depth.
pub fn gl_to_wgpu_depth() -> Mat4 {
    Mat4::from_cols(
        Vec4::new(1.0, 0.0, 0.0, 0.0),
        Vec4::new(0.0, 1.0, 0.0, 0.0),
        Vec4::new(0.0, 0.0, 0.5, 0.0),
        Vec4::new(0.0, 0.0, 0.5, 1.0),
    )
}

/// An axis-aligned box in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x
    }

    pub fn add(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// The world box of this (object-space) box under `m`.
    pub fn transformed(&self, m: &Mat4) -> Aabb {
        let mut out = Aabb::EMPTY;
        if self.is_empty() {
            return out;
        }
        for i in 0..8 {
            let p = Vec3::new(
                if i & 1 == 0 { self.min.x } else { self.max.x },
                if i & 2 == 0 { self.min.y } else { self.max.y },
                if i & 4 == 0 { self.min.z } else { self.max.z },
            );
            out.add(m.transform_point3(p));
        }
        out
    }

    pub fn centre(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }
}

/// Six planes `n·p + d ≥ 0` inside (Gribb–Hartmann, from an OpenGL clip matrix).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frustum {
    planes: [Vec4; 6],
}

impl Frustum {
    pub fn from_clip_gl(m: Mat4) -> Frustum {
        let r = [m.row(0), m.row(1), m.row(2), m.row(3)];
        Frustum {
            planes: [
                r[3] + r[0],
                r[3] - r[0],
                r[3] + r[1],
                r[3] - r[1],
                r[3] + r[2],
                r[3] - r[2],
            ],
        }
    }

    /// Whether the box may intersect the frustum (conservative: no false negatives).
    pub fn intersects(&self, b: &Aabb) -> bool {
        if b.is_empty() {
            return false;
        }
        self.planes.iter().all(|p| {
            let v = Vec3::new(
                if p.x >= 0.0 { b.max.x } else { b.min.x },
                if p.y >= 0.0 { b.max.y } else { b.min.y },
                if p.z >= 0.0 { b.max.z } else { b.min.z },
            );
            p.truncate().dot(v) + p.w >= 0.0
        })
    }

    /// The same frustum in the object space of an instance placed by
    /// `world_from_object` (a plane `q` becomes `Mᵀ q`: `q·(M x) = (Mᵀ q)·x`), so
    /// object-space boxes can be tested without transforming them.
    pub fn in_object_space(&self, world_from_object: &Mat4) -> Frustum {
        let t = world_from_object.transpose();
        Frustum {
            planes: self.planes.map(|q| t * q),
        }
    }

    pub fn contains_point(&self, p: Vec3) -> bool {
        self.planes.iter().all(|q| q.truncate().dot(p) + q.w >= 0.0)
    }
}

/// Distance from `eye` to the nearest point of `b` (0 inside).
pub fn distance_to_box(eye: Vec3, b: &Aabb) -> f32 {
    if b.is_empty() {
        return f32::INFINITY;
    }
    eye.distance(eye.clamp(b.min, b.max))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam() -> Camera {
        Camera {
            eye: Vec3::new(0.0, 5.0, 0.0),
            dir: Vec3::new(0.0, 0.0, -1.0),
            fov_y_deg: 60.0,
            width: 100,
            height: 100,
            near: 0.5,
            far: 100.0,
        }
    }

    #[test]
    fn distance_to_box_is_zero_inside_and_euclidean_outside() {
        let b = Aabb {
            min: Vec3::ZERO,
            max: Vec3::ONE,
        };
        assert_eq!(distance_to_box(Vec3::splat(0.5), &b), 0.0);
        assert!((distance_to_box(Vec3::new(4.0, 0.5, 0.5), &b) - 3.0).abs() < 1e-6);
        assert!((distance_to_box(Vec3::new(4.0, 5.0, 0.5), &b) - 5.0).abs() < 1e-6);
    }

    #[test]
    fn wgpu_depth_maps_near_to_0_and_far_to_1() {
        let c = cam();
        let m = c.clip_from_world_wgpu();
        let near = m * Vec4::new(0.0, 5.0, -0.5, 1.0);
        let far = m * Vec4::new(0.0, 5.0, -100.0, 1.0);
        assert!((near.z / near.w).abs() < 1e-5);
        assert!((far.z / far.w - 1.0).abs() < 1e-4);
    }

    #[test]
    fn frustum_keeps_boxes_ahead_and_drops_boxes_behind() {
        let f = cam().frustum();
        let ahead = Aabb {
            min: Vec3::new(-1.0, 4.0, -11.0),
            max: Vec3::new(1.0, 6.0, -9.0),
        };
        let behind = Aabb {
            min: Vec3::new(-1.0, 4.0, 9.0),
            max: Vec3::new(1.0, 6.0, 11.0),
        };
        let beside = Aabb {
            min: Vec3::new(50.0, 4.0, -11.0),
            max: Vec3::new(52.0, 6.0, -9.0),
        };
        assert!(f.intersects(&ahead));
        assert!(!f.intersects(&behind));
        assert!(!f.intersects(&beside));
    }
}
