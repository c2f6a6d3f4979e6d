//! The representations a frame draws and their debug colours (DESIGN.md
//! "Representations"; `player view`'s C key, issue 18 item 4). This is the one home
//! of the colours: the renderer's shaders get them from
//! [`Representation::linear_palette`] (`gpu`), the overlay's legend draws the same
//! sRGB8 values (`overlay`), and tests tell the representations apart by them. Plain
//! data: no GPU type, no frame model.

/// What a drawn triangle is, for the debug colouring (DESIGN.md "Representations").
/// The discriminants of the proxy kinds are `format::pack::ProxyKind`'s.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Representation {
    /// Original geometry (inside objects; everything in `full` mode; LOD level 0).
    Original = 0,
    SvMesh = 1,
    Cluster = 2,
    MvMesh = 3,
    /// Layered impostor (paper 001; written by bakes with objective selection).
    LayeredImpostor = 4,
    /// Back-facing or occluded from the whole cell: not drawn; legend only.
    Culled = 5,
    /// A simplified level (≥ 1) of the distance-LOD baseline (`lod` mode).
    LodLevel = 6,
}

impl Representation {
    pub const ALL: [Representation; 7] = [
        Representation::Original,
        Representation::SvMesh,
        Representation::Cluster,
        Representation::MvMesh,
        Representation::LayeredImpostor,
        Representation::Culled,
        Representation::LodLevel,
    ];

    /// The debug colour, sRGB8 (lit by DESIGN.md's Lambert term where drawn).
    pub fn colour(self) -> [u8; 3] {
        match self {
            Representation::Original => [225, 225, 225],
            Representation::SvMesh => [40, 110, 255],
            Representation::Cluster => [220, 40, 220],
            Representation::MvMesh => [255, 120, 0],
            Representation::LayeredImpostor => [240, 230, 40],
            Representation::Culled => [60, 60, 60],
            Representation::LodLevel => [30, 200, 60],
        }
    }

    /// The representation whose debug colour a lit pixel (sRGB8) has: the Lambert
    /// term scales linear RGB, so the pixel's linear RGB over its largest channel is
    /// compared with each colour's; `None` when no colour is within 0.08 (sky, text,
    /// edges). For tests and tools that read frames drawn with colouring on.
    pub fn of_pixel(px: &[u8]) -> Option<Representation> {
        use crate::metrics::srgb_to_linear;
        let norm = |c: [f64; 3]| {
            let m = c.iter().cloned().fold(1e-9, f64::max);
            c.map(|x| x / m)
        };
        let p = norm([0, 1, 2].map(|k| srgb_to_linear(px[k])));
        Representation::ALL
            .into_iter()
            .map(|r| {
                let c = norm(r.colour().map(srgb_to_linear));
                let d = (0..3).map(|k| (c[k] - p[k]).abs()).fold(0.0, f64::max);
                (r, d)
            })
            .filter(|&(_, d)| d < 0.08)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(r, _)| r)
    }

    /// Pixels of an RGBA8 frame per representation ([`Representation::of_pixel`]),
    /// indexed by discriminant.
    pub fn count_pixels(rgba: &[u8]) -> [usize; 7] {
        let mut n = [0; 7];
        for p in rgba.chunks_exact(4) {
            if let Some(r) = Representation::of_pixel(p) {
                n[r as usize] += 1;
            }
        }
        n
    }

    pub fn label(self) -> &'static str {
        match self {
            Representation::Original => "original",
            Representation::SvMesh => "SV mesh",
            Representation::Cluster => "cluster",
            Representation::MvMesh => "MV mesh",
            Representation::LayeredImpostor => "layered impostor",
            Representation::Culled => "culled (not drawn)",
            Representation::LodLevel => "LOD level >= 1",
        }
    }

    /// Linear RGB of every representation's colour, indexed by discriminant (the
    /// shader's palette; slot 7 unused).
    pub fn linear_palette() -> [[f32; 4]; 8] {
        let mut p = [[0.0; 4]; 8];
        for r in Representation::ALL {
            let c = r.colour();
            p[r as usize] = [
                crate::metrics::srgb_to_linear(c[0]) as f32,
                crate::metrics::srgb_to_linear(c[1]) as f32,
                crate::metrics::srgb_to_linear(c[2]) as f32,
                1.0,
            ];
        }
        p
    }
}
