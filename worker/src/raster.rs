//! Software rasterizer for captures (paper 000 §3.1.3 step (1): "capture the image
//! and depth image of O using cell's face as the window and cell's center as the
//! center of projection"; DESIGN.md "Capture resolution", "Shading").
//!
//! It writes four buffers per pixel: eye-space depth, shaded sRGB8 colour, object
//! id and triangle id. The pipeline (see [`render_with`]):
//!
//! 1. **Transform** every vertex of every item once to clip space, and where it lies
//!    inside the near plane and the guard band, to 24.8 fixed-point pixel
//!    coordinates (x right, y down, pixel centres at +0.5) with 1/w.
//! 2. **Set up and bin** triangles in parallel chunks: trivial reject by outcodes,
//!    back-face handling by the sign of the fixed-point area, near-plane (and guard
//!    band) clipping in homogeneous space for the few triangles that need it, early
//!    reject of triangles whose bounding box holds no pixel centre, and a fast path
//!    that turns a triangle covering at most one pixel centre into a single
//!    fragment. Survivors go to per-band bins (bands of [`BAND_ROWS`] rows).
//! 3. **Rasterize** bands in parallel; each band owns its rows. Coverage uses exact
//!    integer edge functions with a top-left fill rule (equivalent to nudging the
//!    sample point by (ε, ε²)), so shared edges and vertices are covered exactly
//!    once. 1/w is interpolated linearly in screen space (exact for a plane) and the
//!    depth test keeps the smallest eye depth 1/(1/w); exactly equal depth goes to
//!    the lower (item index, triangle id). That is a total order, so the result does
//!    not depend on the order fragments arrive in, hence not on the thread count.
//!    The bands write straight into the capture's depth / id buffers (the item index
//!    stands in for the object id until step 4).
//! 4. **Resolve** (deferred shading): per visible pixel, perspective-correct
//!    barycentrics of the visible triangle at the pixel centre by 2D homogeneous
//!    rasterization (Olano & Greer 1997), then [`Shading`] — DESIGN.md's Lambert
//!    formula on the interpolated albedo × tint and normal (× the model's albedo
//!    texture at the interpolated UV where it has one).
//!
//! Contract for views: the projection must be an OpenGL-style perspective matrix
//! whose clip `w` is the eye-space depth −z_eye (every builder in [`crate::view`]
//! makes one); the depth buffer holds that `w`.
//!
//! One algorithm in one file (issue 28: over 1,000 lines only where one algorithm
//! needs it): setup, edge functions, the four buffers and their tests belong
//! together; the shading convention and sRGB live in `format`.

use crate::shade::{linear_to_srgb8, shade, srgb8_to_linear, SKY};
use format::Mesh;
use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};
use rayon::prelude::*;

/// Object/triangle id of a pixel nothing covers.
pub const BACKGROUND_ID: u32 = u32::MAX;

/// Object id of the ground rectangle ([`DrawItem::ground`]); like the sky, not an
/// object to [`Capture::covered_pixels`].
pub const GROUND_ID: u32 = u32::MAX - 2;

/// A perspective view through an arbitrary (possibly off-axis) window.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    /// Eye position in world space.
    pub eye: Vec3,
    /// World → eye-space transform (right-handed, looking down −z, y up).
    pub view: Mat4,
    /// Eye → clip transform (OpenGL-style clip space, z ∈ [−w, w]; may be off-axis).
    pub proj: Mat4,
    pub near: f32,
    pub far: f32,
    pub width: u32,
    pub height: u32,
}

/// Which faces to rasterize.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CullMode {
    None,
    /// Skip triangles whose winding is clockwise on screen (back-facing to the eye).
    Back,
}

/// One object to draw: a model mesh placed by a transform, optionally only a subset
/// of its triangles (indices into `mesh.triangles`).
#[derive(Clone, Copy, Debug)]
pub struct DrawItem<'a> {
    pub mesh: &'a Mesh,
    pub transform: Mat4,
    /// Linear RGB multiplier of the albedo (the instance's tint).
    pub tint: Vec3,
    /// Written to the object-ID buffer.
    pub object_id: u32,
    /// `None` = every triangle of the mesh.
    pub triangles: Option<&'a [u32]>,
    /// The model's base-colour texture and UVs (glTF scenes, issue 18): the lit
    /// albedo is multiplied by the texture sampled at the interpolated UV
    /// (`format::albedo`: bilinear after sRGB decoding). `None`: vertex albedo only.
    pub albedo_map: Option<&'a format::albedo::AlbedoMap>,
}

