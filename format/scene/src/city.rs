//! The `City` scene generator: a dense town of building blocks and streets, with
//! statues and props from real meshes standing on the pavements (issue 17, item 1).
//! The parks of the paper are sparse (nothing occludes anything); a city is the
//! scene regional occlusion culling (000 §3.1.7) is for.
//!
//! Deterministic for a seed: the same manifest always gives the same meshes (bit for
//! bit) and the same instances in the same order.
//!
//! **Layout.** Square blocks of side `block_size` separated by streets of width
//! `street_width`, on a grid centred on the ground: `n = floor((W − s) / (b + s))`
//! blocks across (the same along z), a street along every ground edge. Street
//! centre lines lie at `origin + k·(b + s) + s/2`, k = 0..=n ([`CityLayout`]).
//!
//! **Buildings.** A block holds `buildings_per_block`² buildings on a square grid.
//! Every building's footprint is a square of side `f = (b / m)·(1 + OVERLAP)`
//! (m = buildings per side): the outer façades are flush with the block's edges and
//! neighbours interpenetrate by about `2·OVERLAP·b/m`, so a block's buildings form one
//! closed row of walls with no slit between them (as attached town houses do).
//! Buildings are instances of `variants` generated models ([`building_mesh`]); each
//! slot draws, from a generator seeded by `(seed, block, slot)` only, its variant,
//! a yaw of k·90° and a tint in `[tint_min, tint_max]`.
//!
//! **A building** ([`BuildingStyle`], drawn per variant from `(seed, variant)`) is a
//! closed, 2-manifold, consistently wound mesh with real geometric detail:
//! 1 to 3 tiers, each set back from the one below (a terrace between them); every
//! façade of every tier is a grid of floors × window columns, each window an opening
//! recessed [`WINDOW_RECESS`] units into the wall (four reveal quads and a pane);
//! the top tier ends in a flat roof or a hipped roof. Vertex colours: wall colour
//! on the façade plane, dark glass on the recessed panes, roof colour on the roof.
//! Height is uniform in `[min_height, max_height]`, snapped to whole floors.
//!
//! **Props** (statues) stand on the pavements: every street segment between two
//! crossings is cut into slots along both of its sides, each at least the widest
//! prop's footprint diagonal × 1.2 long, set back from the street's centre line by
//! `s/2 − diagonal/2 − 0.5`; the slot list is shuffled by [`SplitMix64`] from the seed
//! and copy k of prop model p (n prop models) takes slot `k·n + p`, as in the park
//! generator. A prop's yaw and tint come from `(seed, p, k)`. The middle half of
//! every street stays free for walking (a prop wider than `s/4` is refused).
//!
//! Instances are listed buildings first (block-major, slot order), then props
//! round-robin by copy then model.

use crate::park::SplitMix64;
pub use format::limits::{MAX_BLOCKS, MAX_WINDOWS_PER_FACADE};
use format::mesh::Mesh;
use format::scene::Ground;

/// Fraction of a building slot by which a footprint exceeds its slot.
pub const OVERLAP: f32 = 0.125;

/// Depth of a window's recess into the wall, in scene units.
pub const WINDOW_RECESS: f32 = 0.35;

/// What the generator needs (the validated manifest's `City` fields, with the props'
/// normalised footprints).
#[derive(Clone, Debug, PartialEq)]
pub struct CityParams {
    pub seed: u64,
    pub block_size: f32,
    pub street_width: f32,
    pub buildings_per_block: u32,
    pub min_height: f32,
    pub max_height: f32,
    pub floor_height: f32,
    pub variants: u32,
    pub tint_min: [f32; 3],
    pub tint_max: [f32; 3],
}

