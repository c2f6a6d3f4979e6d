//! Weighted half-edge collapse: paper 000 §3.1.3.3 (edge collapsing) and §3.1.4
//! (MVMesh: l′ over the cell, per-vertex view sets, the collapse constraint); its
//! precursor 003 §4.1.4 ("weight-based edge collapsing").
//!
//! The cost of collapsing an edge (v_i, v_j) is
//!
//! ```text
//! cost(v_i, v_j) = (1.5 − n_i·n_j)² · l · (w_i + w_j)
//! ```
//!
//! with n the vertex normals, w the vertex weights (from the depth-image classes of
//! the capture, given as input) and l the edge's projected length in pixels. l is
//! the caller's choice ([`ProjectedLength`]): seen from the cell centre for an
//! SVMesh, the maximum over the cell's corners for an MVMesh (the paper's l′, "the
//! projected length of the edge with respect to the cell").
//!
//! Edges sit in a min-heap by cost; the top edge is collapsed, the vertex of smaller
//! weight into the other, until the top edge's cost reaches T_l. The collapse is a
//! *half-edge* collapse: the surviving vertex keeps its original position, so the
//! output only references original vertex ids and a pack stores plain indices, as
//! the paper does.
//!
//! Choices the paper leaves open, written down here:
//!
//! - **Attributes of the survivor.** The survivor keeps its own normal, weight and
//!   view set. §3.1.4 says "the views associated with a vertex cannot propagate in
//!   the course of edge collapsing"; we treat weight and normal the same way, so an
//!   edge's cost depends only on its two (original) vertices and never changes.
//! - **Stopping rule.** An edge collapses while `cost < T_l` (strictly), so T_l = 0
//!   leaves every mesh unchanged, even one with zero weights.
//! - **Equal weights.** §3.1.4 allows u → v when `w_u ≤ w_v`; with equal weights an
//!   interior vertex goes into a boundary one first, else the lower vertex id into
//!   the higher one first; the other direction is tried if the first is rejected.
//! - **MV constraint (§3.1.4).** With view sets, u may collapse into v only if
//!   `w_u ≤ w_v` and the two share a view (`set_u & set_v ≠ 0`) or both sets are
//!   empty. A triangle's view set is the AND of its vertices' sets.
//! - **Rejected collapses** (the paper only says edge collapsing \[14\]; these are the
//!   usual safeguards):
//!   - the link condition (the common neighbours of u and v are exactly the
//!     vertices opposite the edge) so the mesh stays manifold;
//!   - the boundary condition of \[14\] (Hoppe's progressive meshes, which §3.1.3.3
//!     cites): two boundary vertices merge only along a boundary edge. A boundary
//!     vertex may go into an interior one when its weight is lower (the capture
//!     weights, 0.5 on exterior silhouettes, keep real silhouettes);
//!   - a collapse never deletes a whole connected piece (v keeps a triangle);
//!   - no directed edge may appear twice around the survivor (edge-manifold and
//!     consistently oriented even where the input is not manifold elsewhere);
//!   - no triangle may become degenerate (zero area) or duplicate another;
//!   - no triangle's normal may turn by 90° or more ([`MIN_NORMAL_TURN_COS`]);
//!   - a vertex whose neighbourhood is not one disc or half-disc (a non-manifold
//!     vertex, e.g. a bow-tie where a triangle subset touches itself) is not
//!     removed while it stays so;
//!   - a *locked* vertex ([`SimplifyInput::locked`]) is never removed (it may be the
//!     survivor). The worker locks the cut border of every chunk of a split object
//!     (`format::Model::locked_vertices`, `scene::chunk`; issue 29): each chunk is
//!     simplified on its own, and the boundary condition above still lets a border
//!     vertex merge along the border, or go into an interior vertex of higher
//!     weight, in one chunk and not in its neighbour, which left one-pixel cracks
//!     of sky between the proxies of two terrain chunks (80 of the terrain walk's
//!     317 frames). With the border locked, two chunks' proxies share every border
//!     vertex, in the LOD chain levels as in every cell's collapse. A locked vertex
//!     group (welding, below) is locked when one of its copies is.
//! - **Retrying.** A rejected edge leaves the heap and is pushed again when a
//!   collapse changes the neighbourhood of one of its vertices. When it comes up
//!   again with no triangle around its ends or opposite corners changed since (their
//!   corners or carried points), it is rejected without the tests, which would
//!   answer as before. Every test but one reads only the fans of the edge's two
//!   ends (their triangles, corners and static per-vertex data); the one is the
//!   deviation bound at the points carried around u, which also reads the carried
//!   points and the opposite corners' fans. An edge whose every direction failed
//!   another test is rejected again while its two ends' fans are unchanged as
//!   lists of triangles, whatever happened around them (`fans_unchanged_since`).
//!   The tests run cheapest-rejecting first (the deviation bound before the link
//!   condition and the fan tests); the order changes no answer.
//! - **Heap.** Since the survivor keeps its attributes, an edge's cost never
//!   changes: the min-heap is invalidated lazily (an entry whose vertex was removed
//!   is skipped when popped), edges new to the survivor are pushed after each
//!   collapse, and edges that can never collapse (weight order, view sets) or cost
//!   T_l or more are never pushed. Each edge is in the heap at most once.
//! - **Determinism.** Heap ties are broken by (cost, lower id, higher id); all
//!   adjacency is index-based; output triangles are the surviving input triangles in
//!   input order, with their corners renamed.
//!
//! **Deviation bound (not in the paper; `bake.max_deviation_px`, default 0.5 px).**
//! The paper's cost lets a flat silhouette edge of up to 18 px collapse (exterior
//! silhouette weight 0.5 on both ends, n_i·n_j ≈ 1: cost = 0.25 · l · 1 < 4.5), and the
//! viewer anywhere in the cell then sees ears, tails and limbs cut back against the
//! sky. On park-2m that was ~90% of the check's squared error (cell 275, worst view:
//! 3,956 pixels where exactly one of reference and proxy shows the sky). With a bound
//! of `max_px` pixels, a collapse is also rejected unless every point it moves stays
//! within `max_px / ppr × d(p)` of the new fan of v, d(p) being the distance from the
//! point to the nearest point of the cell's prism (so the bound holds in pixels seen
//! from anywhere in the cell, for SVMeshes too). "Every point it moves" is u and all
//! earlier removed vertices carried by u's triangles: each removed vertex is carried
//! by the surviving triangle nearest to it, and is re-assigned whenever that
//! triangle changes, so the bound holds for every original vertex at the end, not
//! just per step (tests/simplify.rs checks exactly that). It changes no cost and no
//! order; it only refuses collapses. `None` (bake.max_deviation_px = 0) is the
//! paper's algorithm as written; the bunny table of Fig. 4/6 is measured that way.
//! Measured on five park-2m cells (`worker check`, pooled PSNR(Y)): unbounded
//! 35.2–40.3 dB with 9,277–14,681 proxy triangles per cell; 1 px 39.9–44.2 dB with
//! 14,022–30,148; 0.5 px 42.8–46.6 dB with 21,886–53,371 (BENCHMARKS.md).
//!
//! **Welding (issue 18, not in the paper).** Textured and flat-shaded models split
//! a vertex wherever its UV or normal jumps (a UV-seamed box has 24 vertices at 8
//! corners). On the split ids a seam is an open boundary, which the boundary
//! condition and the link condition freeze, so such a model kept its seams and
//! lost the rest, or fell apart. The collapse therefore runs on the
//! *position-welded* topology: the input vertices its triangles use are grouped by
//! bit-equal position (−0 = +0), each group acts as one vertex, its lowest id (the
//! representative) standing for it, with the group's normalised normal sum, its
//! highest weight and the OR of its view sets. An input triangle that welding would
//! make degenerate or a repeat of an earlier welded one (a two-sided sheet) keeps its
//! own ids. Each output corner is mapped back to an input id at the same position:
//! a corner that did not move keeps its own id (and its UV, normal, colour); a corner
//! renamed to a surviving group takes the group's copy whose normal is nearest the
//! corner's old one (lowest id on a tie), so a box face keeps its own face's copies.
//! View masks are the AND of the mapped-back ids' sets, as ever. The log names
//! representatives. A mesh without two vertices at one position runs unchanged.
//!
//! [`validate`] checks every output (every test calls it).
//!
//! One algorithm in one file (issue 28: over 1,000 lines only where one algorithm
//! needs it): the cost, the constraints, the queue and the validation of a collapse
//! sequence are read together against the paper.

use glam::Vec3;
use std::cmp::Ordering;
use std::collections::BinaryHeap;
use std::f32::consts::PI;

/// A triangle's normal may turn by less than 90° in a collapse (`cos 90° = 0`):
/// a collapse that turns any triangle by more is a fold-over and is rejected.
pub const MIN_NORMAL_TURN_COS: f32 = 0.0;