impl<'a> DrawItem<'a> {
    /// The ground rectangle (`format::scene::Ground::mesh`, world space) as drawn in
    /// views of the scene — `worker render` and the player draw it, so views are not
    /// objects floating in the sky (issue 18); captures of single objects do not.
    pub fn ground(mesh: &'a Mesh) -> DrawItem<'a> {
        DrawItem::whole(mesh, GROUND_ID)
    }

    /// All of `mesh` as it stands (identity transform, no tint, vertex albedo only),
    /// written as `object_id`.
    pub fn whole(mesh: &'a Mesh, object_id: u32) -> DrawItem<'a> {
        DrawItem {
            mesh,
            transform: Mat4::IDENTITY,
            tint: Vec3::ONE,
            object_id,
            triangles: None,
            albedo_map: None,
        }
    }

    /// Instance `i` of `scene` as its model, whole, with the model's texture (object
    /// id = `i`).
    pub fn instance(scene: &'a format::Scene, i: u32) -> DrawItem<'a> {
        let inst = &scene.instances[i as usize];
        let model = &scene.models[inst.model as usize];
        DrawItem {
            mesh: &model.mesh,
            transform: inst.transform,
            tint: inst.tint,
            object_id: i,
            triangles: None,
            albedo_map: model.albedo_map.as_ref(),
        }
    }

    /// Every instance of `scene` (object id = instance index), whole, then the ground
    /// (`ground` = `scene.ground.mesh()`): a view of the scene as `worker render` and
    /// the tests draw it.
    pub fn scene_with_ground(scene: &'a format::Scene, ground: &'a Mesh) -> Vec<DrawItem<'a>> {
        let mut items: Vec<DrawItem> = (0..scene.instances.len() as u32)
            .map(|i| DrawItem::instance(scene, i))
            .collect();
        items.push(DrawItem::ground(ground));
        items
    }
}

/// The buffers of one capture, row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Capture {
    pub view: View,
    /// Eye-space depth (distance along the view axis, > 0); `f32::INFINITY` for background.
    pub depth: Vec<f32>,
    /// sRGB8 shaded colour (DESIGN.md formula); the sky colour for background.
    pub color: Vec<[u8; 4]>,
    /// `DrawItem::object_id` of the visible surface, or `BACKGROUND_ID`.
    pub object_id: Vec<u32>,
    /// Index into the mesh's `triangles` of the visible surface, or `BACKGROUND_ID`.
    pub triangle_id: Vec<u32>,
}

impl Capture {
    /// Number of pixels covered by some object (the ground, [`GROUND_ID`], is not one).
    pub fn covered_pixels(&self) -> usize {
        self.object_id
            .iter()
            .filter(|&&id| id != BACKGROUND_ID && id != GROUND_ID)
            .count()
    }

    /// Index of pixel `(x, y)` in the buffers.
    pub fn index(&self, x: u32, y: u32) -> usize {
        y as usize * self.view.width as usize + x as usize
    }
}

/// How a visible pixel is coloured; the rasterizer calls [`Shading::shade_pixel`] per
/// visible pixel and nothing else depends on the variant.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Shading<'a> {
    /// DESIGN.md "Shading": per-pixel Lambert of the interpolated vertex albedo
    /// (sRGB8 → linear) × tint and the interpolated, renormalised world normal.
    #[default]
    Lit,
    /// Proxies drawn with projective texturing from their captures (paper 000 §3.2):
    /// items whose `object_id` has a [`ProjectiveSurface`] in the table are textured
    /// from its views, every other item is [`Shading::Lit`].
    Projective(&'a ProjectiveTextures),
}

/// One capture used as a projective texture: the RGBA8 image (row 0 at the top) and
/// the world → texture matrix (`(s, t, _, q) = M · (p, 1)`, texel coordinates
/// `(s/q · width, t/q · height)`).
#[derive(Clone, Debug, PartialEq)]
pub struct ProjectedTexture {
    /// Where the capture was taken from.
    pub eye: Vec3,
    pub matrix: Mat4,
    pub width: u32,
    pub height: u32,
    /// Row-major RGBA8 sRGB, `width · height · 4` bytes. The colour is used whatever
    /// the alpha (background texels next to the object carry padded colours).
    pub rgba: Vec<u8>,
}

impl ProjectedTexture {
    /// Bilinear sRGB8 lookup of the world point `p`; `None` behind the capture's eye
    /// or with a malformed image. Coordinates outside the image clamp to its edge.
    pub fn sample(&self, p: Vec3) -> Option<Vec3> {
        let (w, h) = (self.width as usize, self.height as usize);
        if w == 0 || h == 0 || self.rgba.len() != w * h * 4 {
            return None;
        }
        let c = self.matrix * p.extend(1.0);
        if c.w <= 0.0 || !c.is_finite() {
            return None;
        }
        // Texel centres at +0.5.
        let x = (c.x / c.w * w as f32 - 0.5).clamp(0.0, (w - 1) as f32);
        let y = (c.y / c.w * h as f32 - 0.5).clamp(0.0, (h - 1) as f32);
        let (x0, y0) = (x.floor() as usize, y.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
        let (fx, fy) = (x - x0 as f32, y - y0 as f32);
        let texel = |x: usize, y: usize| {
            let o = (y * w + x) * 4;
            Vec3::new(
                self.rgba[o] as f32,
                self.rgba[o + 1] as f32,
                self.rgba[o + 2] as f32,
            )
        };
        let top = texel(x0, y0).lerp(texel(x1, y0), fx);
        let bottom = texel(x0, y1).lerp(texel(x1, y1), fx);
        Some(top.lerp(bottom, fy))
    }
}

/// The textures of one proxy item (one member mesh of an SvMesh, Cluster or MvMesh).
#[derive(Clone, Debug, PartialEq)]
pub struct ProjectiveSurface {
    pub views: Vec<ProjectedTexture>,
    /// MvMesh: per triangle of the item's mesh, bit i = view i sees it; `None` = every
    /// view may texture every triangle (SvMesh, Cluster).
    pub triangle_masks: Option<Vec<u8>>,
}

/// Projective texturing of proxies for one frame (paper 000 §3.2): SvMesh and Cluster
/// triangles take their single capture; an MvMesh triangle takes the views in its
/// mask — none: lit vertex colour (the paper's "normal map approach" stand-in), one:
/// that view, more: the two whose directions from the surface point are closest to
/// the viewer's, blended by angle (weight of a view ∝ the other's angle).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ProjectiveTextures {
    /// The eye of the frame being rendered.
    pub viewer: Vec3,
    /// Indexed by `DrawItem::object_id`; `None` or out of range = lit.
    pub by_object: Vec<Option<ProjectiveSurface>>,
}

impl ProjectiveTextures {
    /// Colour of a pixel of a proxy, sRGB8 values as f32 (`None`: shade it lit).
    fn shade(&self, s: &PixelSurface<'_>) -> Option<[u8; 4]> {
        let surface = self.by_object.get(s.item.object_id as usize)?.as_ref()?;
        let mesh = s.item.mesh;
        let t = mesh.triangles.get(s.triangle as usize)?;
        let mut local = Vec3::ZERO;
        for (k, &v) in t.iter().enumerate() {
            local += s.barycentric[k] * Vec3::from_array(*mesh.positions.get(v as usize)?);
        }
        let p = s.item.transform.transform_point3(local);
        let mask = match &surface.triangle_masks {
            Some(masks) => *masks.get(s.triangle as usize)? as u32,
            None => u32::MAX,
        };
        let usable = mask & (u32::MAX >> (32 - surface.views.len().clamp(1, 32)));
        if surface.views.is_empty() || usable == 0 {
            return None;
        }
        if usable.is_power_of_two() {
            // One usable view (every SvMesh and cluster pixel): no angles to rank.
            let i = usable.trailing_zeros() as usize;
            return Some(to_srgb8(surface.views[i].sample(p)?));
        }
        let to_viewer = (self.viewer - p).normalize_or_zero();
        // The (up to) two usable views closest in angle to the viewer's direction.
        // Ranked by the cosine, with the arccosine taken only for the two kept (per
        // view and pixel it was 4 % of park-2m's bake CPU); `angle_closer` answers
        // as comparing the angles did, ties included.
        let mut best: [Option<(f32, usize)>; 2] = [None, None];
        let mut rest = usable;
        while rest != 0 {
            let i = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            let view = &surface.views[i];
            let cos = to_viewer
                .dot((view.eye - p).normalize_or_zero())
                .clamp(-1.0, 1.0);
            let candidate = Some((cos, i));
            if best[0].is_none_or(|b| angle_closer(cos, b.0)) {
                best[1] = best[0];
                best[0] = candidate;
            } else if best[1].is_none_or(|b| angle_closer(cos, b.0)) {
                best[1] = candidate;
            }
        }
        let rgb = match best {
            [None, _] => return None,
            [Some((_, i)), None] => surface.views[i].sample(p)?,
            [Some((c0, i0)), Some((c1, i1))] => {
                let (a0, a1) = (c0.acos(), c1.acos());
                let c0 = surface.views[i0].sample(p)?;
                let Some(c1) = surface.views[i1].sample(p) else {
                    return Some(to_srgb8(c0));
                };
                let sum = a0 + a1;
                let w0 = if sum > 1e-9 { a1 / sum } else { 0.5 };
                c0 * w0 + c1 * (1.0 - w0)
            }
        };
        Some(to_srgb8(rgb))
    }
}

/// Whether the view at cosine `cos` from the viewer's direction is strictly closer
/// in angle than the one at `than`: `cos.acos() < than.acos()`, without the
/// arccosine where the cosines differ by more than `1e-5`. There the angles differ
/// by at least as much (|d acos / dc| ≥ 1), forty times the arccosine's
/// rounding (angles ≤ π, whose ulp is 2.4e-7), so the larger cosine is the
/// smaller angle; closer cosines, which may round to one angle, are compared as
/// angles, so ties go as before.
#[inline]
fn angle_closer(cos: f32, than: f32) -> bool {
    if (cos - than).abs() > 1e-5 {
        cos > than
    } else {
        cos.acos() < than.acos()
    }
}

fn to_srgb8(rgb: Vec3) -> [u8; 4] {
    let c = |v: f32| (v + 0.5).clamp(0.0, 255.0) as u8;
    [c(rgb.x), c(rgb.y), c(rgb.z), 255]
}

/// What the resolve pass knows about a visible pixel.
#[derive(Clone, Copy, Debug)]
pub struct PixelSurface<'a> {
    pub item: &'a DrawItem<'a>,
    /// Index into `item.mesh.triangles`.
    pub triangle: u32,
    /// Perspective-correct barycentrics of the pixel centre (sum 1, each ≥ 0).
    pub barycentric: Vec3,
    /// Inverse-transpose of the item transform's linear part (normals → world).
    pub normal_matrix: &'a Mat3,
}

