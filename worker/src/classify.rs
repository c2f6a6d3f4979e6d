//! Pixel classes of an object's depth image (paper 000 §3.1.3.1; 003 §4.1.4).
//!
//! Every pixel of an object's capture falls in one of four categories, each with the
//! weight the paper derived "from experience" (000 §3.1.3.1, last paragraph):
//!
//! | class | test | weight |
//! |---|---|---|
//! | exterior silhouette | on the contour of the object's coverage | 0.5 |
//! | interior silhouette (C0) | `Z[i+1] − Z[i] > T_C0` or `Z[i−1] − Z[i] > T_C0` | 0.4 |
//! | sharp edge (C1) | `abs((Z[i−1] − Z[i]) − (Z[i] − Z[i+1])) ≥ T_C1` | 0.25 |
//! | interior | any other pixel of the object | 0.125 |
//!
//! When a pixel meets several tests it gets the class with the highest weight. The 1-D
//! tests of the paper's Fig. 5 are applied along rows and along columns.
//!
//! # Which depth the thresholds apply to
//!
//! The paper's `T_C0 = 3.4e-4` and `T_C1 = 1.28e-4` (000 §4.1.2) are tiny fractions of
//! a *normalised* depth. We read them as OpenGL window depth in [0, 1] of a capture
//! whose near plane is the paper's projection window, i.e. the cell's side face:
//!
//! ```text
//! Z = f/(f − n) · (1 − n / z_eye),   n = √3/2 · c (the cell's apothem), f ≫ n
//! ```
//!
//! Reasons:
//! 1. The paper reads back the depth image a 2003 GPU rendered with "cell's face as the
//!    window and cell's center as the center of projection" (000 §3.1.3 step 1); the
//!    depth buffer of that window holds exactly this `Z`, with the near plane at the
//!    window, √3/2·c from the centre.
//! 2. Window depth is an affine function of screen position on any plane (it is affine
//!    in 1/z_eye). So the second difference of `Z` is exactly zero on flat faces however
//!    slanted, and only creases give a C1 response — the premise of Fig. 5. Eye depth or
//!    a linear normalisation of it would respond to slanted planes too.
//! 3. With these settings the defaults mean, for the paper's 1024-pixel face
//!    (≈ 1/978 rad per pixel, the same as DESIGN.md's capture resolution): C1 marks
//!    surface regions whose curvature radius is below n·p²/T_C1 ≈ 0.36 units
//!    (c = 50) independently of distance — creases, not a smooth bunny's body; C0 marks
//!    a depth jump larger than T_C0·z²/n between neighbours, e.g. 2.8 units at the
//!    bunny's SV distance of 7 cells (≈ 600 units), i.e. real gaps and near-grazing
//!    surfaces only.
//!
//! Measured on the paper's bunny (43.2 units tall, c = 50, DESIGN.md resolution;
//! `tests/analysis.rs::bunny_class_percentages`), as % of the bunny's pixels:
//!
//! | distance | exterior | interior silhouette | sharp edge | interior |
//! |---|---|---|---|---|
//! | 100 (≈ 1 cell) | 1.5 | 54.0 | 1.6 | 42.9 |
//! | 250 (≈ 3 cells) | 3.8 | 15.4 | 4.3 | 76.5 |
//! | 600 (≈ 7 cells, SV) | 8.9 | 5.1 | 6.4 | 79.6 |
//!
//! The window depth's per-pixel step on a slope of angle α is `n·p·tan α / z`, so C0
//! also catches steep continuous slopes close to the cell (α > 37° at 100 units, > 62°
//! at 250, > 78° at 600): the paper's fixed thresholds are tuned for its SV range;
//! closer objects are MvMeshes, whose weight is the maximum over seven views anyway.
//!
//! Only differences of `Z` matter, so we store `−f/(f−n) · n / z_eye` (the window depth
//! minus its constant term), which keeps full f32 precision far from the near plane.
//! [`classify`] takes `n` and `f` from the capture's [`View`]; to
//! reproduce the paper, build the capture with `near = √3/2 · c` or pass
//! [`WindowDepth::paper`] to [`classify_objects`].
//!
//! # Other objects in the capture
//!
//! The paper captures the object alone ("capture the image and depth image of O",
//! §3.1.3 step 1), or a cluster treated as one object (§3.1.6). [`classify_objects`]
//! takes the set of ids that form "the object"; pixels of any other id count as
//! background, so the exterior silhouette is the contour of the members' coverage. If
//! a foreign occluder is in the capture, the members' pixels along its outline become
//! exterior silhouette: conservative (those vertices are kept), but it also hides the
//! object's vertices behind it, so bake captures should hold the object (or cluster)
//! alone. Pixels on the image border are not silhouette for that reason alone: the
//! window edge is not a contour of the object.