impl CityParams {
    /// A small city for tests and examples: seed 3, 40-unit blocks, 16-unit streets,
    /// two buildings a block, 10 to 50 units tall with 3.5-unit floors, 12 variants.
    pub fn example() -> CityParams {
        CityParams {
            seed: 3,
            block_size: 40.0,
            street_width: 16.0,
            buildings_per_block: 2,
            min_height: 10.0,
            max_height: 50.0,
            floor_height: 3.5,
            variants: 12,
            tint_min: [0.8; 3],
            tint_max: [1.0; 3],
        }
    }
}

/// A prop model: its count and normalised x–z footprint (width, depth).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PropEntry {
    pub count: u32,
    pub footprint: [f32; 2],
}

/// Why a city cannot be generated.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CityError {
    #[error(
        "the ground ({width} × {depth}) holds no block of side {block_size} with streets of \
         width {street_width}"
    )]
    NoBlock {
        width: f32,
        depth: f32,
        block_size: f32,
        street_width: f32,
    },
    #[error("the city would have {blocks} blocks, over the limit {MAX_BLOCKS}")]
    TooManyBlocks { blocks: u64 },
    #[error(
        "prop {prop} is {diagonal} units across its footprint, wider than a quarter of the \
         street ({street_width} / 4): it would stand in the walking lane"
    )]
    PropTooWide {
        prop: usize,
        diagonal: f32,
        street_width: f32,
    },
    #[error(
        "the props need {needed} pavement slots but the streets hold only {available}; lower \
         the counts or enlarge the ground"
    )]
    NotEnoughSlots { needed: usize, available: usize },
}

/// Where the blocks and streets are.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CityLayout {
    pub blocks_x: u32,
    pub blocks_z: u32,
    /// World (x, z) of the first street's near edge.
    pub origin: [f32; 2],
    pub block_size: f32,
    pub street_width: f32,
}

impl CityLayout {
    pub fn new(params: &CityParams, ground: &Ground) -> Result<CityLayout, CityError> {
        let [w, d] = ground.size().map(f64::from);
        let (b, s) = (f64::from(params.block_size), f64::from(params.street_width));
        let pitch = b + s;
        let nx = ((w - s) / pitch).floor().max(0.0);
        let nz = ((d - s) / pitch).floor().max(0.0);
        if !(nx >= 1.0 && nz >= 1.0) {
            return Err(CityError::NoBlock {
                width: w as f32,
                depth: d as f32,
                block_size: params.block_size,
                street_width: params.street_width,
            });
        }
        if nx * nz > MAX_BLOCKS as f64 {
            return Err(CityError::TooManyBlocks {
                blocks: (nx * nz).min(u64::MAX as f64) as u64,
            });
        }
        let origin = [
            (f64::from(ground.min[0]) + (w - (nx * pitch + s)) * 0.5) as f32,
            (f64::from(ground.min[1]) + (d - (nz * pitch + s)) * 0.5) as f32,
        ];
        Ok(CityLayout {
            blocks_x: nx as u32,
            blocks_z: nz as u32,
            origin,
            block_size: params.block_size,
            street_width: params.street_width,
        })
    }

    fn pitch(&self) -> f32 {
        self.block_size + self.street_width
    }

    /// World coordinate (x for `axis` 0, z for 1) of street `k`'s centre line.
    pub fn street_centre(&self, axis: usize, k: u32) -> f32 {
        self.origin[axis] + k as f32 * self.pitch() + 0.5 * self.street_width
    }

    /// World coordinate (x or z) of block `k`'s low edge.
    pub fn block_min(&self, axis: usize, k: u32) -> f32 {
        self.origin[axis] + self.street_width + k as f32 * self.pitch()
    }
}