impl Shading<'_> {
    /// sRGB8 colour of one visible pixel.
    pub fn shade_pixel(&self, s: &PixelSurface<'_>) -> [u8; 4] {
        if let Shading::Projective(textures) = self {
            if let Some(c) = textures.shade(s) {
                return c;
            }
        }
        match self {
            Shading::Lit | Shading::Projective(_) => {
                let mesh = s.item.mesh;
                let t = mesh.triangles[s.triangle as usize];
                let b = s.barycentric;
                let mut albedo = Vec3::ZERO;
                let mut normal = Vec3::ZERO;
                for k in 0..3 {
                    let v = t[k] as usize;
                    let a = mesh
                        .albedo
                        .get(v)
                        .map_or(Vec3::ONE, |&c| srgb8_to_linear(c));
                    albedo += b[k] * a;
                    if let Some(n) = mesh.normals.get(v) {
                        normal += b[k] * Vec3::from_array(*n);
                    }
                }
                let mut n = *s.normal_matrix * normal;
                let usable = n.is_finite() && n.length_squared() > 1e-20;
                if !usable {
                    // No usable vertex normals: the geometric normal.
                    let p = t.map(|v| {
                        s.item
                            .transform
                            .transform_point3(Vec3::from_array(mesh.positions[v as usize]))
                    });
                    n = (p[1] - p[0]).cross(p[2] - p[0]);
                }
                let n = n.normalize_or_zero();
                if let Some(map) = s.item.albedo_map {
                    albedo *= map.sample_triangle(t, b);
                }
                linear_to_srgb8(shade(albedo * s.item.tint, n))
            }
        }
    }
}

