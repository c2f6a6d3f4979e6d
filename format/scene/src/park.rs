//! The `Park` scene generator: a statuary park like the paper's test scenes (000 §4,
//! Table 2), deterministic for a seed and *nested*: with the same ground, model list
//! and seed, every instance of a park with smaller counts has the exact same
//! transform and tint in a park with larger counts (2M ⊂ 4M ⊂ 8M).
//!
//! How (the placement never depends on the counts, and instances never overlap):
//! 1. **Slots.** The ground is divided into square slots of side
//!    `1.1 × max over models of the model's x–z footprint diagonal` (the grid centred
//!    on the ground); any yaw of any model fits inside one slot.
//! 2. **Shuffle.** The slot list (row-major) is shuffled by Fisher–Yates driven by
//!    [`SplitMix64`] seeded from `seed` only.
//! 3. **Assignment.** Copy `k` of model `m` (`m` = position in the manifest's model
//!    list, `n` = number of models) takes slot `shuffled[k·n + m]`.
//! 4. **Inside the slot**, from a generator seeded by `hash(seed, m, k)` only, drawn in
//!    this order: yaw uniform in [0°, 360°), then the x and z offsets from the slot
//!    centre, uniform within the room the yawed footprint rectangle leaves, then the
//!    tint per channel uniform in [tint_min, tint_max].
//!
//! Instances are listed round-robin by copy then model: (k = 0, m = 0..n),
//! (k = 1, m = 0..n), ..., skipping models whose count is reached.

pub use format::rng::{splitmix64, SplitMix64};
use format::scene::Ground;

/// The slots a round-robin placement of these per-model counts needs: copy `k` of
/// model `m` of `n` takes slot `k · n + m`, so the furthest last copy decides.
pub(crate) fn round_robin_slots(counts: impl ExactSizeIterator<Item = u32>) -> usize {
    let n = counts.len();
    counts
        .enumerate()
        .filter(|&(_, count)| count > 0)
        .map(|(m, count)| (count as usize - 1) * n + m + 1)
        .max()
        .unwrap_or(0)
}

/// What the generator needs of one park model: its count and its normalised x–z
/// footprint (width along x, depth along z, centred on the origin).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParkEntry {
    pub count: u32,
    pub footprint: [f32; 2],
}

/// One placed instance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// Position of the model in the manifest's model list.
    pub model_entry: usize,
    /// Which copy of that model (0-based).
    pub copy: u32,
    /// Slot index (row-major over the slot grid).
    pub slot: usize,
    /// World position of the model's base centre (y = 0).
    pub translation: [f32; 3],
    /// Rotation about +y, degrees in [0, 360).
    pub yaw_deg: f32,
    pub tint: [f32; 3],
}

/// The slot grid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlotGrid {
    pub slot_size: f32,
    pub columns: usize,
    pub rows: usize,
    /// World (x, z) of the grid's min corner.
    pub origin: [f32; 2],
}

/// Most slots a park may have (the shuffled slot list is materialised).
pub const MAX_SLOTS: usize = 1 << 24;

#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ParkError {
    #[error(
        "the park needs {needed} slots of side {slot_size} but the ground holds only \
         {available} ({columns} × {rows}); enlarge the ground, lower counts or model sizes"
    )]
    NotEnoughSlots {
        needed: usize,
        available: usize,
        slot_size: f32,
        columns: usize,
        rows: usize,
    },
    #[error(
        "the park's slots ({slot_size} wide) would number {slots}, over the limit {MAX_SLOTS}"
    )]
    TooManySlots { slots: u128, slot_size: f32 },
    #[error("model {model_entry} has a degenerate footprint {footprint:?}")]
    BadFootprint {
        model_entry: usize,
        footprint: [f32; 2],
    },
}

impl SlotGrid {
    /// The slot grid for these models on `ground`.
    pub fn new(entries: &[ParkEntry], ground: &Ground) -> Result<SlotGrid, ParkError> {
        let mut diagonal = 0.0f64;
        for (model_entry, e) in entries.iter().enumerate() {
            let [w, d] = e.footprint.map(f64::from);
            if !(w.is_finite() && d.is_finite() && w >= 0.0 && d >= 0.0 && w + d > 0.0) {
                return Err(ParkError::BadFootprint {
                    model_entry,
                    footprint: e.footprint,
                });
            }
            diagonal = diagonal.max((w * w + d * d).sqrt());
        }
        let slot_size = (diagonal * 1.1) as f32;
        let [width, depth] = ground.size().map(f64::from);
        let s = f64::from(slot_size);
        let columns = (width / s).floor().max(0.0);
        let rows = (depth / s).floor().max(0.0);
        let slots = columns * rows;
        if !slots.is_finite() || slots > MAX_SLOTS as f64 {
            return Err(ParkError::TooManySlots {
                slots: if slots.is_finite() {
                    slots as u128
                } else {
                    u128::MAX
                },
                slot_size,
            });
        }
        let (columns, rows) = (columns as usize, rows as usize);
        let origin = [
            (f64::from(ground.min[0]) + (width - columns as f64 * s) * 0.5) as f32,
            (f64::from(ground.min[1]) + (depth - rows as f64 * s) * 0.5) as f32,
        ];
        Ok(SlotGrid {
            slot_size,
            columns,
            rows,
            origin,
        })
    }