/// Views of a cell's MVMeshes, the most a view set (a `u8` bit mask) names: the
/// cell centre and its 6 neighbours' centres (§3.1.4). Not the pack's limit
/// [`format::pack::cell::MAX_MV_VIEWS`] (8, what a reader accepts), which it must not exceed.
pub const CELL_VIEWS: u32 = 7;
const _: () = assert!(CELL_VIEWS as usize <= format::pack::cell::MAX_MV_VIEWS);

/// Pixels per radian of a capture whose `image_res` pixels span one 60° side face
/// (DESIGN.md "Capture resolution").
pub fn pixels_per_radian(image_res: u32) -> f32 {
    image_res as f32 / (PI / 3.0)
}

/// How the edge's projected length l (pixels) is measured.
#[derive(Clone, Debug, PartialEq)]
pub enum ProjectedLength {
    /// SVMesh: the angle the edge subtends seen from `eye` (the cell centre) ×
    /// pixels per radian.
    FromPoint { eye: Vec3, pixels_per_radian: f32 },
    /// The maximum of that over `eyes`.
    MaxOverPoints {
        eyes: Vec<Vec3>,
        pixels_per_radian: f32,
    },
    /// MVMesh: the paper's l′, "the projected length of the edge with respect to the
    /// cell": the maximum over the viewpoints of the cell's prism, taken over its 12
    /// corners and the prism's point nearest to the edge's midpoint. The corners
    /// alone miss the viewer standing at the middle of the side face next to a near
    /// object (for an object 5 units outside a face of a 50-unit cell, the face's
    /// middle is 5 units away and the nearest corner ~25), and l′ was ~5× too small
    /// there: such objects were simplified for a far viewer and showed 2–5 pixel
    /// silhouette errors from the face.
    MaxOverPrism {
        prism: crate::grid::Prism,
        pixels_per_radian: f32,
    },
}

impl ProjectedLength {
    /// The fixed viewpoints (for `MaxOverPrism`: the 12 corners; the per-edge
    /// nearest point comes on top).
    fn eyes(&self) -> Vec<Vec3> {
        match self {
            ProjectedLength::FromPoint { eye, .. } => vec![*eye],
            ProjectedLength::MaxOverPoints { eyes, .. } => eyes.clone(),
            ProjectedLength::MaxOverPrism { prism, .. } => prism.corners().to_vec(),
        }
    }

    fn prism(&self) -> Option<&crate::grid::Prism> {
        match self {
            ProjectedLength::MaxOverPrism { prism, .. } => Some(prism),
            _ => None,
        }
    }

    fn pixels_per_radian(&self) -> f32 {
        match self {
            ProjectedLength::FromPoint {
                pixels_per_radian, ..
            }
            | ProjectedLength::MaxOverPoints {
                pixels_per_radian, ..
            }
            | ProjectedLength::MaxOverPrism {
                pixels_per_radian, ..
            } => *pixels_per_radian,
        }
    }

    /// Projected length in pixels of the world-space edge `a`–`b`: the largest angle
    /// it subtends from any of the eyes × pixels per radian. An endpoint on an eye
    /// gives `f32::INFINITY` (never collapsed); no eyes gives 0 ([`simplify`]
    /// refuses an empty eye list).
    pub fn pixels(&self, a: Vec3, b: Vec3) -> f32 {
        let mut eyes = self.eyes();
        if let Some(prism) = self.prism() {
            eyes.push(prism.closest_point(0.5 * (a + b)));
        }
        let mut chord: f32 = 0.0;
        for eye in eyes {
            match chord_from(eye, a, b) {
                Some(c) => chord = chord.max(c),
                None => return f32::INFINITY,
            }
        }
        chord_to_angle(chord) * self.pixels_per_radian()
    }
}

/// Chord between the unit directions from `eye` to `a` and to `b` (`None` when an
/// endpoint is on the eye).
fn chord_from(eye: Vec3, a: Vec3, b: Vec3) -> Option<f32> {
    Some((unit_direction(a - eye)? - unit_direction(b - eye)?).length())
}

fn unit_direction(d: Vec3) -> Option<Vec3> {
    let len = d.length();
    (len > 1e-12 && len.is_finite()).then(|| d / len)
}

/// The angle between two unit vectors from the length of their difference.
fn chord_to_angle(chord: f32) -> f32 {
    2.0 * (0.5 * chord).min(1.0).asin()
}

/// What [`simplify`] works on: a triangle subset of one model, in world space.
#[derive(Clone, Copy, Debug)]
pub struct SimplifyInput<'a> {
    /// World-space positions of all the model's vertices.
    pub positions: &'a [Vec3],
    /// World-space unit vertex normals, one per position.
    pub normals: &'a [Vec3],
    /// The triangles to simplify (e.g. the front-facing subset), counter-clockwise,
    /// indexing `positions`. Note: a front-facing subset of a scanned mesh has a
    /// jagged boundary (single back-facing triangles leave one-triangle holes) that
    /// the link condition keeps at full resolution; passing the whole mesh with
    /// back-facing vertices at weight 0.5 (§3.1.3.2) and dropping back faces
    /// afterwards simplifies much further (see the bunny table in
    /// `tests/simplify.rs`).
    pub triangles: &'a [[u32; 3]],
    /// Vertex weights from the capture (§3.1.3.2), one per position.
    pub weights: &'a [f32],
    /// MVMesh only: per-vertex view set, bit k = visible from view k (k < 7).
    pub view_sets: Option<&'a [u8]>,
    /// Vertices no collapse may remove (`true`), one per position; `None`: none.
    /// A locked vertex never moves, though others may collapse into it: the cut
    /// border of a chunk of a split object (module docs, "Rejected collapses";
    /// `format::Model::locked_vertices`, issue 29).
    pub locked: Option<&'a [bool]>,
}

/// The per-vertex mask of [`SimplifyInput::locked`] for a model of `vertex_count`
/// vertices whose [`format::Model::locked_vertices`] are `locked` (ids past the
/// end lock nothing); `None` when nothing is locked.
pub fn locked_mask(vertex_count: usize, locked: &[u32]) -> Option<Vec<bool>> {
    if locked.is_empty() {
        return None;
    }
    let mut mask = vec![false; vertex_count];
    for &v in locked {
        if let Some(m) = mask.get_mut(v as usize) {
            *m = true;
        }
    }
    Some(mask)
}

/// Parameters of one simplification.
#[derive(Clone, Debug, PartialEq)]
pub struct SimplifyParams {
    /// T_l: edges collapse while their cost is below this (pixels).
    pub edge_length_tolerance_px: f32,
    /// How l is measured (SV: from the cell centre; MV: max over the corners).
    pub length: ProjectedLength,
    /// Optional bound on the geometric deviation (our addition, module docs);
    /// `None` runs the paper's algorithm as written.
    pub deviation: Option<DeviationBound>,
}

/// A bound on how far the simplified surface may move, in pixels seen from
/// anywhere in a view region (not in the paper; see the module docs, "Deviation
/// bound").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeviationBound {
    /// Largest allowed deviation in pixels (of [`ProjectedLength`]'s pixels per
    /// radian); must be positive and finite.
    pub max_px: f32,
    /// Where the viewer may stand (the cell's prism).
    pub region: crate::grid::Prism,
}

impl DeviationBound {
    /// World-space tolerance at `p`: `max_px / ppr` radians at the distance of the
    /// region's nearest point (0 inside the region).
    pub fn world_tolerance(&self, p: Vec3, pixels_per_radian: f32) -> f32 {
        self.max_px / pixels_per_radian * p.distance(self.region.closest_point(p))
    }
}

/// One half-edge collapse, in the order performed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Collapse {
    /// The removed vertex (u).
    pub from: u32,
    /// The surviving vertex (v); keeps its position, normal, weight and view set.
    pub into: u32,
    pub cost: f32,
}

/// A simplified triangle subset.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Simplified {
    /// Surviving triangles in input order, referencing original vertex ids.
    pub triangles: Vec<[u32; 3]>,
    /// MVMesh: per-triangle view set (AND of its vertices' sets); empty for SVMesh.
    pub view_masks: Vec<u8>,
    /// Number of collapses performed (`log.len()`).
    pub collapses: u32,
    /// Every collapse in the order performed.
    pub log: Vec<Collapse>,
    /// Input triangles dropped before simplifying because they repeat a vertex or
    /// repeat the vertex set of an earlier input triangle.
    pub dropped_input_triangles: u32,
}