use crate::raster::{Capture, View, BACKGROUND_ID};
use rayon::prelude::*;

/// Paper default for the interior-silhouette (C0) threshold on window depth (000 §4.1.2).
pub const DEFAULT_T_C0: f32 = 3.4e-4;
/// Paper default for the sharp-edge (C1) threshold on window depth (000 §4.1.2).
pub const DEFAULT_T_C1: f32 = 1.28e-4;

/// The category of one pixel of an object's depth image (000 §3.1.3.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum PixelClass {
    /// Not covered by the object (or covered by another object).
    Background,
    /// On the contour of the object's coverage.
    ExteriorSilhouette,
    /// C0 discontinuity: a neighbour of the object is farther by more than `T_C0`.
    InteriorSilhouette,
    /// C1 discontinuity: the depth slope changes by at least `T_C1`.
    SharpEdge,
    /// Any other pixel of the object.
    Interior,
}

impl PixelClass {
    /// Every class, in declaration order (for histograms and legends).
    pub const ALL: [PixelClass; 5] = [
        PixelClass::Background,
        PixelClass::ExteriorSilhouette,
        PixelClass::InteriorSilhouette,
        PixelClass::SharpEdge,
        PixelClass::Interior,
    ];

    /// The paper's weight of the class (000 §3.1.3.1): 0.5 / 0.4 / 0.25 / 0.125; 0 for
    /// background.
    pub fn weight(self) -> f32 {
        match self {
            PixelClass::Background => 0.0,
            PixelClass::ExteriorSilhouette => 0.5,
            PixelClass::InteriorSilhouette => 0.4,
            PixelClass::SharpEdge => 0.25,
            PixelClass::Interior => 0.125,
        }
    }

    /// Position in [`PixelClass::ALL`].
    pub fn index(self) -> usize {
        self as usize
    }
}

/// The projective depth range the thresholds are measured in: OpenGL window depth
/// `Z = f/(f−n) · (1 − n/z_eye)` (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WindowDepth {
    /// Near-plane distance `n` (> 0).
    pub near: f32,
    /// Far-plane distance `f` (> near; `f32::INFINITY` allowed).
    pub far: f32,
}

impl WindowDepth {
    /// The capture's own near/far planes.
    pub fn of_view(view: &View) -> WindowDepth {
        WindowDepth {
            near: view.near,
            far: view.far,
        }
    }

    /// The paper's setting: near plane at the cell's side face (the apothem √3/2·c of a
    /// cell of size `cell_size`), far plane at infinity.
    pub fn paper(cell_size: f32) -> WindowDepth {
        WindowDepth {
            near: 0.5 * 3f32.sqrt() * cell_size,
            far: f32::INFINITY,
        }
    }

    /// Window depth minus its constant term, `−f/(f−n) · n / z_eye`: its differences are
    /// window-depth differences. Finite for `z_eye > 0`; 0 for `z_eye = +∞`.
    pub fn offset_depth(self, z_eye: f32) -> f32 {
        let scale = if self.far.is_finite() && self.far > self.near {
            self.far / (self.far - self.near)
        } else {
            1.0
        };
        -scale * self.near / z_eye
    }
}

/// Counts of each class, indexed like [`PixelClass::ALL`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ClassCounts(pub [usize; 5]);

impl ClassCounts {
    pub fn of(classes: &[PixelClass]) -> ClassCounts {
        let mut counts = [0usize; 5];
        for class in classes {
            counts[class.index()] += 1;
        }
        ClassCounts(counts)
    }

    pub fn get(&self, class: PixelClass) -> usize {
        self.0[class.index()]
    }

    /// Pixels of the object (everything but background).
    pub fn object_pixels(&self) -> usize {
        self.0.iter().sum::<usize>() - self.get(PixelClass::Background)
    }