/// Rows per band: the unit of parallel work and of triangle binning.
pub const BAND_ROWS: u32 = 16;
/// Triangles per setup chunk.
const SETUP_CHUNK: usize = 4096;
/// Sub-pixel precision of the fixed-point screen coordinates (bits).
const SUB_BITS: i32 = 8;
const SUB: i32 = 1 << SUB_BITS;
/// Guard band beyond the image, in pixels; geometry beyond it is clipped.
const GUARD_PX: f32 = 8192.0;
/// Largest image side supported (keeps fixed-point products within i64).
pub const MAX_SIDE: u32 = 16384;

// Vertex flags.
const OUT_LEFT: u32 = 1;
const OUT_RIGHT: u32 = 2;
const OUT_BOTTOM: u32 = 4;
const OUT_TOP: u32 = 8;
const OUT_NEAR: u32 = 16;
const OUT_FAR: u32 = 32;
/// Outside the near plane or the guard band: the triangle needs clipping.
const NEEDS_CLIP: u32 = 64;

/// One transformed vertex.
#[derive(Clone, Copy, Debug, Default)]
struct ScreenVert {
    x: i32,
    y: i32,
    inv_w: f32,
    flags: u32,
}

/// A set-up triangle, oriented so that its fixed-point area is positive.
#[derive(Clone, Copy, Debug)]
struct TriSetup {
    /// Fixed-point vertices; a band computes its edge functions from them exactly.
    vx: [i32; 3],
    vy: [i32; 3],
    /// 1/w of each vertex divided by the doubled area.
    iw_over_area: [f32; 3],
    x_min: i32,
    x_max: i32,
    y_min: i32,
    y_max: i32,
    id: u64,
}

/// A triangle that covers exactly one pixel centre: already resolved to a fragment.
#[derive(Clone, Copy, Debug)]
struct Fragment {
    x: u32,
    y: u32,
    /// Eye-space depth.
    depth: f32,
    id: u64,
}

/// Output of setting up one chunk of triangles.
struct SetupChunk {
    tris: Vec<TriSetup>,
    frags: Vec<Fragment>,
    /// Per band: indices into `tris`.
    tri_bins: Vec<Vec<u32>>,
    /// Per band: indices into `frags`.
    frag_bins: Vec<Vec<u32>>,
}

/// Per-item data shared by setup and resolve.
struct ItemData {
    clip: Vec<Vec4>,
    screen: Vec<ScreenVert>,
    normal_matrix: Mat3,
}

/// Screen mapping of one view.
#[derive(Clone, Copy)]
struct Viewport {
    width: u32,
    height: u32,
    half_w: f32,
    half_h: f32,
    /// Guard band extents in NDC units.
    guard_x: f32,
    guard_y: f32,
    bands: usize,
}

impl Viewport {
    fn new(view: &View) -> Viewport {
        let w = view.width.min(MAX_SIDE);
        let h = view.height.min(MAX_SIDE);
        Viewport {
            width: w,
            height: h,
            half_w: w as f32 * 0.5,
            half_h: h as f32 * 0.5,
            guard_x: 1.0 + 2.0 * GUARD_PX / w.max(1) as f32,
            guard_y: 1.0 + 2.0 * GUARD_PX / h.max(1) as f32,
            bands: h.div_ceil(BAND_ROWS) as usize,
        }
    }

    #[inline]
    fn flags(&self, c: Vec4) -> u32 {
        let mut f = 0;
        if c.x < -c.w {
            f |= OUT_LEFT;
        }
        if c.x > c.w {
            f |= OUT_RIGHT;
        }
        if c.y < -c.w {
            f |= OUT_BOTTOM;
        }
        if c.y > c.w {
            f |= OUT_TOP;
        }
        if c.z > c.w {
            f |= OUT_FAR;
        }
        // Written so that NaN coordinates count as outside.
        let inside_near = c.z >= -c.w && c.w > 0.0;
        if !inside_near {
            f |= OUT_NEAR | NEEDS_CLIP;
        }
        let inside_guard = c.x.abs() <= self.guard_x * c.w && c.y.abs() <= self.guard_y * c.w;
        if !inside_guard {
            f |= NEEDS_CLIP;
        }
        f
    }

    /// Fixed-point screen position of a clip-space point inside the near plane and
    /// the guard band.
    #[inline]
    fn screen_vert(&self, c: Vec4) -> ScreenVert {
        let inv_w = 1.0 / c.w;
        let sx = (c.x * inv_w + 1.0) * self.half_w;
        let sy = (1.0 - c.y * inv_w) * self.half_h;
        ScreenVert {
            x: round_to_i32(sx * SUB as f32),
            y: round_to_i32(sy * SUB as f32),
            inv_w,
            flags: 0,
        }
    }
}

/// Round to nearest (ties to even) for |v| < 2^31, without a libm call: adding and
/// subtracting 1.5·2^52 in f64 leaves the nearest integer.
#[inline(always)]
fn round_to_i32(v: f32) -> i32 {
    const MAGIC: f64 = 6_755_399_441_055_744.0;
    ((v as f64 + MAGIC) - MAGIC) as i32
}

/// Renders `items` from `view` with DESIGN.md's lighting ([`Shading::Lit`]).
pub fn render(view: &View, items: &[DrawItem], cull: CullMode) -> Capture {
    render_with(view, items, cull, Shading::Lit)
}

/// Renders `items` from `view`, colouring visible pixels with `shading`.
///
/// Images larger than [`MAX_SIDE`] on a side are cropped to it. Triangles with
/// out-of-range vertex indices (and subset entries out of range) are skipped.
/// The result is bit-identical for any rayon thread count.
pub fn render_with(view: &View, items: &[DrawItem], cull: CullMode, shading: Shading) -> Capture {
    let mut capture = Capture {
        view: *view,
        depth: Vec::new(),
        color: Vec::new(),
        object_id: Vec::new(),
        triangle_id: Vec::new(),
    };
    render_into(view, items, cull, shading, &mut capture);
    capture
}