    pub fn slot_count(&self) -> usize {
        self.columns * self.rows
    }

    /// World (x, z) of slot `slot`'s centre.
    pub fn centre(&self, slot: usize) -> [f64; 2] {
        let (col, row) = (slot % self.columns.max(1), slot / self.columns.max(1));
        let s = f64::from(self.slot_size);
        [
            f64::from(self.origin[0]) + (col as f64 + 0.5) * s,
            f64::from(self.origin[1]) + (row as f64 + 0.5) * s,
        ]
    }
}

/// Places the park (steps in the module docs).
pub fn place(
    seed: u64,
    entries: &[ParkEntry],
    tint_min: [f32; 3],
    tint_max: [f32; 3],
    ground: &Ground,
) -> Result<(SlotGrid, Vec<Placement>), ParkError> {
    // Step 1: slots.
    let grid = SlotGrid::new(entries, ground)?;
    let n = entries.len();
    let needed = round_robin_slots(entries.iter().map(|e| e.count));
    if needed > grid.slot_count() {
        return Err(ParkError::NotEnoughSlots {
            needed,
            available: grid.slot_count(),
            slot_size: grid.slot_size,
            columns: grid.columns,
            rows: grid.rows,
        });
    }

    // Step 2: shuffle the slots (depends on the seed and the grid only).
    let mut shuffled: Vec<usize> = (0..grid.slot_count()).collect();
    let mut rng = SplitMix64::new(seed ^ 0x005E_ED0F_5107_u64);
    for i in (1..shuffled.len()).rev() {
        let j = rng.below(i as u64 + 1) as usize;
        shuffled.swap(i, j);
    }

    // Steps 3–4: round-robin by copy, then model.
    let max_count = entries.iter().map(|e| e.count).max().unwrap_or(0);
    let mut placements = Vec::new();
    let half_slot = f64::from(grid.slot_size) * 0.5;
    for k in 0..max_count {
        for (m, e) in entries.iter().enumerate() {
            if k >= e.count {
                continue;
            }
            let slot = shuffled[k as usize * n + m];
            let mut rng = SplitMix64::new(instance_seed(seed, m as u64, u64::from(k)));
            let yaw_deg = rng.next_f64() * 360.0;
            let (sin, cos) = yaw_deg.to_radians().sin_cos();
            let [w, d] = e.footprint.map(|x| f64::from(x) * 0.5);
            let half_x = cos.abs() * w + sin.abs() * d;
            let half_z = sin.abs() * w + cos.abs() * d;
            let room_x = (half_slot - half_x).max(0.0);
            let room_z = (half_slot - half_z).max(0.0);
            let centre = grid.centre(slot);
            let x = centre[0] + (rng.next_f64() * 2.0 - 1.0) * room_x;
            let z = centre[1] + (rng.next_f64() * 2.0 - 1.0) * room_z;
            let tint = [0, 1, 2].map(|c| {
                let t = rng.next_f64();
                (f64::from(tint_min[c]) + t * f64::from(tint_max[c] - tint_min[c])) as f32
            });
            placements.push(Placement {
                model_entry: m,
                copy: k,
                slot,
                translation: [x as f32, 0.0, z as f32],
                yaw_deg: yaw_deg as f32,
                tint,
            });
        }
    }
    Ok((grid, placements))
}

/// The per-instance seed `hash(seed, m, k)`.
fn instance_seed(seed: u64, model_entry: u64, copy: u64) -> u64 {
    let mut rng = SplitMix64::new(seed);
    let a = rng.next_u64() ^ model_entry.wrapping_mul(0xD6E8_FEB8_6659_FD93);
    let mut rng = SplitMix64::new(a);
    let b = rng.next_u64() ^ copy.wrapping_mul(0xA076_1D64_78BD_642F);
    SplitMix64::new(b).next_u64()
}