/// Bad input to [`simplify`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimplifyError {
    #[error("{what} has {found} entries, expected {expected} (one per position)")]
    LengthMismatch {
        what: &'static str,
        expected: usize,
        found: usize,
    },
    #[error("triangle {triangle} references vertex {vertex}, but there are {vertex_count}")]
    IndexOutOfRange {
        triangle: usize,
        vertex: u32,
        vertex_count: usize,
    },
    #[error("{what} of vertex {vertex} is not finite")]
    NonFinite { what: &'static str, vertex: u32 },
    #[error("view set of vertex {vertex} is {set:#04x}, but only {CELL_VIEWS} views exist")]
    ViewSetOutOfRange { vertex: u32, set: u8 },
    #[error("edge-length tolerance {0} is negative or not a number")]
    BadTolerance(f32),
    #[error("pixels per radian {0} is not positive and finite")]
    BadPixelsPerRadian(f32),
    #[error("the projected length has no eyes to measure from")]
    NoEyes,
    #[error("too many vertices ({0}) for u32 ids")]
    TooManyVertices(usize),
    #[error("deviation bound {0} px is not positive and finite")]
    BadDeviation(f32),
}

/// A broken simplified mesh, found by [`validate`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ValidationError {
    #[error(
        "output triangle {triangle} references vertex {vertex}, but the model has {vertex_count}"
    )]
    IndexOutOfRange {
        triangle: usize,
        vertex: u32,
        vertex_count: usize,
    },
    #[error("output triangle {triangle} references vertex {vertex}, which no input triangle uses")]
    VertexNotInInput { triangle: usize, vertex: u32 },
    #[error("output triangle {triangle} {corners:?} is degenerate")]
    Degenerate { triangle: usize, corners: [u32; 3] },
    #[error("output triangles {first} and {second} have the same vertices {corners:?}")]
    Duplicate {
        first: usize,
        second: usize,
        corners: [u32; 3],
    },
    #[error(
        "edge {a}-{b} is used {uses} times ({forward} as {a}->{b}); the input was manifold there"
    )]
    NonManifoldEdge {
        a: u32,
        b: u32,
        uses: u32,
        forward: u32,
    },
    #[error("{masks} view masks for {triangles} triangles")]
    MaskCount { masks: usize, triangles: usize },
    #[error(
        "triangle {triangle} has view mask {found:#04x}, its vertices' sets AND to {expected:#04x}"
    )]
    WrongMask {
        triangle: usize,
        expected: u8,
        found: u8,
    },
    #[error("collapse log has {log} entries but `collapses` says {count}")]
    CollapseCount { log: usize, count: u32 },
}

/// Simplifies `input` with the cost and stopping rule of 000 §3.1.3.3 (and the MV
/// constraint of §3.1.4 when `input.view_sets` is given).
pub fn simplify(
    input: &SimplifyInput,
    params: &SimplifyParams,
) -> Result<Simplified, SimplifyError> {
    simplify_seeded(input, params, None)
}

/// [`simplify`] starting from a coarser level of the model ([`crate::lod_chain`]):
/// `carried[t]` lists the original vertices that input triangle `t` already carries
/// (removed by the chain's collapses). The deviation bound then covers them too, so
/// it holds for every original vertex under the input triangles, end to end, as if
/// the collapse had started from the full model. Ignored without a bound.
pub fn simplify_seeded(
    input: &SimplifyInput,
    params: &SimplifyParams,
    carried: Option<Vec<Vec<u32>>>,
) -> Result<Simplified, SimplifyError> {
    check_carried(input, carried.as_deref())?;
    let ppr = params.length.pixels_per_radian();
    if !(ppr.is_finite() && ppr > 0.0) {
        return Err(SimplifyError::BadPixelsPerRadian(ppr));
    }
    if params.length.eyes().is_empty() {
        return Err(SimplifyError::NoEyes);
    }
    check_input(input, params.edge_length_tolerance_px)?;
    let tolerances = match &params.deviation {
        None => None,
        Some(bound) if !(bound.max_px.is_finite() && bound.max_px > 0.0) => {
            return Err(SimplifyError::BadDeviation(bound.max_px))
        }
        Some(bound) => Some(
            input
                .positions
                .iter()
                .map(|&p| bound.world_tolerance(p, ppr))
                .collect::<Vec<f32>>(),
        ),
    };
    // Unit directions from every eye to every vertex the triangles use, computed
    // once: an edge's l is then one chord per eye (the same arithmetic as
    // `ProjectedLength::pixels`). `slot` maps a vertex id to its row.
    let eyes = params.length.eyes();
    let eyes = &eyes[..];
    let prism = params.length.prism();
    let mut slot = vec![u32::MAX; input.positions.len()];
    let mut directions: Vec<Option<Vec3>> = Vec::new();
    for tri in input.triangles {
        for &v in tri {
            if slot[v as usize] == u32::MAX {
                slot[v as usize] = (directions.len() / eyes.len().max(1)) as u32;
                let p = input.positions[v as usize];
                directions.extend(eyes.iter().map(|&eye| unit_direction(p - eye)));
            }
        }
    }
    let length = |a: u32, b: u32| -> f32 {
        let mut chord: f32 = 0.0;
        if let Some(prism) = prism {
            let (pa, pb) = (input.positions[a as usize], input.positions[b as usize]);
            match chord_from(prism.closest_point(0.5 * (pa + pb)), pa, pb) {
                Some(c) => chord = c,
                None => return f32::INFINITY,
            }
        }
        let row = |v: u32| slot[v as usize] as usize * eyes.len();
        let (a, b) = (row(a), row(b));
        for k in 0..eyes.len() {
            match (directions[a + k], directions[b + k]) {
                (Some(da), Some(db)) => chord = chord.max((da - db).length()),
                _ => return f32::INFINITY,
            }
        }
        chord_to_angle(chord) * ppr
    };
    let deviation = tolerances.map(|t| {
        let mut dev = Deviation::new(t, input.triangles.len());
        dev.seed(carried);
        dev
    });
    Ok(collapse_welded(input, deviation, params.edge_length_tolerance_px, length).simplified)
}

/// Checks the carried lists of [`simplify_seeded`] / [`collapse_within`].
fn check_carried(input: &SimplifyInput, carried: Option<&[Vec<u32>]>) -> Result<(), SimplifyError> {
    let Some(carried) = carried else {
        return Ok(());
    };
    if carried.len() != input.triangles.len() {
        return Err(SimplifyError::LengthMismatch {
            what: "carried lists",
            expected: input.triangles.len(),
            found: carried.len(),
        });
    }
    for (t, list) in carried.iter().enumerate() {
        if let Some(&vertex) = list.iter().find(|&&v| v as usize >= input.positions.len()) {
            return Err(SimplifyError::IndexOutOfRange {
                triangle: t,
                vertex,
                vertex_count: input.positions.len(),
            });
        }
    }
    Ok(())
}

/// What [`collapse_within`] returns: the simplified triangles and, per surviving
/// triangle (in output order), the removed vertices it carries.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Tracked {
    pub simplified: Simplified,
    pub carried: Vec<Vec<u32>>,
}

/// The collapse with a plain world-space tolerance per vertex instead of a bound
/// in pixels (the per-model LOD chain, [`crate::lod_chain`]): every collapse the
/// module's rules allow is taken, cheapest `cost` first (`length(a, b)` is l), while
/// every removed vertex (and every vertex `carried` already lists, e.g. from a finer
/// level) stays within `tolerance[v]` of the surviving surface; returns the result
/// and the final carriers, so a coarser level or a cell can continue from it.
pub fn collapse_within(
    input: &SimplifyInput,
    length: impl Fn(u32, u32) -> f32,
    tolerance: Vec<f32>,
    carried: Option<Vec<Vec<u32>>>,
) -> Result<Tracked, SimplifyError> {
    check_input(input, f32::INFINITY)?;
    check_carried(input, carried.as_deref())?;
    if tolerance.len() != input.positions.len() {
        return Err(SimplifyError::LengthMismatch {
            what: "tolerances",
            expected: input.positions.len(),
            found: tolerance.len(),
        });
    }
    let mut dev = Deviation::new(tolerance, input.triangles.len());
    dev.seed(carried);
    let welded = collapse_welded(input, Some(dev), f32::INFINITY, length);
    let mut dev = welded.deviation.expect("given above");
    let carried = welded
        .kept
        .iter()
        .map(|&t| std::mem::take(&mut dev.carried[t]))
        .collect();
    Ok(Tracked {
        simplified: welded.simplified,
        carried,
    })
}

/// [`simplify`] with a caller-supplied projected length: `length_px(a, b)` gives l
/// in pixels for the edge between vertex ids `a` and `b` (symmetric).
pub fn simplify_with(
    input: &SimplifyInput,
    edge_length_tolerance_px: f32,
    length_px: impl Fn(u32, u32) -> f32,
) -> Result<Simplified, SimplifyError> {
    check_input(input, edge_length_tolerance_px)?;
    Ok(collapse_welded(input, None, edge_length_tolerance_px, length_px).simplified)
}