/// [`render_with`] into an existing capture, reusing its buffers' memory (for
/// callers that make many captures). Every buffer and the view are overwritten.
pub fn render_into(
    view: &View,
    items: &[DrawItem],
    cull: CullMode,
    shading: Shading,
    capture: &mut Capture,
) {
    let vp = Viewport::new(view);
    let (w, h) = (vp.width as usize, vp.height as usize);
    // Item indices stand in for object ids during rasterization; `BACKGROUND_ID`
    // marks "none", so at most `u32::MAX` items are drawn.
    let items = &items[..items.len().min(BACKGROUND_ID as usize)];

    // Step 1: transform every vertex once per item.
    let view_proj = view.proj * view.view;
    let item_data: Vec<ItemData> = items
        .iter()
        .map(|item| transform_item(&vp, view_proj, item))
        .collect();

    // Step 2: set up triangles in chunks (item order, then triangle order) and bin
    // them per band.
    let mut chunks_desc = Vec::new();
    for (i, item) in items.iter().enumerate() {
        let n = item
            .triangles
            .map_or(item.mesh.triangles.len(), |subset| subset.len());
        let mut start = 0;
        while start < n {
            let end = (start + SETUP_CHUNK).min(n);
            chunks_desc.push((i, start, end));
            start = end;
        }
    }
    let chunks: Vec<SetupChunk> = chunks_desc
        .par_iter()
        .map(|&(i, start, end)| setup_chunk(&vp, cull, items, &item_data, i, start, end))
        .collect();

    // Step 3: rasterize bands; each band owns `BAND_ROWS` full rows. The capture's
    // buffers are the targets: depth, the item index (mapped to the object id in
    // step 4) and the triangle id.
    let Capture {
        depth,
        color,
        object_id,
        triangle_id,
        ..
    } = capture;
    for (buffer, value) in [
        (&mut *object_id, BACKGROUND_ID),
        (&mut *triangle_id, BACKGROUND_ID),
    ] {
        buffer.clear();
        buffer.resize(w * h, value);
    }
    depth.clear();
    depth.resize(w * h, f32::INFINITY);
    color.clear();
    color.resize(w * h, SKY);
    let far = view.far;
    let band_len = w * BAND_ROWS as usize;
    if w > 0 && h > 0 {
        depth
            .par_chunks_mut(band_len)
            .zip(object_id.par_chunks_mut(band_len))
            .zip(triangle_id.par_chunks_mut(band_len))
            .enumerate()
            .for_each(|(band, ((depth, item), tri))| {
                let y0 = band as i32 * BAND_ROWS as i32;
                let y1 = y0 + (depth.len() / w) as i32;
                let mut target = Band {
                    depth,
                    item,
                    tri,
                    width: w,
                    y0,
                    y1,
                    far,
                };
                for chunk in &chunks {
                    for &f in &chunk.frag_bins[band] {
                        let f = &chunk.frags[f as usize];
                        let o = (f.y as usize - y0 as usize) * w + f.x as usize;
                        target.test(o, f.depth, f.id);
                    }
                    for &t in &chunk.tri_bins[band] {
                        raster_triangle(&chunk.tris[t as usize], &mut target);
                    }
                }
            });
    }

    // Step 4: resolve object ids and colour per visible pixel; rows of bands nothing
    // reached stay background.
    let touched: Vec<bool> = (0..vp.bands)
        .map(|b| {
            chunks
                .iter()
                .any(|c| !c.frag_bins[b].is_empty() || !c.tri_bins[b].is_empty())
        })
        .collect();
    if w > 0 && h > 0 {
        color
            .par_chunks_mut(w)
            .zip(object_id.par_chunks_mut(w))
            .zip(triangle_id.par_chunks(w))
            .enumerate()
            .for_each(|(y, ((color, object_id), triangle_id))| {
                if !touched[y / BAND_ROWS as usize] {
                    return;
                }
                for x in 0..w {
                    if object_id[x] == BACKGROUND_ID {
                        continue;
                    }
                    let item_index = object_id[x] as usize;
                    let tri = triangle_id[x];
                    let item = &items[item_index];
                    object_id[x] = item.object_id;
                    let data = &item_data[item_index];
                    let t = item.mesh.triangles[tri as usize];
                    let ndc = Vec2::new(
                        (x as f32 + 0.5) / vp.half_w - 1.0,
                        1.0 - (y as f32 + 0.5) / vp.half_h,
                    );
                    let barycentric = homogeneous_barycentrics(
                        [
                            data.clip[t[0] as usize],
                            data.clip[t[1] as usize],
                            data.clip[t[2] as usize],
                        ],
                        ndc,
                    );
                    color[x] = shading.shade_pixel(&PixelSurface {
                        item,
                        triangle: tri,
                        barycentric,
                        normal_matrix: &data.normal_matrix,
                    });
                }
            });
    }

    capture.view = *view;
    capture.view.width = vp.width;
    capture.view.height = vp.height;
}