/// One tier of a building: a box of façades set back `inset` from the footprint.
#[derive(Clone, Debug, PartialEq)]
pub struct Tier {
    pub inset: f32,
    pub floors: u32,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Roof {
    Flat,
    /// A hipped roof rising `0.35 ×` the tier's shorter side.
    Hipped,
}

/// The shape of one building variant.
#[derive(Clone, Debug, PartialEq)]
pub struct BuildingStyle {
    /// Footprint side (square), centred on the origin.
    pub footprint: f32,
    pub floor_height: f32,
    pub tiers: Vec<Tier>,
    pub roof: Roof,
    /// Horizontal window pitch (centre to centre).
    pub window_pitch: f32,
    pub wall: [u8; 4],
    pub glass: [u8; 4],
    pub roof_colour: [u8; 4],
}

impl BuildingStyle {
    /// Draws variant `variant`'s style (module docs).
    pub fn draw(params: &CityParams, variant: u32) -> BuildingStyle {
        let slot = params.block_size / params.buildings_per_block as f32;
        let footprint = slot * (1.0 + OVERLAP);
        let mut rng = SplitMix64::new(mix(params.seed ^ 0x0B11_D1A6, u64::from(variant)));
        let fh = params.floor_height;
        let lo = (params.min_height / fh).round().max(1.0) as u32;
        let hi = ((params.max_height / fh).round() as u32).max(lo);
        let floors = lo + rng.below(u64::from(hi - lo) + 1) as u32;
        // Taller buildings get more setbacks: 1 tier up to 6 floors, up to 3 above.
        let max_tiers = if floors <= 6 {
            1
        } else if floors <= 12 {
            2
        } else {
            3
        };
        let tier_count = 1 + rng.below(max_tiers) as u32;
        let mut tiers = Vec::new();
        let mut left = floors;
        let mut inset = 0.0f32;
        for t in 0..tier_count {
            let remaining_tiers = tier_count - t;
            let this = if remaining_tiers == 1 {
                left
            } else {
                // The lower tiers take the larger share.
                let share = (left as f64 * (0.45 + 0.25 * rng.next_f64())).round() as u32;
                share.clamp(1, left - (remaining_tiers - 1))
            };
            tiers.push(Tier {
                inset,
                floors: this,
            });
            left -= this;
            inset += footprint * (0.08 + 0.07 * rng.next_f64() as f32);
        }
        let roof = if rng.below(2) == 0 {
            Roof::Flat
        } else {
            Roof::Hipped
        };
        let window_pitch = fh * (0.8 + 0.4 * rng.next_f64() as f32);
        let palette: [[u8; 3]; 6] = [
            [196, 178, 152],
            [170, 120, 96],
            [210, 206, 196],
            [150, 150, 158],
            [188, 160, 120],
            [160, 110, 90],
        ];
        let [r, g, b] = palette[rng.below(palette.len() as u64) as usize];
        BuildingStyle {
            footprint,
            floor_height: fh,
            tiers,
            roof,
            window_pitch,
            wall: [r, g, b, 255],
            glass: [44, 58, 72, 255],
            roof_colour: [92, 84, 80, 255],
        }
    }

    /// Total wall height (without the hipped roof).
    pub fn wall_height(&self) -> f32 {
        self.tiers.iter().map(|t| t.floors).sum::<u32>() as f32 * self.floor_height
    }
}

/// A mesh under construction: vertices keyed by (position bits, colour) so shared
/// corners are one vertex, and every face oriented by the normal it must face.
#[derive(Default)]
struct Builder {
    positions: Vec<[f32; 3]>,
    albedo: Vec<[u8; 4]>,
    triangles: Vec<[u32; 3]>,
    index: std::collections::BTreeMap<([u32; 3], [u8; 4]), u32>,
}

impl Builder {
    fn vertex(&mut self, p: [f32; 3], colour: [u8; 4]) -> u32 {
        let p = p.map(|x| x + 0.0);
        let key = (p.map(f32::to_bits), colour);
        let next = self.positions.len() as u32;
        *self.index.entry(key).or_insert_with(|| {
            self.positions.push(p);
            self.albedo.push(colour);
            next
        })
    }