/// `triangles` with every vertex renamed to the lowest id at its bit-equal
/// position (−0 = +0), the topology [`simplify`] collapses on (module docs,
/// "Welding"); borrowed as they are when no two vertices share a position. For
/// connectivity outside the collapse (e.g. `svmesh::tidy_selection`, whose specks
/// would otherwise be every face of a UV-seamed box).
pub fn welded_triangles<'t>(
    positions: &[[f32; 3]],
    triangles: &'t [[u32; 3]],
) -> std::borrow::Cow<'t, [[u32; 3]]> {
    let key = |v: u32| positions[v as usize].map(|x| (x + 0.0).to_bits());
    let mut order: Vec<u32> = (0..positions.len() as u32).collect();
    order.sort_unstable_by_key(|&v| (key(v), v));
    let mut rep: Vec<u32> = (0..positions.len() as u32).collect();
    let mut any = false;
    for k in 1..order.len() {
        if key(order[k]) == key(order[k - 1]) {
            rep[order[k] as usize] = rep[order[k - 1] as usize];
            any = true;
        }
    }
    if !any {
        return std::borrow::Cow::Borrowed(triangles);
    }
    std::borrow::Cow::Owned(
        triangles
            .iter()
            .map(|t| t.map(|v| rep.get(v as usize).copied().unwrap_or(v)))
            .collect(),
    )
}

/// What [`collapse_welded`] returns.
struct WeldedRun {
    /// The result in `input`'s vertex ids.
    simplified: Simplified,
    /// The input triangles that survive, in order (one per output triangle).
    kept: Vec<usize>,
    /// The deviation bookkeeping after the run, when one was given.
    deviation: Option<Deviation>,
}

/// The input's topology on position-welded vertices (module docs, "Welding").
struct Weld {
    normals: Vec<Vec3>,
    weights: Vec<f32>,
    view_sets: Option<Vec<u8>>,
    locked: Option<Vec<bool>>,
    /// Input triangles on representatives (or their own ids, see the docs).
    triangles: Vec<[u32; 3]>,
    /// Per representative with more than one copy: its copies, ascending (only ids
    /// that welded triangle corners use); empty elsewhere.
    copies: Vec<Vec<u32>>,
}

impl Weld {
    /// `None` when no two vertices the triangles use share a position.
    fn of(input: &SimplifyInput) -> Option<Weld> {
        let n = input.positions.len();
        let key = |v: u32| {
            let p = input.positions[v as usize] + Vec3::ZERO; // −0 → +0
            [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]
        };
        let mut used = vec![false; n];
        let mut order = Vec::new();
        for tri in input.triangles {
            for &v in tri {
                if !std::mem::replace(&mut used[v as usize], true) {
                    order.push(v);
                }
            }
        }
        order.sort_unstable_by_key(|&v| (key(v), v));
        // Step 1: the representative of every used vertex.
        let mut rep: Vec<u32> = (0..n as u32).collect();
        let mut any = false;
        for k in 1..order.len() {
            if key(order[k]) == key(order[k - 1]) {
                rep[order[k] as usize] = rep[order[k - 1] as usize];
                any = true;
            }
        }
        if !any {
            return None;
        }
        // Step 2: welded triangles; dropped ones (degenerate or repeated in the
        // input) become degenerate so the collapser drops them as before.
        let mut seen_input = std::collections::HashSet::new();
        let mut seen_welded = std::collections::HashSet::new();
        let mut welded_corner = vec![false; n];
        let triangles = input
            .triangles
            .iter()
            .map(|&tri| {
                let key = sorted(tri);
                if key[0] == key[1] || key[1] == key[2] || !seen_input.insert(key) {
                    return [tri[0]; 3];
                }
                let w = tri.map(|v| rep[v as usize]);
                let wkey = sorted(w);
                if wkey[0] == wkey[1] || wkey[1] == wkey[2] || !seen_welded.insert(wkey) {
                    return tri; // a two-sided sheet or a sliver: its own ids
                }
                for v in tri {
                    welded_corner[v as usize] = true;
                }
                w
            })
            .collect();
        // Step 3: the groups' copies and attributes.
        let mut copies = vec![Vec::new(); n];
        for &v in &order {
            if welded_corner[v as usize] {
                copies[rep[v as usize] as usize].push(v);
            }
        }
        let mut normals = input.normals.to_vec();
        let mut weights = input.weights.to_vec();
        let mut view_sets = input.view_sets.map(<[u8]>::to_vec);
        let mut locked = input.locked.map(<[bool]>::to_vec);
        for (r, group) in copies.iter_mut().enumerate() {
            if group.len() < 2 {
                group.clear();
                continue;
            }
            group.sort_unstable();
            let sum: Vec3 = group.iter().map(|&v| input.normals[v as usize]).sum();
            normals[r] = sum.try_normalize().unwrap_or(input.normals[r]);
            weights[r] = group
                .iter()
                .map(|&v| input.weights[v as usize])
                .fold(f32::NEG_INFINITY, f32::max);
            if let (Some(out), Some(sets)) = (view_sets.as_mut(), input.view_sets) {
                out[r] = group.iter().fold(0, |acc, &v| acc | sets[v as usize]);
            }
            if let (Some(out), Some(lock)) = (locked.as_mut(), input.locked) {
                out[r] = group.iter().any(|&v| lock[v as usize]);
            }
        }
        Some(Weld {
            normals,
            weights,
            view_sets,
            locked,
            triangles,
            copies,
        })
    }

    /// An output triangle in input ids: `input` its input corners, `start` its
    /// welded corners, `now` its corners after the collapse (module docs).
    fn map_back(
        &self,
        input_normals: &[Vec3],
        input: [u32; 3],
        start: [u32; 3],
        now: [u32; 3],
    ) -> [u32; 3] {
        let mut out = [u32::MAX; 3];
        for k in 0..3 {
            if now[k] == start[k] {
                out[k] = input[k];
            }
        }
        for k in 0..3 {
            if out[k] != u32::MAX {
                continue;
            }
            let group = &self.copies[now[k] as usize];
            let old = input_normals[input[k] as usize];
            out[k] = group
                .iter()
                .copied()
                .filter(|c| {
                    !out.contains(c) && !now.iter().enumerate().any(|(j, &x)| j != k && x == *c)
                })
                .fold((f32::NEG_INFINITY, now[k]), |best, c| {
                    let d = input_normals[c as usize].dot(old);
                    if d > best.0 {
                        (d, c)
                    } else {
                        best
                    }
                })
                .1;
        }
        if out[0] == out[1] || out[1] == out[2] || out[0] == out[2] {
            now
        } else {
            out
        }
    }
}

/// Runs the collapse on the position-welded topology of `input` (module docs,
/// "Welding") and maps the result back to `input`'s vertex ids.
fn collapse_welded(
    input: &SimplifyInput,
    deviation: Option<Deviation>,
    tolerance: f32,
    length_px: impl Fn(u32, u32) -> f32,
) -> WeldedRun {
    let Some(weld) = Weld::of(input) else {
        let mut collapser = Collapser::new(input);
        collapser.deviation = deviation;
        let simplified = collapser.run(tolerance, length_px);
        let kept = (0..input.triangles.len())
            .filter(|&t| collapser.alive[t])
            .collect();
        return WeldedRun {
            simplified,
            kept,
            deviation: collapser.deviation,
        };
    };
    let welded = SimplifyInput {
        positions: input.positions,
        normals: &weld.normals,
        triangles: &weld.triangles,
        weights: &weld.weights,
        view_sets: weld.view_sets.as_deref(),
        locked: weld.locked.as_deref(),
    };
    let mut collapser = Collapser::new(&welded);
    collapser.deviation = deviation;
    let mut simplified = collapser.run(tolerance, length_px);
    let kept: Vec<usize> = (0..input.triangles.len())
        .filter(|&t| collapser.alive[t])
        .collect();
    let mapped: Vec<[u32; 3]> = kept
        .iter()
        .map(|&t| {
            weld.map_back(
                input.normals,
                input.triangles[t],
                weld.triangles[t],
                collapser.triangles[t],
            )
        })
        .collect();
    // Distinct welded triangles map to distinct ones; should a corner case of
    // two-sided sheets break that, the representatives' triangles stand.
    let mut keys: Vec<[u32; 3]> = mapped.iter().map(|&t| sorted(t)).collect();
    keys.sort_unstable();
    if keys.windows(2).all(|w| w[0] != w[1]) {
        simplified.triangles = mapped;
    }
    if let Some(sets) = input.view_sets {
        simplified.view_masks = simplified
            .triangles
            .iter()
            .map(|t| sets[t[0] as usize] & sets[t[1] as usize] & sets[t[2] as usize])
            .collect();
    }
    WeldedRun {
        simplified,
        kept,
        deviation: collapser.deviation,
    }
}

