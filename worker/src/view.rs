//! View construction for captures (paper 000 §3.1.3 step (1): "capture the image and
//! depth image of O using cell's face as the window and cell's center as the center
//! of projection"; DESIGN.md "Capture resolution").
//!
//! Every builder produces a right-handed eye space looking down −z with y up and an
//! OpenGL-style perspective matrix whose clip `w` equals the eye-space depth
//! (−z_eye), which is what [`crate::raster::render`] relies on.

use crate::raster::View;
use glam::{Mat4, Vec3, Vec4};
use std::f32::consts::FRAC_PI_3;
use thiserror::Error;

/// Largest capture side [`View::tight_around`] will make, in pixels.
pub const MAX_CAPTURE_SIDE: u32 = 16384;

/// Why a view cannot be built.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ViewError {
    #[error("window is degenerate (its corners do not span a plane)")]
    DegenerateWindow,
    #[error("eye {eye:?} lies in the window's plane")]
    EyeInWindowPlane { eye: [f32; 3] },
    #[error(
        "the box reaches within {depth} of the eye's plane: it does not lie in front of the eye"
    )]
    BoxNotInFront { depth: f32 },
    #[error("capture of {width} × {height} px exceeds the maximum side {max}")]
    TooLarge { width: u64, height: u64, max: u32 },
    #[error("bad view parameters: {what}")]
    BadParameters { what: String },
}

/// Off-axis OpenGL frustum matrix (glFrustum): the window `[l, r] × [b, t]` on the
/// near plane.
pub fn frustum(l: f32, r: f32, b: f32, t: f32, near: f32, far: f32) -> Mat4 {
    let rl = r - l;
    let tb = t - b;
    let fnr = far - near;
    Mat4::from_cols(
        Vec4::new(2.0 * near / rl, 0.0, 0.0, 0.0),
        Vec4::new(0.0, 2.0 * near / tb, 0.0, 0.0),
        Vec4::new((r + l) / rl, (t + b) / tb, -(far + near) / fnr, -1.0),
        Vec4::new(0.0, 0.0, -2.0 * far * near / fnr, 0.0),
    )
}

fn check_common(width: u32, height: u32, near: f32, far: f32) -> Result<(), ViewError> {
    if width == 0 || height == 0 {
        return Err(ViewError::BadParameters {
            what: format!("image size {width} × {height}"),
        });
    }
    if !(near.is_finite() && far.is_finite() && near > 0.0 && far > near) {
        return Err(ViewError::BadParameters {
            what: format!("near {near}, far {far} (need 0 < near < far)"),
        });
    }
    Ok(())
}

/// The 8 corners of the box `[lo, hi]`, corner `k` taking `hi` on x where bit 0 of
/// `k` is set, on y for bit 1, on z for bit 2.
pub fn box_corners(lo: Vec3, hi: Vec3) -> [Vec3; 8] {
    std::array::from_fn(|k| {
        Vec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        )
    })
}

/// An orthonormal eye basis looking along `forward`, with `up_hint` as up where it
/// is not parallel to `forward`.
fn eye_basis(eye: Vec3, forward: Vec3, up_hint: Vec3) -> Mat4 {
    let f = forward.normalize();
    let mut up = up_hint - f * up_hint.dot(f);
    if up.length_squared() < 1e-8 {
        // Looking straight along the hint: pick the world axis least aligned with f.
        let alt = if f.x.abs() < 0.9 { Vec3::X } else { Vec3::Z };
        up = alt - f * alt.dot(f);
    }
    let up = up.normalize();
    let right = f.cross(up).normalize();
    // Rows of the rotation: right, up, −forward.
    let z = -f;
    Mat4::from_cols(
        Vec4::new(right.x, up.x, z.x, 0.0),
        Vec4::new(right.y, up.y, z.y, 0.0),
        Vec4::new(right.z, up.z, z.z, 0.0),
        Vec4::new(-right.dot(eye), -up.dot(eye), -z.dot(eye), 1.0),
    )
}