    /// Triangle `a, b, c` wound so that it faces `normal`.
    fn triangle(&mut self, t: [u32; 3], normal: [f32; 3]) {
        let [a, b, c] = t.map(|i| glam::Vec3::from(self.positions[i as usize]));
        let n = (b - a).cross(c - a);
        if n.dot(glam::Vec3::from(normal)) >= 0.0 {
            self.triangles.push(t);
        } else {
            self.triangles.push([t[0], t[2], t[1]]);
        }
    }

    fn quad(&mut self, q: [u32; 4], normal: [f32; 3]) {
        self.triangle([q[0], q[1], q[2]], normal);
        self.triangle([q[0], q[2], q[3]], normal);
    }

    fn finish(self) -> Mesh {
        let mut mesh = Mesh {
            positions: self.positions,
            normals: Vec::new(),
            albedo: self.albedo,
            triangles: self.triangles,
        };
        crate::cleanup::recompute_normals(&mut mesh);
        mesh
    }
}

/// Grid lines across a façade of length `length`: `[0, a0, b0, a1, b1, ..., length]`
/// where `[a_k, b_k]` is window k's opening (half the pitch wide, centred in its bay).
fn window_lines(length: f32, pitch: f32) -> Vec<f32> {
    let margin = 0.6f32.min(length * 0.1);
    let usable = length - 2.0 * margin;
    let n = ((usable / pitch).floor() as u32).min(MAX_WINDOWS_PER_FACADE as u32);
    let mut lines = vec![0.0];
    if n > 0 {
        let bay = usable / n as f32;
        for k in 0..n {
            let centre = margin + (k as f32 + 0.5) * bay;
            lines.push(centre - 0.25 * bay);
            lines.push(centre + 0.25 * bay);
        }
    }
    lines.push(length);
    lines
}

/// Height lines of a tier: `[bottom, sill0, lintel0, ..., top]`.
fn floor_lines(bottom: f32, floors: u32, floor_height: f32) -> Vec<f32> {
    let mut lines = vec![bottom];
    for f in 0..floors {
        let base = bottom + f as f32 * floor_height;
        lines.push(base + 0.3 * floor_height);
        lines.push(base + 0.8 * floor_height);
    }
    lines.push(bottom + floors as f32 * floor_height);
    lines
}

/// The four façades of a tier `[−h, h]²` between `bottom` and `bottom + floors·fh`;
/// returns the vertex ids of its bottom and top boundary loops (counter-clockwise
/// seen from above, starting at corner (−h, +h)).
fn tier_facades(
    b: &mut Builder,
    style: &BuildingStyle,
    half: f32,
    bottom: f32,
    floors: u32,
) -> (Vec<u32>, Vec<u32>) {
    let ys = floor_lines(bottom, floors, style.floor_height);
    let us = window_lines(2.0 * half, style.window_pitch);
    // Sides: start corner, direction along the side, outward normal.
    let sides: [([f32; 2], [f32; 2], [f32; 3]); 4] = [
        ([-half, half], [1.0, 0.0], [0.0, 0.0, 1.0]),
        ([half, half], [0.0, -1.0], [1.0, 0.0, 0.0]),
        ([half, -half], [-1.0, 0.0], [0.0, 0.0, -1.0]),
        ([-half, -half], [0.0, 1.0], [-1.0, 0.0, 0.0]),
    ];
    let corners = [[-half, half], [half, half], [half, -half], [-half, -half]];
    let mut bottom_loop = Vec::new();
    let mut top_loop = Vec::new();
    for (s, &(start, dir, normal)) in sides.iter().enumerate() {
        let end = corners[(s + 1) % 4];
        let at = |u: usize| -> [f32; 2] {
            if u == 0 {
                start
            } else if u == us.len() - 1 {
                end
            } else {
                [start[0] + dir[0] * us[u], start[1] + dir[1] * us[u]]
            }
        };
        let grid: Vec<Vec<u32>> = (0..us.len())
            .map(|u| {
                let xz = at(u);
                ys.iter()
                    .map(|&y| b.vertex([xz[0], y, xz[1]], style.wall))
                    .collect()
            })
            .collect();
        for u in 0..us.len() - 1 {
            for v in 0..ys.len() - 1 {
                let q = [
                    grid[u][v],
                    grid[u + 1][v],
                    grid[u + 1][v + 1],
                    grid[u][v + 1],
                ];
                let window = u % 2 == 1 && v % 2 == 1;
                if !window {
                    b.quad(q, normal);
                    continue;
                }
                // A recessed window: the pane WINDOW_RECESS behind the wall, and
                // four reveals joining the opening to it.
                let back: [u32; 4] = q.map(|i| {
                    let p = b.positions[i as usize];
                    b.vertex(
                        [
                            p[0] - normal[0] * WINDOW_RECESS,
                            p[1],
                            p[2] - normal[2] * WINDOW_RECESS,
                        ],
                        style.glass,
                    )
                });
                b.quad(back, normal);
                let along = [dir[0], 0.0, dir[1]];
                let reveals: [(usize, usize, [f32; 3]); 4] = [
                    (0, 1, [0.0, 1.0, 0.0]),             // sill faces up
                    (1, 2, [-along[0], 0.0, -along[2]]), // right reveal faces back along
                    (2, 3, [0.0, -1.0, 0.0]),            // lintel faces down
                    (3, 0, [along[0], 0.0, along[2]]),   // left reveal
                ];
                for (i, j, n) in reveals {
                    b.quad([q[i], q[j], back[j], back[i]], n);
                }
            }
        }
        // Boundary loops: this side's corner and inner columns (the next side adds
        // its own start corner, which is this side's end).
        for column in grid.iter().take(us.len() - 1) {
            bottom_loop.push(column[0]);
            top_loop.push(*column.last().unwrap());
        }
    }
    (bottom_loop, top_loop)
}

/// Joins two closed loops of `sides` sides each (`outer` above or around `inner`)
/// with a strip of triangles facing `normal`: side by side, the zipper advances
/// along whichever loop's next vertex is nearer (by its fraction of the side).
fn zip_loops(
    b: &mut Builder,
    outer: &[u32],
    outer_corners: &[usize; 5],
    inner: &[u32],
    inner_corners: &[usize; 5],
    normal: [f32; 3],
) {
    for s in 0..4 {
        let o: Vec<u32> = (outer_corners[s]..=outer_corners[s + 1])
            .map(|k| outer[k % outer.len()])
            .collect();
        let i: Vec<u32> = (inner_corners[s]..=inner_corners[s + 1])
            .map(|k| inner[k % inner.len()])
            .collect();
        // Fraction of the side at each vertex, for the zipper's order.
        let fractions = |ids: &[u32]| -> Vec<f32> {
            let p = |id: u32| glam::Vec3::from(b.positions[id as usize]);
            let total = p(ids[0]).distance(p(*ids.last().unwrap()));
            ids.iter()
                .map(|&id| p(ids[0]).distance(p(id)) / total.max(f32::MIN_POSITIVE))
                .collect()
        };
        let (fo, fi) = (fractions(&o), fractions(&i));
        let (mut a, mut c) = (0usize, 0usize);
        while a + 1 < o.len() || c + 1 < i.len() {
            let advance_outer = if a + 1 >= o.len() {
                false
            } else if c + 1 >= i.len() {
                true
            } else {
                fo[a + 1] <= fi[c + 1]
            };
            if advance_outer {
                b.triangle([o[a], o[a + 1], i[c]], normal);
                a += 1;
            } else {
                b.triangle([o[a], i[c + 1], i[c]], normal);
                c += 1;
            }
        }
    }
}

/// Indices of the four corners in a boundary loop of `tier_facades` (and the first
/// again, closing it): each side contributes `columns − 1` vertices.
fn loop_corners(loop_len: usize) -> [usize; 5] {
    let per_side = loop_len / 4;
    [0, per_side, 2 * per_side, 3 * per_side, 4 * per_side]
}

/// The closed mesh of one building (module docs): base, tiers with recessed
/// windows, terraces, roof. Centred on the origin in x–z, base on y = 0.
pub fn building_mesh(style: &BuildingStyle) -> Mesh {
    let mut b = Builder::default();
    let half0 = 0.5 * style.footprint;
    let mut bottom = 0.0f32;
    let mut previous_top: Option<Vec<u32>> = None;
    for tier in &style.tiers {
        let half = half0 - tier.inset;
        let (bottom_loop, top_loop) = tier_facades(&mut b, style, half, bottom, tier.floors);
        match previous_top.take() {
            // Base: a fan from the footprint's centre, facing down.
            None => {
                let centre = b.vertex([0.0, 0.0, 0.0], style.wall);
                for k in 0..bottom_loop.len() {
                    let next = bottom_loop[(k + 1) % bottom_loop.len()];
                    b.triangle([centre, bottom_loop[k], next], [0.0, -1.0, 0.0]);
                }
            }
            // Terrace: the lower tier's top loop to this tier's bottom loop.
            Some(lower) => {
                let oc = loop_corners(lower.len());
                let ic = loop_corners(bottom_loop.len());
                zip_loops(&mut b, &lower, &oc, &bottom_loop, &ic, [0.0, 1.0, 0.0]);
            }
        }
        bottom += tier.floors as f32 * style.floor_height;
        previous_top = Some(top_loop);
    }
    // Roof over the last tier: a fan to a centre point, flat or raised.
    let top = previous_top.expect("a building has at least one tier");
    let last_half = half0 - style.tiers.last().map_or(0.0, |t| t.inset);
    let rise = match style.roof {
        Roof::Flat => 0.0,
        Roof::Hipped => 0.35 * last_half,
    };
    // The roof's own ring (roof colour) joined to the wall's top loop by a thin
    // parapet band, so the wall vertices keep the wall colour.
    let top_positions: Vec<[f32; 3]> = top.iter().map(|&i| b.positions[i as usize]).collect();
    let ring: Vec<u32> = top_positions
        .iter()
        .map(|p| b.vertex([p[0], p[1] + 0.4, p[2]], style.roof_colour))
        .collect();
    for k in 0..top.len() {
        let n = (k + 1) % top.len();
        let p = b.positions[top[k] as usize];
        let q = b.positions[top[n] as usize];
        // Outward: from the centre axis towards the segment's midpoint.
        let mid = [(p[0] + q[0]) * 0.5, 0.0, (p[2] + q[2]) * 0.5];
        b.quad([top[k], top[n], ring[n], ring[k]], mid);
    }
    let apex_y = b.positions[ring[0] as usize][1] + rise;
    let apex = b.vertex([0.0, apex_y, 0.0], style.roof_colour);
    for k in 0..ring.len() {
        let next = ring[(k + 1) % ring.len()];
        b.triangle([apex, ring[k], next], [0.0, 1.0, 0.0]);
    }
    b.finish()
}

/// One placed instance of the city.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CityPlacement {
    /// `Building(variant)` or `Prop(index in the manifest's prop list)`.
    pub kind: PlacedKind,
    pub translation: [f32; 3],
    pub yaw_deg: f32,
    pub tint: [f32; 3],
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlacedKind {
    Building(u32),
    Prop(usize),
}

/// Places the city (module docs): buildings, then props.
pub fn place(
    params: &CityParams,
    props: &[PropEntry],
    ground: &Ground,
) -> Result<(CityLayout, Vec<CityPlacement>), CityError> {
    let layout = CityLayout::new(params, ground)?;
    let tint = |rng: &mut SplitMix64| {
        [0, 1, 2].map(|c| {
            let t = rng.next_f64() as f32;
            params.tint_min[c] + t * (params.tint_max[c] - params.tint_min[c])
        })
    };
    let mut placements = Vec::new();

    // Buildings: block-major, slots row-major inside the block.
    let m = params.buildings_per_block;
    let footprint = params.block_size / m as f32 * (1.0 + OVERLAP);
    let spacing = if m > 1 {
        (params.block_size - footprint) / (m - 1) as f32
    } else {
        0.0
    };
    for bz in 0..layout.blocks_z {
        for bx in 0..layout.blocks_x {
            let block = u64::from(bz) * u64::from(layout.blocks_x) + u64::from(bx);
            for sz in 0..m {
                for sx in 0..m {
                    let slot = u64::from(sz * m + sx);
                    let mut rng = SplitMix64::new(mix(mix(params.seed, block), slot));
                    let variant = rng.below(u64::from(params.variants)) as u32;
                    let yaw_deg = 90.0 * rng.below(4) as f32;
                    let x = if m > 1 {
                        layout.block_min(0, bx) + 0.5 * footprint + sx as f32 * spacing
                    } else {
                        layout.block_min(0, bx) + 0.5 * params.block_size
                    };
                    let z = if m > 1 {
                        layout.block_min(1, bz) + 0.5 * footprint + sz as f32 * spacing
                    } else {
                        layout.block_min(1, bz) + 0.5 * params.block_size
                    };
                    placements.push(CityPlacement {
                        kind: PlacedKind::Building(variant),
                        translation: [x, 0.0, z],
                        yaw_deg,
                        tint: tint(&mut rng),
                    });
                }
            }
        }
    }

    // Props: pavement slots along both sides of every street segment.
    let s = params.street_width;
    let mut widest = 0.0f32;
    for (p, e) in props.iter().enumerate() {
        let diagonal = (e.footprint[0].powi(2) + e.footprint[1].powi(2)).sqrt();
        if diagonal.is_nan() || diagonal > s * 0.25 {
            return Err(CityError::PropTooWide {
                prop: p,
                diagonal,
                street_width: s,
            });
        }
        widest = widest.max(diagonal);
    }
    let total: usize = props.iter().map(|e| e.count as usize).sum();
    if total == 0 {
        return Ok((layout, placements));
    }
    let slot_len = (widest * 1.2).max(1e-3);
    let per_segment = (params.block_size / slot_len).floor().max(0.0) as u32;
    let setback = 0.5 * s - 0.5 * widest - 0.5;
    // (street axis, street index, segment index, side, position along).
    let mut slots: Vec<[f32; 2]> = Vec::new();
    for axis in 0..2usize {
        let (streets, segments) = if axis == 0 {
            (layout.blocks_x + 1, layout.blocks_z)
        } else {
            (layout.blocks_z + 1, layout.blocks_x)
        };
        for k in 0..streets {
            let centre = layout.street_centre(axis, k);
            for seg in 0..segments {
                let start = layout.block_min(1 - axis, seg);
                for side in [-1.0f32, 1.0] {
                    for j in 0..per_segment {
                        let along = start + (j as f32 + 0.5) * slot_len;
                        let across = centre + side * setback;
                        slots.push(if axis == 0 {
                            [across, along]
                        } else {
                            [along, across]
                        });
                    }
                }
            }
        }
    }
    let n = props.len();
    let max_count = props.iter().map(|e| e.count).max().unwrap_or(0);
    let needed = crate::park::round_robin_slots(props.iter().map(|e| e.count));
    if needed > slots.len() {
        return Err(CityError::NotEnoughSlots {
            needed,
            available: slots.len(),
        });
    }
    let mut rng = SplitMix64::new(params.seed ^ 0x57EE_7500);
    for i in (1..slots.len()).rev() {
        let j = rng.below(i as u64 + 1) as usize;
        slots.swap(i, j);
    }
    for k in 0..max_count {
        for (p, e) in props.iter().enumerate() {
            if k >= e.count {
                continue;
            }
            let [x, z] = slots[k as usize * n + p];
            let mut rng = SplitMix64::new(mix(mix(params.seed ^ 0x9409, p as u64), u64::from(k)));
            let yaw_deg = (rng.next_f64() * 360.0) as f32;
            placements.push(CityPlacement {
                kind: PlacedKind::Prop(p),
                translation: [x, 0.0, z],
                yaw_deg,
                tint: tint(&mut rng),
            });
        }
    }
    Ok((layout, placements))
}

/// splitmix64's finaliser over `a` combined with `b`.
fn mix(a: u64, b: u64) -> u64 {
    let mut r = SplitMix64::new(a ^ b.wrapping_mul(0xD6E8_FEB8_6659_FD93));
    r.next_u64()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_building_variant_is_closed_and_valid() {
        let p = CityParams::example();
        for v in 0..p.variants {
            let style = BuildingStyle::draw(&p, v);
            let mesh = building_mesh(&style);
            mesh.validate().unwrap();
            let topo = mesh.edge_topology();
            assert!(topo.is_closed_manifold(), "variant {v}: {topo:?}");
            assert!(
                mesh.signed_volume() > 0.0,
                "variant {v} is wound inside out"
            );
            let (lo, hi) = mesh.bounds().unwrap();
            assert_eq!(lo[1], 0.0);
            assert!((hi[0] - style.footprint * 0.5).abs() < 1e-4);
            assert!(hi[1] >= style.wall_height());
            // Real detail: many recessed windows.
            assert!(mesh.triangle_count() > 500, "{}", mesh.triangle_count());
        }
    }

    /// The ground from the origin to (`x`, `z`).
    fn ground_to(x: f32, z: f32) -> Ground {
        Ground {
            min: [0.0, 0.0],
            max: [x, z],
        }
    }

    #[test]
    fn placement_is_deterministic_and_props_stay_off_the_walking_lane() {
        let p = CityParams::example();
        let ground = ground_to(300.0, 250.0);
        let props = [
            PropEntry {
                count: 6,
                footprint: [2.0, 3.0],
            },
            PropEntry {
                count: 4,
                footprint: [1.0, 1.0],
            },
        ];
        let (layout, a) = place(&p, &props, &ground).unwrap();
        let (_, b) = place(&p, &props, &ground).unwrap();
        assert_eq!(a, b);
        assert_eq!(layout.blocks_x, 5);
        assert_eq!(layout.blocks_z, 4);
        let buildings = a
            .iter()
            .filter(|c| matches!(c.kind, PlacedKind::Building(_)))
            .count();
        assert_eq!(buildings, 5 * 4 * 4);
        for c in a.iter().filter(|c| matches!(c.kind, PlacedKind::Prop(_))) {
            // On some street, within the street but off its middle half.
            let [x, _, z] = c.translation;
            let off = |axis: usize, v: f32| {
                (0..=if axis == 0 {
                    layout.blocks_x
                } else {
                    layout.blocks_z
                })
                    .map(|k| (v - layout.street_centre(axis, k)).abs())
                    .fold(f32::INFINITY, f32::min)
            };
            let d = off(0, x).min(off(1, z));
            assert!(
                d >= 0.25 * p.street_width && d <= 0.5 * p.street_width,
                "{d}"
            );
        }
    }

    #[test]
    fn too_small_a_ground_and_too_wide_a_prop_are_refused() {
        let p = CityParams::example();
        let small = ground_to(50.0, 50.0);
        assert!(matches!(
            place(&p, &[], &small),
            Err(CityError::NoBlock { .. })
        ));
        let ground = ground_to(300.0, 300.0);
        let wide = [PropEntry {
            count: 1,
            footprint: [10.0, 10.0],
        }];
        assert!(matches!(
            place(&p, &wide, &ground),
            Err(CityError::PropTooWide { .. })
        ));
    }
}