fn check_input(input: &SimplifyInput, tolerance: f32) -> Result<(), SimplifyError> {
    let n = input.positions.len();
    if n > u32::MAX as usize {
        return Err(SimplifyError::TooManyVertices(n));
    }
    if tolerance.is_nan() || tolerance < 0.0 {
        return Err(SimplifyError::BadTolerance(tolerance));
    }
    let lengths = [
        ("normals", input.normals.len()),
        ("weights", input.weights.len()),
        ("view_sets", input.view_sets.map_or(n, <[u8]>::len)),
        ("locked", input.locked.map_or(n, <[bool]>::len)),
    ];
    for (what, found) in lengths {
        if found != n {
            return Err(SimplifyError::LengthMismatch {
                what,
                expected: n,
                found,
            });
        }
    }
    for (t, tri) in input.triangles.iter().enumerate() {
        if let Some(&vertex) = tri.iter().find(|&&v| v as usize >= n) {
            return Err(SimplifyError::IndexOutOfRange {
                triangle: t,
                vertex,
                vertex_count: n,
            });
        }
    }
    // Only vertices the triangles use matter; check those.
    for tri in input.triangles {
        for &v in tri {
            let i = v as usize;
            let checks = [
                ("position", input.positions[i].is_finite()),
                ("normal", input.normals[i].is_finite()),
                ("weight", input.weights[i].is_finite()),
            ];
            if let Some((what, _)) = checks.iter().find(|(_, ok)| !ok) {
                return Err(SimplifyError::NonFinite { what, vertex: v });
            }
            if let Some(sets) = input.view_sets {
                if u32::from(sets[i]) >= 1 << CELL_VIEWS {
                    return Err(SimplifyError::ViewSetOutOfRange {
                        vertex: v,
                        set: sets[i],
                    });
                }
            }
        }
    }
    Ok(())
}

/// A heap entry: the undirected edge `a < b` and its cost. Ordered so that
/// `BinaryHeap` pops the smallest (cost, a, b).
#[derive(Clone, Copy, Debug)]
struct HeapEdge {
    cost: f32,
    a: u32,
    b: u32,
    /// The collapse count when the edge was last rejected ([`NEVER_REJECTED`]:
    /// never); not part of the order.
    rejected_at: u32,
    /// That rejection came from tests that read only the fans of `a` and `b`
    /// ([`Collapser::point_test_failed`]); not part of the order.
    fan_only: bool,
}

/// [`HeapEdge::rejected_at`] of an edge that was never rejected.
const NEVER_REJECTED: u32 = u32::MAX;

impl HeapEdge {
    fn key(&self) -> (f32, u32, u32) {
        (self.cost, self.a, self.b)
    }
}

impl PartialEq for HeapEdge {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for HeapEdge {}
impl PartialOrd for HeapEdge {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for HeapEdge {
    fn cmp(&self, other: &Self) -> Ordering {
        let (c0, a0, b0) = self.key();
        let (c1, a1, b1) = other.key();
        // Reversed: the max-heap pops the smallest key.
        c1.total_cmp(&c0).then(a1.cmp(&a0)).then(b1.cmp(&b0))
    }
}

/// The mutable mesh during simplification: triangles with alive flags and an
/// index-based vertex → triangle adjacency.
struct Collapser<'a> {
    input: &'a SimplifyInput<'a>,
    triangles: Vec<[u32; 3]>,
    alive: Vec<bool>,
    /// Triangles around each vertex (alive ones only).
    fans: Vec<Vec<u32>>,
    removed: Vec<bool>,
    /// Per vertex: the other ends of its rejected edges (waiting for a change),
    /// each with the collapse count when it was rejected and whether only tests
    /// reading the two ends' fans rejected it ([`HeapEdge::fan_only`]).
    rejected: Vec<Vec<(u32, u32, bool)>>,
    /// Collapses done so far.
    clock: u32,
    /// Per vertex: the collapse count when a triangle of its fan last changed (its
    /// corners, its removal, or the points it carries). A rejected edge whose two
    /// ends and opposite corners are unchanged since its rejection is rejected
    /// again without the tests: they read nothing else that changes.
    changed_at: Vec<u32>,
    /// Per vertex: the collapse count when its fan last changed as a list of
    /// triangles (a corner renamed, a triangle removed or added); unlike
    /// `changed_at`, not when a triangle of it gains or loses carried points.
    fan_changed_at: Vec<u32>,
    /// Set by [`Collapser::can_collapse`] when a candidate fails the deviation
    /// bound at the points carried around u, the one test that reads more than the
    /// fans of u and v (module docs, "Retrying").
    point_test_failed: bool,
    /// Per vertex: [`Collapser::is_boundary`]'s answer and the collapse count + 1
    /// when it was worked out (0: never); valid while its fan is unchanged.
    boundary_memo: Vec<(u32, bool)>,
    dropped: u32,
    // Scratch buffers, reused across collapses.
    scratch_u: Vec<u32>,
    scratch_v: Vec<u32>,
    scratch_edges: Vec<(u32, u32)>,
    scratch_fan: Vec<u32>,
    /// The deviation bound's bookkeeping (`None`: the paper's algorithm).
    deviation: Option<Deviation>,
}

/// Deviation bookkeeping: every removed vertex is carried by the surviving triangle
/// nearest to its original position; a collapse must keep every point it moves
/// (u and the points carried around u) within its tolerance of the new fan of v.
struct Deviation {
    /// Per vertex: allowed world distance from the simplified surface.
    tolerance: Vec<f32>,
    /// Per triangle: removed vertices it carries.
    carried: Vec<Vec<u32>>,
    /// Set by a successful `can_collapse`: (point, triangle) assignments.
    pending: Vec<(u32, u32)>,
    /// (point, index in `scratch_fan` of its carrier after the collapse).
    scratch_points: Vec<(u32, usize)>,
    /// v's fan after the candidate collapse: (triangle id, corner positions).
    scratch_fan: Vec<(u32, [Vec3; 3])>,
}

impl Deviation {
    fn new(tolerance: Vec<f32>, triangles: usize) -> Self {
        Deviation {
            tolerance,
            carried: vec![Vec::new(); triangles],
            pending: Vec::new(),
            scratch_points: Vec::new(),
            scratch_fan: Vec::new(),
        }
    }

    /// Starts from carried lists of a coarser level (checked by `check_carried`).
    fn seed(&mut self, carried: Option<Vec<Vec<u32>>>) {
        if let Some(carried) = carried {
            self.carried = carried;
        }
    }
}

impl<'a> Collapser<'a> {
    fn new(input: &'a SimplifyInput<'a>) -> Self {
        let n = input.positions.len();
        // Step 1: keep the input triangles that have three distinct vertices and a
        // vertex set no earlier triangle had.
        let mut keys: Vec<([u32; 3], u32)> = input
            .triangles
            .iter()
            .enumerate()
            .map(|(t, tri)| (sorted(*tri), t as u32))
            .collect();
        keys.sort_unstable();
        let mut alive = vec![true; input.triangles.len()];
        for (i, (key, t)) in keys.iter().enumerate() {
            let degenerate = key[0] == key[1] || key[1] == key[2];
            let repeated = i > 0 && keys[i - 1].0 == *key;
            if degenerate || repeated {
                alive[*t as usize] = false;
            }
        }
        let dropped = alive.iter().filter(|a| !**a).count() as u32;
        // Step 2: vertex → triangle adjacency.
        let mut fans: Vec<Vec<u32>> = vec![Vec::new(); n];
        for (t, tri) in input.triangles.iter().enumerate() {
            if alive[t] {
                for &v in tri {
                    fans[v as usize].push(t as u32);
                }
            }
        }
        Collapser {
            input,
            triangles: input.triangles.to_vec(),
            alive,
            fans,
            removed: vec![false; n],
            rejected: vec![Vec::new(); n],
            clock: 0,
            changed_at: vec![0; n],
            fan_changed_at: vec![0; n],
            point_test_failed: false,
            boundary_memo: vec![(0, false); n],
            dropped,
            scratch_u: Vec::new(),
            scratch_v: Vec::new(),
            scratch_edges: Vec::new(),
            scratch_fan: Vec::new(),
            deviation: None,
        }
    }