impl View {
    /// The frustum from `eye` through a planar quad `window` (e.g. a cell's side
    /// face): the view axis is the window plane's normal, the image is the window's
    /// bounding rectangle in that plane (up = world y projected onto the plane), so
    /// the projection is off-axis. Pixels are square only if `width / height`
    /// matches the window's aspect ratio.
    pub fn off_axis(
        eye: Vec3,
        window: [Vec3; 4],
        width: u32,
        height: u32,
        near: f32,
        far: f32,
    ) -> Result<View, ViewError> {
        check_common(width, height, near, far)?;
        // Plane normal by Newell's method (robust for any planar quad order).
        let mut normal = Vec3::ZERO;
        for i in 0..4 {
            let a = window[i];
            let b = window[(i + 1) % 4];
            normal += Vec3::new(
                (a.y - b.y) * (a.z + b.z),
                (a.z - b.z) * (a.x + b.x),
                (a.x - b.x) * (a.y + b.y),
            );
        }
        if !normal.is_finite() || normal.length_squared() < 1e-20 {
            return Err(ViewError::DegenerateWindow);
        }
        let normal = normal.normalize();
        let centroid = window.iter().copied().sum::<Vec3>() / 4.0;
        let dist = (centroid - eye).dot(normal);
        if dist.abs() < 1e-6 * (centroid - eye).length().max(1e-6) {
            return Err(ViewError::EyeInWindowPlane { eye: eye.into() });
        }
        let forward = if dist > 0.0 { normal } else { -normal };
        let view = eye_basis(eye, forward, Vec3::Y);
        // Window extents on the plane z_eye = −d, scaled to the near plane.
        let mut lo = glam::Vec2::splat(f32::INFINITY);
        let mut hi = glam::Vec2::splat(f32::NEG_INFINITY);
        for p in window {
            let e = view.transform_point3(p);
            let d = -e.z;
            let s = glam::Vec2::new(e.x, e.y) / d;
            lo = lo.min(s);
            hi = hi.max(s);
        }
        if !(hi.x > lo.x && hi.y > lo.y) {
            return Err(ViewError::DegenerateWindow);
        }
        let proj = frustum(
            lo.x * near,
            hi.x * near,
            lo.y * near,
            hi.y * near,
            near,
            far,
        );
        Ok(View {
            eye,
            view,
            proj,
            near,
            far,
            width,
            height,
        })
    }

    /// A symmetric perspective view from `eye` towards `target` with vertical field
    /// of view `fov_y_deg` and square pixels.
    #[allow(clippy::too_many_arguments)]
    pub fn look_at_fov(
        eye: Vec3,
        target: Vec3,
        up: Vec3,
        fov_y_deg: f32,
        width: u32,
        height: u32,
        near: f32,
        far: f32,
    ) -> Result<View, ViewError> {
        check_common(width, height, near, far)?;
        if !(fov_y_deg > 0.0 && fov_y_deg < 179.0) {
            return Err(ViewError::BadParameters {
                what: format!("vertical field of view {fov_y_deg}°"),
            });
        }
        let forward = target - eye;
        if !forward.is_finite() || forward.length_squared() < 1e-20 {
            return Err(ViewError::BadParameters {
                what: "eye and target coincide".to_string(),
            });
        }
        let view = eye_basis(eye, forward, up);
        let t = near * (fov_y_deg.to_radians() / 2.0).tan();
        let r = t * width as f32 / height as f32;
        Ok(View {
            eye,
            view,
            proj: frustum(-r, r, -t, t, near, far),
            near,
            far,
            width,
            height,
        })
    }