fn transform_item(vp: &Viewport, view_proj: Mat4, item: &DrawItem) -> ItemData {
    let mvp = view_proj * item.transform;
    let positions = &item.mesh.positions;
    let mut clip = vec![Vec4::ZERO; positions.len()];
    let mut screen = vec![ScreenVert::default(); positions.len()];
    const CHUNK: usize = 8192;
    clip.par_chunks_mut(CHUNK)
        .zip(screen.par_chunks_mut(CHUNK))
        .zip(positions.par_chunks(CHUNK))
        .for_each(|((clip, screen), positions)| {
            for ((c, s), p) in clip.iter_mut().zip(screen.iter_mut()).zip(positions) {
                let cp = mvp * Vec4::new(p[0], p[1], p[2], 1.0);
                *c = cp;
                let flags = vp.flags(cp);
                *s = if flags & NEEDS_CLIP == 0 {
                    vp.screen_vert(cp)
                } else {
                    ScreenVert::default()
                };
                s.flags = flags;
            }
        });
    let linear = Mat3::from_mat4(item.transform);
    let normal_matrix = if linear.determinant().abs() > 1e-30 {
        linear.inverse().transpose()
    } else {
        linear
    };
    ItemData {
        clip,
        screen,
        normal_matrix,
    }
}

/// Doubled signed area / edge function: (b − a) × (p − a) in fixed point.
#[inline(always)]
fn edge(ax: i32, ay: i32, bx: i32, by: i32, px: i64, py: i64) -> i64 {
    (bx as i64 - ax as i64) * (py - ay as i64) - (by as i64 - ay as i64) * (px - ax as i64)
}

/// Top-left rule: an edge a→b of a positively oriented triangle owns the pixel
/// centres exactly on it when it points up the screen (dy < 0), or right when
/// horizontal. Returns the bias added to the edge function (0 or −1).
#[inline(always)]
fn edge_bias(ax: i32, ay: i32, bx: i32, by: i32) -> i64 {
    let dy = by - ay;
    let dx = bx - ax;
    if dy < 0 || (dy == 0 && dx > 0) {
        0
    } else {
        -1
    }
}

/// The rows `[y0, y1)` of the capture one band owns.
struct Band<'a> {
    depth: &'a mut [f32],
    /// Item index of the visible surface (`BACKGROUND_ID` for none).
    item: &'a mut [u32],
    tri: &'a mut [u32],
    width: usize,
    y0: i32,
    y1: i32,
    far: f32,
}

impl Band<'_> {
    /// Depth test of a fragment at offset `o` with eye depth `d` and id
    /// `item << 32 | triangle`: the nearer wins; on exactly equal depth the lower id.
    #[inline(always)]
    fn test(&mut self, o: usize, d: f32, id: u64) {
        let cur = self.depth[o];
        if d <= self.far && (d < cur || (d == cur && id < self.id(o))) {
            self.depth[o] = d;
            self.item[o] = (id >> 32) as u32;
            self.tri[o] = id as u32;
        }
    }

    #[inline(always)]
    fn id(&self, o: usize) -> u64 {
        ((self.item[o] as u64) << 32) | self.tri[o] as u64
    }
}

/// Sets up triangles `[start, end)` of item `i` (indices into its subset or mesh).
fn setup_chunk(
    vp: &Viewport,
    cull: CullMode,
    items: &[DrawItem],
    item_data: &[ItemData],
    i: usize,
    start: usize,
    end: usize,
) -> SetupChunk {
    let mut out = SetupChunk {
        tris: Vec::new(),
        frags: Vec::new(),
        tri_bins: vec![Vec::new(); vp.bands],
        frag_bins: vec![Vec::new(); vp.bands],
    };
    let item = &items[i];
    let data = &item_data[i];
    let tris = &item.mesh.triangles;
    let nverts = data.screen.len();
    for k in start..end {
        let tri_index = match item.triangles {
            Some(subset) => subset[k],
            None => k as u32,
        };
        let Some(t) = tris.get(tri_index as usize) else {
            continue;
        };
        if t[0] as usize >= nverts || t[1] as usize >= nverts || t[2] as usize >= nverts {
            continue;
        }
        let v = [
            data.screen[t[0] as usize],
            data.screen[t[1] as usize],
            data.screen[t[2] as usize],
        ];
        let id = ((i as u64) << 32) | tri_index as u64;
        let all = v[0].flags & v[1].flags & v[2].flags;
        if all & !NEEDS_CLIP != 0 {
            continue; // entirely outside one frustum plane
        }
        let any = v[0].flags | v[1].flags | v[2].flags;
        if any & NEEDS_CLIP == 0 {
            setup_triangle(vp, cull, v, id, &mut out);
        } else {
            let c = [
                data.clip[t[0] as usize],
                data.clip[t[1] as usize],
                data.clip[t[2] as usize],
            ];
            setup_clipped(vp, cull, c, id, &mut out);
        }
    }
    out
}