    fn run(&mut self, tolerance: f32, length_px: impl Fn(u32, u32) -> f32) -> Simplified {
        let weights = self.input.weights;
        let normals = self.input.normals;
        let cost_of = |a: u32, b: u32| -> f32 {
            let (ai, bi) = (a as usize, b as usize);
            let bend = 1.5 - normals[ai].dot(normals[bi]);
            bend * bend * length_px(a, b) * (weights[ai] + weights[bi])
        };
        // An edge is worth a heap entry only if one direction passes the static
        // rules: the weight order and, for MV, the view-set constraint (§3.1.4).
        let view_sets = self.input.view_sets;
        let locked = self.input.locked;
        let may_collapse = |u: u32, v: u32| -> bool {
            let (ui, vi) = (u as usize, v as usize);
            weights[ui] <= weights[vi]
                && locked.is_none_or(|locked| !locked[ui])
                && view_sets.is_none_or(|sets| {
                    let (su, sv) = (sets[ui], sets[vi]);
                    su & sv != 0 || (su == 0 && sv == 0)
                })
        };
        let push =
            |heap: &mut BinaryHeap<HeapEdge>, a: u32, b: u32, rejected_at: u32, fan_only: bool| {
                let (a, b) = (a.min(b), a.max(b));
                if may_collapse(a, b) || may_collapse(b, a) {
                    let cost = cost_of(a, b);
                    if cost < tolerance {
                        heap.push(HeapEdge {
                            cost,
                            a,
                            b,
                            rejected_at,
                            fan_only,
                        });
                    }
                }
            };
        let mut heap = BinaryHeap::new();
        let mut neighbours = Vec::new();
        let mut neighbours_before = Vec::new();
        let mut revived = Vec::new();
        // Step 1: every edge of the input into the heap (those that could collapse).
        // Costs depend only on the two original vertices, so an entry stays right
        // until one of its vertices is removed; each edge is at most once in the
        // heap or in `rejected`.
        for a in 0..self.fans.len() as u32 {
            self.neighbours(a, &mut neighbours);
            for &b in neighbours.iter().filter(|&&b| b > a) {
                push(&mut heap, a, b, NEVER_REJECTED, false);
            }
        }
        // Step 2: collapse the cheapest edge until the cheapest costs T_l or more.
        let mut log = Vec::new();
        while let Some(edge) = heap.pop() {
            let (a, b) = (edge.a, edge.b);
            if self.removed[a as usize] || self.removed[b as usize] {
                continue; // stale entry
            }
            if edge.cost >= tolerance {
                break; // (only finite costs below T_l are pushed; kept as a guard)
            }
            let at = edge.rejected_at;
            let unchanged = at != NEVER_REJECTED
                && if edge.fan_only {
                    self.fans_unchanged_since(a, b, at)
                } else {
                    self.unchanged_since(a, b, at)
                };
            if unchanged {
                // Rejected before and nothing the failing tests read has changed.
                self.rejected[a as usize].push((b, at, edge.fan_only));
                self.rejected[b as usize].push((a, at, edge.fan_only));
                continue;
            }
            // The lower weight collapses into the higher (§3.1.3.3); on a tie an
            // interior vertex goes into a boundary one first, else the lower id
            // into the higher (a < b) first.
            let (wa, wb) = (weights[a as usize], weights[b as usize]);
            let directions: &[(u32, u32)] = match wa.total_cmp(&wb) {
                Ordering::Less => &[(a, b)],
                Ordering::Greater => &[(b, a)],
                Ordering::Equal if self.is_boundary(a) && !self.is_boundary(b) => &[(b, a), (a, b)],
                Ordering::Equal => &[(a, b), (b, a)],
            };
            self.point_test_failed = false;
            let Some(&(u, v)) = directions.iter().find(|&&(u, v)| self.can_collapse(u, v)) else {
                // Rejected: tried again when a collapse changes either vertex's
                // neighbourhood.
                let fan_only = !self.point_test_failed;
                self.rejected[a as usize].push((b, self.clock, fan_only));
                self.rejected[b as usize].push((a, self.clock, fan_only));
                continue;
            };
            self.neighbours(v, &mut neighbours_before);
            self.collapse(u, v);
            log.push(Collapse {
                from: u,
                into: v,
                cost: edge.cost,
            });
            // Step 3: edges that are new to v (from u's side) into the heap.
            self.neighbours(v, &mut neighbours);
            for &x in &neighbours {
                if neighbours_before.binary_search(&x).is_err() {
                    push(&mut heap, v, x, NEVER_REJECTED, false);
                }
            }
            // Step 4: v and its neighbours changed neighbourhoods: the edges at them
            // that were rejected get another chance.
            revived.clear();
            for &x in neighbours.iter().chain([&v, &u]) {
                for (y, at, fan_only) in std::mem::take(&mut self.rejected[x as usize]) {
                    revived.push((x.min(y), x.max(y), at, fan_only));
                }
            }
            revived.sort_unstable();
            revived.dedup();
            for &(x, y, at, fan_only) in &revived {
                for (p, q) in [(x, y), (y, x)] {
                    self.rejected[p as usize].retain(|&(r, ..)| r != q);
                }
                if !self.removed[x as usize] && !self.removed[y as usize] {
                    push(&mut heap, x, y, at, fan_only);
                }
            }
        }
        // Step 5: surviving triangles in input order; MV masks as the AND of sets.
        let mut triangles = Vec::new();
        for (t, tri) in self.triangles.iter().enumerate() {
            if self.alive[t] {
                triangles.push(*tri);
            }
        }
        let view_masks = match self.input.view_sets {
            Some(sets) => triangles
                .iter()
                .map(|t| sets[t[0] as usize] & sets[t[1] as usize] & sets[t[2] as usize])
                .collect(),
            None => Vec::new(),
        };
        Simplified {
            triangles,
            view_masks,
            collapses: log.len() as u32,
            log,
            dropped_input_triangles: self.dropped,
        }
    }

    /// Whether no triangle around `a`, `b` or a corner opposite the edge (a, b) has
    /// changed since collapse count `at`: [`Collapser::can_collapse`] reads only
    /// those fans (their corners, the points they carry), so its answer for the
    /// edge, either way, is then the one it gave at `at`.
    fn unchanged_since(&self, a: u32, b: u32, at: u32) -> bool {
        let changed = |x: u32| self.changed_at[x as usize] > at;
        if changed(a) || changed(b) {
            return false;
        }
        self.fans[a as usize].iter().all(|&t| {
            let tri = &self.triangles[t as usize];
            !tri.contains(&b) || tri.iter().all(|&w| !changed(w))
        })
    }

    /// Whether neither `a`'s nor `b`'s fan has changed as a list of triangles since
    /// collapse count `at`: every test of [`Collapser::can_collapse`] but the
    /// deviation bound's carried points reads only those two fans (their
    /// triangles, corners and static per-vertex data), so an edge that failed such
    /// a test in every direction tried fails it again.
    fn fans_unchanged_since(&self, a: u32, b: u32, at: u32) -> bool {
        self.fan_changed_at[a as usize] <= at && self.fan_changed_at[b as usize] <= at
    }

    /// Sorted, distinct neighbours of `v` (vertices sharing an alive triangle).
    fn neighbours(&self, v: u32, out: &mut Vec<u32>) {
        out.clear();
        for &t in &self.fans[v as usize] {
            for &x in &self.triangles[t as usize] {
                if x != v {
                    out.push(x);
                }
            }
        }
        out.sort_unstable();
        out.dedup();
    }

    /// Whether the triangles around `v` form one disc (closed fan) or one half-disc
    /// (open fan), each directed edge at `v` used once.
    fn fan_is_disc(&mut self, v: u32) -> bool {
        // For each triangle (v, x, y) in ccw order: the fan steps x → y.
        let mut steps = std::mem::take(&mut self.scratch_edges);
        let mut targets = std::mem::take(&mut self.scratch_fan);
        steps.clear();
        for &t in &self.fans[v as usize] {
            steps.push(opposite_edge(&self.triangles[t as usize], v));
        }
        targets.clear();
        targets.extend(steps.iter().map(|s| s.1));
        let disc = Self::steps_form_one_fan(&mut steps, &mut targets);
        self.scratch_edges = steps;
        self.scratch_fan = targets;
        disc
    }

    fn steps_form_one_fan(steps: &mut [(u32, u32)], targets: &mut [u32]) -> bool {
        if steps.is_empty() {
            return false;
        }
        steps.sort_unstable();
        if steps.windows(2).any(|w| w[0].0 == w[1].0) {
            return false; // a directed edge v→x used twice
        }
        targets.sort_unstable();
        if targets.windows(2).any(|w| w[0] == w[1]) {
            return false; // a directed edge y→v used twice
        }
        // Start at a step whose source is no step's target (the open end), if any.
        let start = steps
            .iter()
            .find(|s| targets.binary_search(&s.0).is_err())
            .unwrap_or(&steps[0])
            .0;
        let mut at = start;
        let mut walked = 0;
        while let Ok(i) = steps.binary_search_by(|s| s.0.cmp(&at)) {
            walked += 1;
            at = steps[i].1;
            if at == start || walked > steps.len() {
                break;
            }
        }
        walked == steps.len()
    }

    /// Whether `v` lies on a boundary: some edge at `v` has a triangle on one side
    /// only. Remembered until a triangle of its fan changes.
    fn is_boundary(&mut self, v: u32) -> bool {
        let (at, memo) = self.boundary_memo[v as usize];
        if at > self.changed_at[v as usize] {
            return memo;
        }
        let boundary = self.fan_has_open_edge(v);
        self.boundary_memo[v as usize] = (self.clock + 1, boundary);
        boundary
    }