    /// A tight frustum from `eye` around the box `[aabb_min, aabb_max]` at the
    /// capture resolution of DESIGN.md: `image_res_per_60deg` pixels per π/3 radians
    /// of angular extent, i.e. `width = ceil(horizontal angle · image_res / (π/3))`
    /// (likewise the height). The view axis points at the box centre; near and far
    /// hug the box (its nearest and farthest corner depths, widened by 0.1%).
    ///
    /// A box wide beside the eye (a long wall, a building block along the cell) can
    /// reach behind the plane through the eye across that axis although the eye is
    /// outside it (issue 29). The axis then turns towards the box's nearest point
    /// ([`tight_axes`]): every point of a box lies in front of the plane through the
    /// eye normal to the direction of its nearest point, so a box that does not
    /// hold the eye always gets a view (one wider than the centred one would be).
    pub fn tight_around(
        eye: Vec3,
        aabb_min: Vec3,
        aabb_max: Vec3,
        image_res_per_60deg: u32,
    ) -> Result<View, ViewError> {
        if image_res_per_60deg == 0 || !(aabb_min.is_finite() && aabb_max.is_finite()) {
            return Err(ViewError::BadParameters {
                what: format!("box {aabb_min:?}..{aabb_max:?}, resolution {image_res_per_60deg}"),
            });
        }
        let extent = (aabb_max - aabb_min).length().max(1e-6);
        let mut first_depth = None;
        let mut framed = None;
        for forward in tight_axes(eye, aabb_min, aabb_max) {
            let view = eye_basis(eye, forward, Vec3::Y);
            let mut lo = glam::Vec2::splat(f32::INFINITY);
            let mut hi = glam::Vec2::splat(f32::NEG_INFINITY);
            let mut dmin = f32::INFINITY;
            let mut dmax = f32::NEG_INFINITY;
            for p in box_corners(aabb_min, aabb_max) {
                let e = view.transform_point3(p);
                let d = -e.z;
                dmin = dmin.min(d);
                dmax = dmax.max(d);
                if d > 0.0 {
                    let s = glam::Vec2::new(e.x, e.y) / d;
                    lo = lo.min(s);
                    hi = hi.max(s);
                }
            }
            first_depth.get_or_insert(dmin);
            if dmin > 1e-4 * extent {
                framed = Some((view, lo, hi, dmin, dmax));
                break;
            }
        }
        let Some((view, lo, hi, dmin, dmax)) = framed else {
            return Err(ViewError::BoxNotInFront {
                depth: first_depth.unwrap_or(0.0),
            });
        };
        let near = dmin * 0.999;
        let far = dmax * 1.001 + f32::EPSILON * dmax.abs();
        let per_radian = image_res_per_60deg as f64 / FRAC_PI_3 as f64;
        let ang_x = (hi.x as f64).atan() - (lo.x as f64).atan();
        let ang_y = (hi.y as f64).atan() - (lo.y as f64).atan();
        let width = (ang_x * per_radian).ceil().max(1.0) as u64;
        let height = (ang_y * per_radian).ceil().max(1.0) as u64;
        if width > MAX_CAPTURE_SIDE as u64 || height > MAX_CAPTURE_SIDE as u64 {
            return Err(ViewError::TooLarge {
                width,
                height,
                max: MAX_CAPTURE_SIDE,
            });
        }
        // A box seen edge-on can have zero extent on one axis: widen to one pixel.
        let (lo, hi) = widen(lo, hi);
        Ok(View {
            eye,
            view,
            proj: frustum(
                lo.x * near,
                hi.x * near,
                lo.y * near,
                hi.y * near,
                near,
                far,
            ),
            near,
            far,
            width: width as u32,
            height: height as u32,
        })
    }

    /// World → clip transform.
    pub fn view_proj(&self) -> Mat4 {
        self.proj * self.view
    }

    /// Projects a world point to pixel coordinates (x right, y down, pixel centres
    /// at +0.5) and its eye-space depth; `None` behind the eye.
    pub fn project(&self, p: Vec3) -> Option<(glam::Vec2, f32)> {
        let c = self.view_proj() * p.extend(1.0);
        if c.w <= 0.0 {
            return None;
        }
        let ndc = glam::Vec2::new(c.x / c.w, c.y / c.w);
        Some((
            glam::Vec2::new(
                (ndc.x + 1.0) * 0.5 * self.width as f32,
                (1.0 - ndc.y) * 0.5 * self.height as f32,
            ),
            c.w,
        ))
    }

    /// The world-space ray direction (unit) through pixel coordinates `(x, y)`.
    pub fn ray_dir(&self, x: f32, y: f32) -> Vec3 {
        let ndc_x = 2.0 * x / self.width as f32 - 1.0;
        let ndc_y = 1.0 - 2.0 * y / self.height as f32;
        let inv = self.view_proj().inverse();
        let p = inv * Vec4::new(ndc_x, ndc_y, 1.0, 1.0);
        let p = p.truncate() / p.w;
        (p - self.eye).normalize()
    }
}

/// The view axes [`View::tight_around`] tries, in order: towards the box centre,
/// then turning in quarter steps to the direction of the box's nearest point,
/// which frames any box not holding the eye (module docs of the method). None
/// when the eye is the centre; only the centre's when the eye is in the box.
/// The first axis is the unnormalised centre direction (the basis normalises it).
fn tight_axes(eye: Vec3, lo: Vec3, hi: Vec3) -> Vec<Vec3> {
    let centre = 0.5 * (lo + hi) - eye;
    if centre.length_squared() < 1e-20 {
        return Vec::new();
    }
    let to_centre = centre.normalize();
    let to_nearest = (eye.clamp(lo, hi) - eye).normalize_or_zero();
    let mut axes = vec![centre];
    if to_nearest != Vec3::ZERO {
        for t in [0.75f32, 0.5, 0.25] {
            let axis = (t * to_centre + (1.0 - t) * to_nearest).normalize_or_zero();
            if axis != Vec3::ZERO {
                axes.push(axis);
            }
        }
        axes.push(to_nearest);
    }
    axes
}

fn widen(lo: glam::Vec2, hi: glam::Vec2) -> (glam::Vec2, glam::Vec2) {
    let mut lo = lo;
    let mut hi = hi;
    for k in 0..2 {
        if hi[k] - lo[k] < 1e-6 {
            lo[k] -= 5e-7;
            hi[k] += 5e-7;
        }
    }
    (lo, hi)
}