    /// Percentage of the object's pixels in `class` (0 when the object covers nothing).
    pub fn percent_of_object(&self, class: PixelClass) -> f64 {
        let total = self.object_pixels();
        if total == 0 {
            0.0
        } else {
            100.0 * self.get(class) as f64 / total as f64
        }
    }
}

/// Classes of the pixels of object `object_id` in `capture`, with the capture's
/// near/far planes as the window-depth range (module docs). Row-major like the capture.
pub fn classify(capture: &Capture, object_id: u32, t_c0: f32, t_c1: f32) -> Vec<PixelClass> {
    classify_objects(
        capture,
        &[object_id],
        t_c0,
        t_c1,
        WindowDepth::of_view(&capture.view),
    )
}

/// Classes of the pixels covered by any id of `members` (one object, or a cluster
/// treated as one object), with thresholds on window depth in `window`.
pub fn classify_objects(
    capture: &Capture,
    members: &[u32],
    t_c0: f32,
    t_c1: f32,
    window: WindowDepth,
) -> Vec<PixelClass> {
    let width = capture.view.width as usize;
    let height = capture.view.height as usize;
    let pixel_count = width * height;
    if width == 0
        || height == 0
        || capture.depth.len() != pixel_count
        || capture.object_id.len() != pixel_count
    {
        return vec![PixelClass::Background; pixel_count];
    }

    // Step 1: the members' coverage mask and their normalised depth.
    let is_member = |id: u32| id != BACKGROUND_ID && members.contains(&id);
    let covered: Vec<bool> = capture
        .object_id
        .par_iter()
        .zip(capture.depth.par_iter())
        .map(|(&id, &z)| z.is_finite() && z > 0.0 && is_member(id))
        .collect();
    let depth: Vec<f32> = capture
        .depth
        .par_iter()
        .zip(covered.par_iter())
        .map(|(&z, &c)| if c { window.offset_depth(z) } else { 0.0 })
        .collect();

    // Step 2: per pixel, the highest-weight class whose test it meets.
    let mut classes = vec![PixelClass::Background; pixel_count];
    classes
        .par_chunks_mut(width)
        .enumerate()
        .for_each(|(y, row)| {
            for (x, class) in row.iter_mut().enumerate() {
                *class = classify_pixel(&covered, &depth, width, height, x, y, t_c0, t_c1);
            }
        });
    classes
}

/// The class of pixel (x, y): tests in decreasing weight order.
#[allow(clippy::too_many_arguments)]
fn classify_pixel(
    covered: &[bool],
    depth: &[f32],
    width: usize,
    height: usize,
    x: usize,
    y: usize,
    t_c0: f32,
    t_c1: f32,
) -> PixelClass {
    let i = y * width + x;
    if !covered[i] {
        return PixelClass::Background;
    }
    // 4-neighbours inside the image: (left, right, up, down).
    let left = (x > 0).then(|| i - 1);
    let right = (x + 1 < width).then(|| i + 1);
    let up = (y > 0).then(|| i - width);
    let down = (y + 1 < height).then(|| i + width);
    let neighbours = [left, right, up, down];

    // Exterior silhouette: a 4-neighbour (inside the image) not covered by the object.
    if neighbours.iter().flatten().any(|&j| !covered[j]) {
        return PixelClass::ExteriorSilhouette;
    }
    // All in-image 4-neighbours are covered from here on.
    let z = depth[i];

    // C0: some neighbour farther by more than T_C0 (Z[i±1] − Z[i] > T_C0).
    if neighbours.iter().flatten().any(|&j| depth[j] - z > t_c0) {
        return PixelClass::InteriorSilhouette;
    }

    // C1: |(Z[i−1] − Z[i]) − (Z[i] − Z[i+1])| ≥ T_C1 along the row or the column.
    let second_difference = |a: Option<usize>, b: Option<usize>| match (a, b) {
        (Some(a), Some(b)) => ((depth[a] - z) - (z - depth[b])).abs(),
        _ => 0.0,
    };
    if second_difference(left, right) >= t_c1 || second_difference(up, down) >= t_c1 {
        return PixelClass::SharpEdge;
    }
    PixelClass::Interior
}