    fn fan_has_open_edge(&self, v: u32) -> bool {
        let fan = &self.fans[v as usize];
        // The fan's steps x → y looked up once (small fans: on the stack); v is on
        // a boundary when some x is no y or some y is no x.
        const SMALL: usize = 16;
        if fan.len() <= SMALL {
            let mut steps = [(0u32, 0u32); SMALL];
            for (step, &t) in steps.iter_mut().zip(fan) {
                *step = opposite_edge(&self.triangles[t as usize], v);
            }
            let steps = &steps[..fan.len()];
            return steps
                .iter()
                .any(|&(x, _)| !steps.iter().any(|&(_, y)| y == x))
                || steps
                    .iter()
                    .any(|&(_, y)| !steps.iter().any(|&(x, _)| x == y));
        }
        fan.iter().any(|&t| {
            let (x, _) = opposite_edge(&self.triangles[t as usize], v);
            // Edge v→x needs a partner x→v in another triangle of the fan.
            !fan.iter().any(|&s| {
                let (_, y) = opposite_edge(&self.triangles[s as usize], v);
                y == x
            })
        }) || fan.iter().any(|&t| {
            let (_, y) = opposite_edge(&self.triangles[t as usize], v);
            !fan.iter().any(|&s| {
                let (x, _) = opposite_edge(&self.triangles[s as usize], v);
                x == y
            })
        })
    }

    /// All the tests a half-edge collapse u → v must pass (see the module docs).
    fn can_collapse(&mut self, u: u32, v: u32) -> bool {
        let (ui, vi) = (u as usize, v as usize);
        // A locked vertex (a chunk's cut border, issue 29) is never removed.
        if self.input.locked.is_some_and(|locked| locked[ui]) {
            return false;
        }
        // MV constraint (§3.1.4): a common view, or both sets empty.
        if let Some(sets) = self.input.view_sets {
            let (su, sv) = (sets[ui], sets[vi]);
            if su & sv == 0 && (su != 0 || sv != 0) {
                return false;
            }
        }
        // Triangles on the edge, and the vertices opposite it.
        let mut opposite = [0u32; 2];
        let mut on_edge = 0;
        for &t in &self.fans[ui] {
            let tri = &self.triangles[t as usize];
            if tri.contains(&v) {
                if on_edge == 2 {
                    return false; // non-manifold edge
                }
                opposite[on_edge] = tri.iter().copied().find(|&x| x != u && x != v).unwrap_or(u);
                on_edge += 1;
            }
        }
        if on_edge == 0 {
            return false; // no longer an edge
        }
        // [14]: two boundary vertices may only merge along a boundary edge.
        if on_edge == 2 && self.is_boundary(u) && self.is_boundary(v) {
            return false;
        }
        // The collapse must not delete a whole piece (v keeps some triangle).
        if self.fans[ui].len() == on_edge && self.fans[vi].len() == on_edge {
            return false;
        }
        // The deviation bound rejects most candidates (three in four on park-2m's
        // cells): it runs before the costlier topology tests. Each test only reads
        // the mesh, so their order changes no answer.
        if !self.deviation_allows(u, v) {
            return false;
        }
        // Link condition: common neighbours == vertices opposite the edge.
        let mut nu = std::mem::take(&mut self.scratch_u);
        let mut nv = std::mem::take(&mut self.scratch_v);
        self.neighbours(u, &mut nu);
        self.neighbours(v, &mut nv);
        let mut common = 0;
        let mut link_ok = true;
        let (mut i, mut j) = (0, 0);
        while i < nu.len() && j < nv.len() {
            match nu[i].cmp(&nv[j]) {
                Ordering::Less => i += 1,
                Ordering::Greater => j += 1,
                Ordering::Equal => {
                    if !opposite[..on_edge].contains(&nu[i]) {
                        link_ok = false;
                    }
                    common += 1;
                    i += 1;
                    j += 1;
                }
            }
        }
        self.scratch_u = nu;
        self.scratch_v = nv;
        if !link_ok || common != on_edge {
            return false;
        }
        // u's neighbourhood must be one disc or half-disc (a non-manifold vertex of
        // the input, e.g. a bow-tie where the subset touches itself, stays).
        if !self.fan_is_disc(u) {
            return false;
        }
        // Geometry and local topology of the triangles that change (u → v).
        let positions = self.input.positions;
        let mut edges = std::mem::take(&mut self.scratch_edges);
        edges.clear();
        let mut ok = true;
        for &t in &self.fans[ui] {
            let tri = self.triangles[t as usize];
            if tri.contains(&v) {
                continue; // removed by the collapse
            }
            let moved = tri.map(|x| if x == u { v } else { x });
            let before = triangle_cross(positions, tri);
            let after = triangle_cross(positions, moved);
            let after_len2 = after.length_squared();
            if after_len2.partial_cmp(&0.0) != Some(Ordering::Greater) {
                ok = false; // degenerate
                break;
            }
            let before_len2 = before.length_squared();
            if before_len2 > 0.0
                && before.dot(after) <= MIN_NORMAL_TURN_COS * (before_len2 * after_len2).sqrt()
            {
                ok = false; // fold-over
                break;
            }
            // Duplicate of a triangle already around v?
            let key = sorted(moved);
            if self.fans[vi].iter().any(|&s| {
                let other = self.triangles[s as usize];
                !other.contains(&u) && sorted(other) == key
            }) {
                ok = false;
                break;
            }
            let (x, y) = opposite_edge(&moved, v);
            edges.push((v, x));
            edges.push((y, v));
        }
        if ok {
            // Every directed edge at v appears once after the collapse.
            for &t in &self.fans[vi] {
                let tri = self.triangles[t as usize];
                if tri.contains(&u) {
                    continue;
                }
                let (x, y) = opposite_edge(&tri, v);
                edges.push((v, x));
                edges.push((y, v));
            }
            edges.sort_unstable();
            ok = edges.windows(2).all(|w| w[0] != w[1]);
        }
        self.scratch_edges = edges;
        ok
    }

    /// Deviation bound: u and every point carried by u's triangles must lie within
    /// its tolerance of some triangle around v after the collapse; records the
    /// nearest such triangle of each point for [`Collapser::collapse`].
    fn deviation_allows(&mut self, u: u32, v: u32) -> bool {
        let Some(dev) = self.deviation.as_mut() else {
            return true;
        };
        let positions = self.input.positions;
        let corners = |tri: [u32; 3]| tri.map(|x| positions[x as usize]);
        // v's fan after the collapse, with corner positions looked up once.
        let mut fan = std::mem::take(&mut dev.scratch_fan);
        fan.clear();
        for &t in &self.fans[v as usize] {
            let tri = self.triangles[t as usize];
            if !tri.contains(&u) {
                fan.push((t, corners(tri)));
            }
        }
        let moved_from = fan.len();
        for &t in &self.fans[u as usize] {
            let tri = self.triangles[t as usize];
            if !tri.contains(&v) {
                fan.push((t, corners(tri.map(|x| if x == u { v } else { x }))));
            }
        }
        dev.pending.clear();
        // The carrier of point p after the collapse: the fan triangle at `moved`
        // when p is within tolerance of it (a point whose carrier only moves is
        // usually still close to it; any carrier within tolerance keeps the bound),
        // else the nearest (first on a tie); and whether p is within tolerance.
        let tolerance = &dev.tolerance;
        let carrier = |p: u32, moved: usize| -> (bool, u32) {
            let q = positions[p as usize];
            let tol = tolerance[p as usize];
            if let Some(&(t, [a, b, c])) = fan.get(moved) {
                if point_triangle_distance_squared(q, a, b, c) <= tol * tol {
                    return (true, t);
                }
            }
            let (d, t) = fan
                .iter()
                .map(|&(t, [a, b, c])| (point_triangle_distance_squared(q, a, b, c), t))
                .fold((f32::INFINITY, u32::MAX), |best, x| {
                    if x.0 < best.0 {
                        x
                    } else {
                        best
                    }
                });
            (d <= tol * tol, t)
        };
        // u first: it fails alone in most rejections (86 % on park-2m's cell 275), before
        // the points carried around it are gathered.
        let (ok, t) = carrier(u, usize::MAX);
        dev.pending.push((u, t));
        if fan.is_empty() || !ok {
            dev.scratch_fan = fan;
            return false;
        }
        // The other points, each with the index in `fan` of its carrier after the
        // collapse (usize::MAX: its carrier disappears).
        let mut points = std::mem::take(&mut dev.scratch_points);
        points.clear();
        let mut next_moved = moved_from;
        for &t in &self.fans[u as usize] {
            let tri = self.triangles[t as usize];
            let moved = if tri.contains(&v) {
                // The corner opposite the edge loses its last triangle when all of
                // its triangles are on the edge: it leaves the mesh like u and must
                // be carried like u.
                for &w in &tri {
                    if w != u
                        && w != v
                        && self.fans[w as usize].iter().all(|&s| {
                            let other = &self.triangles[s as usize];
                            other.contains(&u) && other.contains(&v)
                        })
                    {
                        points.push((w, usize::MAX));
                    }
                }
                usize::MAX
            } else {
                next_moved += 1;
                next_moved - 1
            };
            points.extend(dev.carried[t as usize].iter().map(|&p| (p, moved)));
        }
        let ok = points.iter().all(|&(p, moved)| {
            let (ok, t) = carrier(p, moved);
            dev.pending.push((p, t));
            ok
        });
        dev.scratch_fan = fan;
        dev.scratch_points = points;
        if !ok {
            self.point_test_failed = true;
        }
        ok
    }