/// Sets up one triangle whose vertices are all inside the near plane and the guard
/// band: cull, early reject, single-pixel fast path, or bin.
#[inline(always)]
fn setup_triangle(
    vp: &Viewport,
    cull: CullMode,
    v: [ScreenVert; 3],
    id: u64,
    out: &mut SetupChunk,
) {
    // Pixel-centre range of the bounding box: the first centre at or right of the
    // minimum, the last at or left of the maximum.
    let x_lo = v[0].x.min(v[1].x).min(v[2].x);
    let x_hi = v[0].x.max(v[1].x).max(v[2].x);
    let y_lo = v[0].y.min(v[1].y).min(v[2].y);
    let y_hi = v[0].y.max(v[1].y).max(v[2].y);
    let x_min = ((x_lo - SUB / 2 + SUB - 1) >> SUB_BITS).max(0);
    let x_max = ((x_hi - SUB / 2) >> SUB_BITS).min(vp.width as i32 - 1);
    let y_min = ((y_lo - SUB / 2 + SUB - 1) >> SUB_BITS).max(0);
    let y_max = ((y_hi - SUB / 2) >> SUB_BITS).min(vp.height as i32 - 1);
    if x_min > x_max || y_min > y_max {
        return; // no pixel centre in the box
    }
    let area = edge(v[0].x, v[0].y, v[1].x, v[1].y, v[2].x as i64, v[2].y as i64);
    // Screen y points down, so a counter-clockwise (front) triangle has area < 0.
    if area == 0 || (cull == CullMode::Back && area > 0) {
        return;
    }
    let (v1, v2) = if area < 0 { (v[2], v[1]) } else { (v[1], v[2]) };
    let v0 = v[0];
    let area = area.unsigned_abs() as f32;
    let inv_area = 1.0 / area;
    let tri = TriSetup {
        vx: [v0.x, v1.x, v2.x],
        vy: [v0.y, v1.y, v2.y],
        iw_over_area: [
            v0.inv_w * inv_area,
            v1.inv_w * inv_area,
            v2.inv_w * inv_area,
        ],
        x_min,
        x_max,
        y_min,
        y_max,
        id,
    };
    if x_min == x_max && y_min == y_max {
        // Fast path: one candidate pixel centre.
        if let Some(k) = sample(&tri, x_min, y_min) {
            out.frag_bins[(y_min as u32 / BAND_ROWS) as usize].push(out.frags.len() as u32);
            out.frags.push(Fragment {
                x: x_min as u32,
                y: y_min as u32,
                depth: 1.0 / k,
                id,
            });
        }
        return;
    }
    let b0 = (y_min as u32 / BAND_ROWS) as usize;
    let b1 = (y_max as u32 / BAND_ROWS) as usize;
    let index = out.tris.len() as u32;
    for bin in &mut out.tri_bins[b0..=b1] {
        bin.push(index);
    }
    out.tris.push(tri);
}

/// Coverage and 1/w of one pixel centre, `None` when not covered.
#[inline(always)]
fn sample(t: &TriSetup, x: i32, y: i32) -> Option<f32> {
    let px = ((x as i64) << SUB_BITS) + (SUB / 2) as i64;
    let py = ((y as i64) << SUB_BITS) + (SUB / 2) as i64;
    let [x0, x1, x2] = t.vx;
    let [y0, y1, y2] = t.vy;
    let e0 = edge(x1, y1, x2, y2, px, py) + edge_bias(x1, y1, x2, y2);
    let e1 = edge(x2, y2, x0, y0, px, py) + edge_bias(x2, y2, x0, y0);
    let e2 = edge(x0, y0, x1, y1, px, py) + edge_bias(x0, y0, x1, y1);
    if (e0 | e1 | e2) < 0 {
        return None;
    }
    Some(
        e0 as f32 * t.iw_over_area[0]
            + e1 as f32 * t.iw_over_area[1]
            + e2 as f32 * t.iw_over_area[2],
    )
}

/// Rasterizes a set-up triangle into the rows `[y0, y1)` a band owns.
#[inline]
fn raster_triangle(t: &TriSetup, band: &mut Band) {
    let (w, y0) = (band.width, band.y0);
    let ys = t.y_min.max(y0);
    let ye = t.y_max.min(band.y1 - 1);
    if ys > ye {
        return;
    }
    let [x0, x1, x2] = t.vx;
    let [vy0, vy1, vy2] = t.vy;
    // Edge functions at the centre of pixel (x_min, ys), exactly, then stepped in
    // exact integers: the values do not depend on where a band starts.
    let px = ((t.x_min as i64) << SUB_BITS) + (SUB / 2) as i64;
    let py = ((ys as i64) << SUB_BITS) + (SUB / 2) as i64;
    let mut r0 = edge(x1, vy1, x2, vy2, px, py) + edge_bias(x1, vy1, x2, vy2);
    let mut r1 = edge(x2, vy2, x0, vy0, px, py) + edge_bias(x2, vy2, x0, vy0);
    let mut r2 = edge(x0, vy0, x1, vy1, px, py) + edge_bias(x0, vy0, x1, vy1);
    // d/dx of edge a→b is −(b.y − a.y)·SUB, d/dy is (b.x − a.x)·SUB.
    let sx0 = -((vy2 - vy1) as i64) << SUB_BITS;
    let sx1 = -((vy0 - vy2) as i64) << SUB_BITS;
    let sx2 = -((vy1 - vy0) as i64) << SUB_BITS;
    let sy0 = ((x2 - x1) as i64) << SUB_BITS;
    let sy1 = ((x0 - x2) as i64) << SUB_BITS;
    let sy2 = ((x1 - x0) as i64) << SUB_BITS;
    let [a0, a1, a2] = t.iw_over_area;
    for y in ys..=ye {
        let row = (y - y0) as usize * w;
        let (mut e0, mut e1, mut e2) = (r0, r1, r2);
        let mut inside_seen = false;
        for x in t.x_min..=t.x_max {
            if (e0 | e1 | e2) >= 0 {
                inside_seen = true;
                let k = e0 as f32 * a0 + e1 as f32 * a1 + e2 as f32 * a2;
                band.test(row + x as usize, 1.0 / k, t.id);
            } else if inside_seen {
                break; // a triangle's span on a row is contiguous
            }
            e0 += sx0;
            e1 += sx1;
            e2 += sx2;
        }
        r0 += sy0;
        r1 += sy1;
        r2 += sy2;
    }
}