    /// Performs the half-edge collapse u → v (checked by `can_collapse`).
    fn collapse(&mut self, u: u32, v: u32) {
        self.clock += 1;
        let clock = self.clock;
        self.changed_at[u as usize] = clock;
        self.changed_at[v as usize] = clock;
        if let Some(dev) = self.deviation.as_mut() {
            for &t in &self.fans[u as usize] {
                dev.carried[t as usize].clear();
            }
            for &(p, t) in &dev.pending {
                dev.carried[t as usize].push(p);
                for x in self.triangles[t as usize] {
                    self.changed_at[x as usize] = clock;
                }
            }
        }
        let fan_u = std::mem::take(&mut self.fans[u as usize]);
        for t in fan_u {
            let ti = t as usize;
            let tri = self.triangles[ti];
            for x in tri {
                self.changed_at[x as usize] = clock;
                self.fan_changed_at[x as usize] = clock;
            }
            if tri.contains(&v) {
                // The triangle on the edge disappears from all its vertices' fans.
                self.alive[ti] = false;
                for x in tri {
                    if x != u {
                        let fan = &mut self.fans[x as usize];
                        if let Some(k) = fan.iter().position(|&s| s == t) {
                            fan.swap_remove(k);
                        }
                    }
                }
            } else {
                self.triangles[ti] = tri.map(|x| if x == u { v } else { x });
                self.fans[v as usize].push(t);
            }
        }
        self.removed[u as usize] = true;
    }
}

/// The two other corners of `tri` after `v`, in ccw order: `tri` = (v, x, y).
fn opposite_edge(tri: &[u32; 3], v: u32) -> (u32, u32) {
    if tri[0] == v {
        (tri[1], tri[2])
    } else if tri[1] == v {
        (tri[2], tri[0])
    } else {
        (tri[0], tri[1])
    }
}

fn sorted(mut tri: [u32; 3]) -> [u32; 3] {
    tri.sort_unstable();
    tri
}

/// Squared distance from `p` to the triangle `abc` (closest point by Voronoi
/// regions, Ericson, *Real-Time Collision Detection* §5.1.5).
pub fn point_triangle_distance_squared(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> f32 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return ap.length_squared();
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return bp.length_squared();
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let t = d1 / (d1 - d3);
        return (ap - t * ab).length_squared();
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return cp.length_squared();
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let t = d2 / (d2 - d6);
        return (ap - t * ac).length_squared();
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (bp - t * (c - b)).length_squared();
    }
    let denom = va + vb + vc;
    if denom.abs() <= f32::MIN_POSITIVE {
        // Degenerate triangle: nearest of its edges.
        return [(a, b), (b, c), (c, a)]
            .iter()
            .map(|&(x, y)| {
                let e = y - x;
                let t =
                    ((p - x).dot(e) / e.length_squared().max(f32::MIN_POSITIVE)).clamp(0.0, 1.0);
                (p - x - t * e).length_squared()
            })
            .fold(f32::INFINITY, f32::min);
    }
    let (v, w) = (vb / denom, vc / denom);
    (ap - ab * v - ac * w).length_squared()
}

fn triangle_cross(positions: &[Vec3], tri: [u32; 3]) -> Vec3 {
    let [a, b, c] = tri.map(|i| positions[i as usize]);
    (b - a).cross(c - a)
}

/// Checks a simplified mesh against the model and its input triangles: indices in
/// range, only vertices the input used, no degenerate or duplicate triangles, every
/// undirected edge used at most twice and in opposite directions wherever the
/// input's edge was, a view mask per triangle or none, and a consistent log count.
pub fn validate(
    model_vertex_count: usize,
    input_triangles: &[[u32; 3]],
    out: &Simplified,
) -> Result<(), ValidationError> {
    if out.log.len() != out.collapses as usize {
        return Err(ValidationError::CollapseCount {
            log: out.log.len(),
            count: out.collapses,
        });
    }
    if !out.view_masks.is_empty() && out.view_masks.len() != out.triangles.len() {
        return Err(ValidationError::MaskCount {
            masks: out.view_masks.len(),
            triangles: out.triangles.len(),
        });
    }
    // Indices in range, used by the input, not degenerate.
    let mut used = vec![false; model_vertex_count];
    for tri in input_triangles {
        for &v in tri {
            if let Some(u) = used.get_mut(v as usize) {
                *u = true;
            }
        }
    }
    for (t, tri) in out.triangles.iter().enumerate() {
        for &vertex in tri {
            if vertex as usize >= model_vertex_count {
                return Err(ValidationError::IndexOutOfRange {
                    triangle: t,
                    vertex,
                    vertex_count: model_vertex_count,
                });
            }
            if !used[vertex as usize] {
                return Err(ValidationError::VertexNotInInput {
                    triangle: t,
                    vertex,
                });
            }
        }
        if tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2] {
            return Err(ValidationError::Degenerate {
                triangle: t,
                corners: *tri,
            });
        }
    }
    // Duplicates.
    let mut keys: Vec<([u32; 3], usize)> = out
        .triangles
        .iter()
        .enumerate()
        .map(|(t, tri)| (sorted(*tri), t))
        .collect();
    keys.sort_unstable();
    for w in keys.windows(2) {
        if w[0].0 == w[1].0 {
            return Err(ValidationError::Duplicate {
                first: w[0].1,
                second: w[1].1,
                corners: *out.triangles.get(w[1].1).unwrap_or(&w[1].0),
            });
        }
    }
    // Manifold edges wherever the input's edge was manifold (or did not exist).
    let input_edges = edge_uses(input_triangles);
    for (a, b, uses, forward) in edge_uses(&out.triangles) {
        let manifold = uses <= 2 && (uses < 2 || forward == 1);
        if manifold {
            continue;
        }
        let was_broken = input_edges
            .binary_search_by(|e| (e.0, e.1).cmp(&(a, b)))
            .ok()
            .map(|i| input_edges[i])
            .is_some_and(|(_, _, u, f)| !(u <= 2 && (u < 2 || f == 1)));
        if !was_broken {
            return Err(ValidationError::NonManifoldEdge {
                a,
                b,
                uses,
                forward,
            });
        }
    }
    Ok(())
}

/// Checks the MV view masks: one per triangle, each the AND of its vertices' sets.
pub fn validate_view_masks(view_sets: &[u8], out: &Simplified) -> Result<(), ValidationError> {
    if out.view_masks.len() != out.triangles.len() {
        return Err(ValidationError::MaskCount {
            masks: out.view_masks.len(),
            triangles: out.triangles.len(),
        });
    }
    for (t, (tri, &found)) in out.triangles.iter().zip(&out.view_masks).enumerate() {
        let set = |v: u32| view_sets.get(v as usize).copied().unwrap_or(0);
        let expected = set(tri[0]) & set(tri[1]) & set(tri[2]);
        if expected != found {
            return Err(ValidationError::WrongMask {
                triangle: t,
                expected,
                found,
            });
        }
    }
    Ok(())
}

/// Undirected edges `(a < b, uses, uses as a→b)`, sorted.
fn edge_uses(triangles: &[[u32; 3]]) -> Vec<(u32, u32, u32, u32)> {
    let mut directed: Vec<(u32, u32, bool)> = Vec::with_capacity(triangles.len() * 3);
    for tri in triangles {
        for k in 0..3 {
            let (p, q) = (tri[k], tri[(k + 1) % 3]);
            directed.push((p.min(q), p.max(q), p < q));
        }
    }
    directed.sort_unstable();
    let mut out: Vec<(u32, u32, u32, u32)> = Vec::new();
    for (a, b, forward) in directed {
        match out.last_mut() {
            Some(last) if last.0 == a && last.1 == b => {
                last.2 += 1;
                last.3 += u32::from(forward);
            }
            _ => out.push((a, b, 1, u32::from(forward))),
        }
    }
    out
}