/// Clips a triangle in homogeneous space against the near plane (z ≥ −w) and the
/// guard band, then sets up the resulting fan.
fn setup_clipped(vp: &Viewport, cull: CullMode, c: [Vec4; 3], id: u64, out: &mut SetupChunk) {
    let planes = [
        Vec4::new(0.0, 0.0, 1.0, 1.0),
        Vec4::new(1.0, 0.0, 0.0, vp.guard_x),
        Vec4::new(-1.0, 0.0, 0.0, vp.guard_x),
        Vec4::new(0.0, 1.0, 0.0, vp.guard_y),
        Vec4::new(0.0, -1.0, 0.0, vp.guard_y),
    ];
    let mut poly = [Vec4::ZERO; 9];
    let mut n = 3;
    poly[..3].copy_from_slice(&c);
    let mut next = [Vec4::ZERO; 9];
    for plane in planes {
        let mut m = 0;
        for i in 0..n {
            let a = poly[i];
            let b = poly[(i + 1) % n];
            let da = plane.dot(a);
            let db = plane.dot(b);
            if da >= 0.0 {
                next[m] = a;
                m += 1;
            }
            if (da >= 0.0) != (db >= 0.0) {
                next[m] = intersect(a, da, b, db);
                m += 1;
            }
        }
        n = m;
        poly[..n].copy_from_slice(&next[..n]);
        if n < 3 {
            return;
        }
    }
    if poly[..n].iter().any(|p| !(p.w > 0.0 && p.is_finite())) {
        return;
    }
    let s: [ScreenVert; 9] = std::array::from_fn(|i| {
        if i < n {
            vp.screen_vert(poly[i])
        } else {
            ScreenVert::default()
        }
    });
    for i in 1..n - 1 {
        setup_triangle(vp, cull, [s[0], s[i], s[i + 1]], id, out);
    }
}

/// Intersection of segment a–b with a plane, computed from a canonical end so that
/// an edge shared by two triangles is cut at the same point whichever way it runs.
#[inline]
fn intersect(a: Vec4, da: f32, b: Vec4, db: f32) -> Vec4 {
    let a_first = (a.x, a.y, a.z, a.w)
        .partial_cmp(&(b.x, b.y, b.z, b.w))
        .is_none_or(|o| o.is_le());
    let (p, dp, q, dq) = if a_first {
        (a, da, b, db)
    } else {
        (b, db, a, da)
    };
    let t = dp / (dp - dq);
    p + (q - p) * t
}

/// Perspective-correct barycentrics of the NDC point `ndc` in a triangle given by
/// clip-space vertices (2D homogeneous rasterization: λ ∝ M⁻¹·(u, v, 1) with M's
/// columns the vertices' (x, y, w)); valid for any sign of w. Clamped to ≥ 0 and
/// normalised to sum 1.
pub fn homogeneous_barycentrics(c: [Vec4; 3], ndc: Vec2) -> Vec3 {
    let col = c.map(|v| Vec3::new(v.x, v.y, v.w));
    let q = Vec3::new(ndc.x, ndc.y, 1.0);
    let l = Vec3::new(
        col[1].cross(col[2]).dot(q),
        col[2].cross(col[0]).dot(q),
        col[0].cross(col[1]).dot(q),
    );
    let sum = l.x + l.y + l.z;
    let usable = sum.is_finite() && sum.abs() > 0.0;
    if !usable {
        return Vec3::splat(1.0 / 3.0);
    }
    let l = (l / sum).max(Vec3::ZERO);
    let s = l.x + l.y + l.z;
    if s > 0.0 {
        l / s
    } else {
        Vec3::splat(1.0 / 3.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn solid(colour: u8) -> ProjectedTexture {
        ProjectedTexture {
            eye: Vec3::new(0.0, 0.0, 10.0 + colour as f32),
            matrix: Mat4::IDENTITY,
            width: 1,
            height: 1,
            rgba: vec![colour, colour, colour, 255],
        }
    }

    /// A pixel whose triangle one view alone may texture takes that view's colour;
    /// none: lit (`None`); two: a blend of the two.
    #[test]
    fn a_pixel_with_one_usable_view_takes_it() {
        let mesh = Mesh {
            positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            triangles: vec![[0, 1, 2]],
            ..Mesh::default()
        };
        let item = DrawItem::whole(&mesh, 0);
        let normal_matrix = Mat3::IDENTITY;
        let pixel = PixelSurface {
            item: &item,
            triangle: 0,
            barycentric: Vec3::splat(1.0 / 3.0),
            normal_matrix: &normal_matrix,
        };
        let shade = |views: Vec<ProjectedTexture>, mask: Option<u8>| {
            ProjectiveTextures {
                viewer: Vec3::new(0.0, 0.0, 5.0),
                by_object: vec![Some(ProjectiveSurface {
                    views,
                    triangle_masks: mask.map(|m| vec![m]),
                })],
            }
            .shade(&pixel)
        };
        let three = || vec![solid(10), solid(100), solid(200)];
        assert_eq!(shade(vec![solid(77)], None), Some([77, 77, 77, 255]));
        assert_eq!(shade(three(), Some(0b100)), Some([200, 200, 200, 255]));
        assert_eq!(shade(three(), Some(0b010)), Some([100, 100, 100, 255]));
        assert_eq!(shade(three(), Some(0)), None);
        assert_eq!(shade(Vec::new(), None), None);
        let blend = shade(three(), Some(0b011)).unwrap();
        assert!(blend[0] > 10 && blend[0] < 100, "{blend:?}");
    }

    proptest! {
        /// Ranking views by cosine picks what ranking them by angle picked, for
        /// cosines far apart and for ones a few ulps apart (which may share an angle).
        #[test]
        fn ranking_by_cosine_is_ranking_by_angle(
            a in -1.0f32..=1.0,
            b in -1.0f32..=1.0,
            ulps in -64i32..=64,
        ) {
            let near = f32::from_bits((b.to_bits() as i32 + ulps) as u32).clamp(-1.0, 1.0);
            for (x, y) in [(a, b), (b, a), (near, b), (b, near)] {
                prop_assert_eq!(angle_closer(x, y), x.acos() < y.acos(), "{} vs {}", x, y);
            }
        }
    }
}
