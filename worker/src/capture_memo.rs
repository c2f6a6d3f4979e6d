//! Captures computed once per run (issue 27 item 3, "captures stored once", on the
//! computing side; paper 000 §3.1.3 step (1) and §3.1.4).
//!
//! An MVMesh captures its object from the cell centre and from the centres of the
//! neighbouring cells (§3.1.4); an SVMesh captures it from the cell centre (§3.1.3).
//! A capture renders the object **alone** ([`crate::capture`]), so what it yields
//! does not depend on the cell asking: cell A's SVMesh of object O and the MVMeshes
//! of O in A's six neighbours all capture O from A's centre. A job bakes neighbouring
//! cells one after another, so before this memo the same capture was rendered,
//! classified (§3.1.3.1) and weighted (§3.1.3.2) up to seven times per job.
//!
//! The memo keeps, per single-object capture, what a derivation reads from it: the
//! state every model vertex would have if it were front-facing
//! ([`crate::weights::vertex_states_if_front`]; the start mesh's own front-facing
//! test, which depends on which level of the model's LOD chain a cell starts from,
//! is applied per use by [`crate::weights::with_front_facing`], so one capture
//! serves every level) and the unfitted projective texture with its covered pixel
//! count. It does not keep the capture's buffers (16 bytes per pixel at `image_res`
//! 1024 would not fit the bake's memory budget). The key is everything that result
//! depends on: the model's content hash, the instance's transform and tint, the eye,
//! and the settings that enter the capture, the classes and the states
//! (`image_res`, T_c0, T_c1, the window depth's cell size and the depth
//! tolerance). So a hit returns exactly the value a fresh computation would, and
//! packs stay byte-identical whatever the memo holds, for any thread count and job
//! order (DESIGN.md "Determinism"). Clusters (several objects in one capture) are not
//! memoised.
//!
//! It also keeps the pack encoding (BC1 with coverage) of the capture textures the
//! cells and groups write ([`CaptureMemo::encoded`]), keyed by the BLAKE3 hash of the
//! image: a texture is shared by up to seven cells, and before this each encoded it
//! again (park-2m: 78,381 encodings of 22,408 distinct images).
//!
//! Memory is bounded: at most [`MEMO_BYTES`] of states and textures and
//! [`ENCODED_BYTES`] of encoded textures; past it the oldest entries go first. Two threads missing on the same key both compute it (the
//! same value); the memo never blocks on a computation.

use crate::capture::CaptureError;
use crate::raster::{DrawItem, ProjectedTexture};
use crate::weights::VertexState;
use glam::Vec3;
use std::collections::{HashMap, VecDeque};
use std::sync::{Arc, Mutex};

/// Bytes of states and textures the memo holds at most (per run): a few jobs' worth
/// (park-2m's cell-275 sample kept 6 MiB per 4-cell job), so that two jobs baking side
/// by side find their neighbours' captures.
pub const MEMO_BYTES: usize = 32 << 20;

/// Bytes of encoded pack textures the memo holds at most (per run): BC1 takes an
/// eighth of a capture's RGBA8, so this keeps as many textures as [`MEMO_BYTES`]
/// keeps captures, with room to spare.
pub const ENCODED_BYTES: usize = 8 << 20;

/// What a derivation reads from a single-object capture.
#[derive(Debug)]
pub struct Captured {
    /// The state of every vertex of the model were it front-facing.
    pub if_front: Vec<VertexState>,
    /// The capture's texture, before any fitting to the region.
    pub texture: ProjectedTexture,
    pub covered_pixels: usize,
}

impl Captured {
    fn bytes(&self) -> usize {
        self.if_front.len() * std::mem::size_of::<VertexState>() + self.texture.rgba.len() + 128
    }
}

/// The key of one capture (module docs): every input its result depends on.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct CaptureKey {
    model_hash: [u8; 32],
    /// Transform (16), tint (3), eye (3), then the settings (module docs), as bits.
    bits: [u32; 28],
}

/// The settings that enter a capture's result.
#[derive(Clone, Copy, Debug)]
pub struct CaptureSettings {
    pub image_res: u32,
    pub t_c0: f32,
    pub t_c1: f32,
    pub cell_size: f32,
    pub footprint_px: f32,
    pub neighbourhood_px: u32,
}

impl CaptureKey {
    pub fn new(
        model_hash: [u8; 32],
        item: &DrawItem,
        eye: Vec3,
        s: &CaptureSettings,
    ) -> Option<CaptureKey> {
        // A subset of the mesh's triangles is not what the model hash names.
        if item.triangles.is_some() {
            return None;
        }
        let mut bits = [0u32; 28];
        let floats = item
            .transform
            .to_cols_array()
            .into_iter()
            .chain(item.tint.to_array())
            .chain(eye.to_array())
            .chain([s.t_c0, s.t_c1, s.cell_size, s.footprint_px]);
        for (b, f) in bits.iter_mut().zip(floats) {
            *b = f.to_bits();
        }
        bits[26] = s.image_res;
        bits[27] = s.neighbourhood_px;
        Some(CaptureKey { model_hash, bits })
    }
}

/// A map with a byte budget: past it the oldest entries go first.
struct Fifo<K, V> {
    map: HashMap<K, V>,
    order: VecDeque<(K, usize)>,
    bytes: usize,
    budget: usize,
    hits: u64,
    misses: u64,
}

impl<K: Clone + Eq + std::hash::Hash, V: Clone> Fifo<K, V> {
    fn new(budget: usize) -> Fifo<K, V> {
        Fifo {
            map: HashMap::new(),
            order: VecDeque::new(),
            bytes: 0,
            budget,
            hits: 0,
            misses: 0,
        }
    }

    /// The value kept for `key`, counting the lookup.
    fn get(&mut self, key: &K) -> Option<V> {
        let hit = self.map.get(key).cloned();
        match hit {
            Some(_) => self.hits += 1,
            None => self.misses += 1,
        }
        hit
    }

    /// Keeps `value` (`bytes` of it) unless the key is there already or the value
    /// is over a quarter of the budget.
    fn insert(&mut self, key: K, value: V, bytes: usize) {
        if bytes > self.budget / 4 || self.map.contains_key(&key) {
            return;
        }
        while self.bytes + bytes > self.budget {
            let Some((old, b)) = self.order.pop_front() else {
                break;
            };
            self.map.remove(&old);
            self.bytes -= b;
        }
        self.map.insert(key.clone(), value);
        self.order.push_back((key, bytes));
        self.bytes += bytes;
    }
}

/// The memo of a run (module docs); shared by every cell and group baked with the
/// same [`crate::lod_chain::LodChains`].
pub struct CaptureMemo {
    captures: Mutex<Fifo<CaptureKey, Arc<Captured>>>,
    /// Encoded pack textures by the content hash of their RGBA8 image
    /// ([`CaptureMemo::encoded`]).
    encoded: Mutex<Fifo<[u8; 32], Arc<format::pack::Texture>>>,
}

impl Default for CaptureMemo {
    fn default() -> CaptureMemo {
        CaptureMemo {
            captures: Mutex::new(Fifo::new(MEMO_BYTES)),
            encoded: Mutex::new(Fifo::new(ENCODED_BYTES)),
        }
    }
}

impl std::fmt::Debug for CaptureMemo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (hits, misses) = self.counts();
        f.debug_struct("CaptureMemo")
            .field("hits", &hits)
            .field("misses", &misses)
            .finish()
    }
}

impl CaptureMemo {
    /// The memoised result for `key`, or `compute`'s (kept when it succeeds).
    pub fn get_or_compute(
        &self,
        key: CaptureKey,
        compute: impl FnOnce() -> Result<Captured, CaptureError>,
    ) -> Result<Arc<Captured>, CaptureError> {
        if let Some(hit) = lock(&self.captures).get(&key) {
            return Ok(hit);
        }
        let value = Arc::new(compute()?);
        let bytes = value.bytes();
        lock(&self.captures).insert(key, value.clone(), bytes);
        Ok(value)
    }

    /// The pack texture `encode` makes of the `width` × `height` RGBA8 image
    /// `rgba`, or the one it made of the same image before. A capture's texture is
    /// encoded once per run instead of once per cell or group using it (park-2m:
    /// 22,408 distinct textures for 78,381 uses). The key is the BLAKE3 hash of the
    /// size and every byte, so a hit is the encoding of the same image, and the
    /// encoding depends on nothing else ([`crate::capture::pack_texture`]).
    pub fn encoded(
        &self,
        width: u32,
        height: u32,
        rgba: &[u8],
        encode: impl FnOnce() -> Result<format::pack::Texture, String>,
    ) -> Result<Arc<format::pack::Texture>, String> {
        let mut h = blake3::Hasher::new();
        h.update(&width.to_le_bytes());
        h.update(&height.to_le_bytes());
        h.update(rgba);
        let key = *h.finalize().as_bytes();
        if let Some(hit) = lock(&self.encoded).get(&key) {
            return Ok(hit);
        }
        let value = Arc::new(encode()?);
        let bytes = value.data.len() + 64;
        lock(&self.encoded).insert(key, value.clone(), bytes);
        Ok(value)
    }

    /// Capture lookups answered from the memo and lookups computed, so far.
    pub fn counts(&self) -> (u64, u64) {
        let e = lock(&self.captures);
        (e.hits, e.misses)
    }

    /// Texture encodings answered from the memo and encodings made, so far.
    pub fn encoded_counts(&self) -> (u64, u64) {
        let e = lock(&self.encoded);
        (e.hits, e.misses)
    }
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    // A panic while holding the lock leaves consistent entries (every update is
    // completed before the guard drops), so a poisoned lock is usable.
    m.lock().unwrap_or_else(|p| p.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Mat4;

    fn texture(n: usize) -> ProjectedTexture {
        ProjectedTexture {
            eye: Vec3::ZERO,
            matrix: Mat4::IDENTITY,
            width: 1,
            height: 1,
            rgba: vec![0; n],
        }
    }

    const SETTINGS: CaptureSettings = CaptureSettings {
        image_res: 64,
        t_c0: 1.0,
        t_c1: 0.5,
        cell_size: 10.0,
        footprint_px: 1.0,
        neighbourhood_px: 1,
    };

    fn key(i: u32) -> CaptureKey {
        let mesh = format::Mesh::default();
        let item = DrawItem::whole(&mesh, 0);
        let s = SETTINGS;
        CaptureKey::new([0; 32], &item, Vec3::new(i as f32, 0.0, 0.0), &s).unwrap()
    }

    #[test]
    fn a_hit_returns_the_first_value_and_the_budget_evicts_the_oldest() {
        let memo = CaptureMemo::default();
        let make = |n| {
            move || {
                Ok(Captured {
                    if_front: Vec::new(),
                    texture: texture(n),
                    covered_pixels: n,
                })
            }
        };
        let a = memo.get_or_compute(key(0), make(7)).unwrap();
        let again = memo.get_or_compute(key(0), make(9)).unwrap();
        assert_eq!(again.covered_pixels, 7);
        assert!(Arc::ptr_eq(&a, &again));
        assert_eq!(memo.counts(), (1, 1));
        // Fill past the budget: the first key is evicted, the last one is kept.
        let big = MEMO_BYTES / 5;
        for i in 1..=5 {
            memo.get_or_compute(key(i), make(big)).unwrap();
        }
        assert_eq!(
            memo.get_or_compute(key(0), make(3)).unwrap().covered_pixels,
            3
        );
        assert_eq!(
            memo.get_or_compute(key(5), make(1)).unwrap().covered_pixels,
            big
        );
        // A failed computation is not kept.
        let failed = memo.get_or_compute(key(99), || Err(CaptureError::Empty));
        assert!(failed.is_err());
        assert_eq!(
            memo.get_or_compute(key(99), make(2))
                .unwrap()
                .covered_pixels,
            2
        );
    }

    #[test]
    fn an_image_is_encoded_once_and_a_changed_byte_is_encoded_again() {
        let memo = CaptureMemo::default();
        let rgba: Vec<u8> = (0..4 * 4 * 4).map(|i| (i * 7) as u8).collect();
        let encode = |rgba: &[u8]| format::pack::Texture::from_rgba8_bc1_coverage(4, 4, rgba);
        let first = memo.encoded(4, 4, &rgba, || encode(&rgba)).unwrap();
        assert_eq!(*first, encode(&rgba).unwrap());
        let again = memo
            .encoded(4, 4, &rgba, || Err("not called on a hit".into()))
            .unwrap();
        assert!(Arc::ptr_eq(&first, &again));
        let mut changed = rgba.clone();
        changed[5] ^= 1;
        let other = memo.encoded(4, 4, &changed, || encode(&changed)).unwrap();
        assert!(!Arc::ptr_eq(&first, &other));
        // The size is in the key: the same bytes as 2 x 8 are another image.
        assert!(memo.encoded(2, 8, &rgba, || Err("miss".into())).is_err());
        assert_eq!(memo.encoded_counts(), (1, 3));
    }

    #[test]
    fn keys_differ_in_every_input() {
        let mesh = format::Mesh::default();
        let item = DrawItem::whole(&mesh, 0);
        let s = SETTINGS;
        let k = |hash: u8, item: &DrawItem, eye: Vec3, s: CaptureSettings| {
            CaptureKey::new([hash; 32], item, eye, &s)
        };
        let base = k(0, &item, Vec3::ZERO, s).unwrap();
        let moved = DrawItem {
            transform: Mat4::from_translation(Vec3::X),
            ..item
        };
        let tinted = DrawItem {
            tint: Vec3::splat(0.5),
            ..item
        };
        let others = [
            k(1, &item, Vec3::ZERO, s),
            k(0, &moved, Vec3::ZERO, s),
            k(0, &tinted, Vec3::ZERO, s),
            k(0, &item, Vec3::Y, s),
            k(0, &item, Vec3::ZERO, CaptureSettings { image_res: 65, ..s }),
            k(0, &item, Vec3::ZERO, CaptureSettings { t_c0: 2.0, ..s }),
            k(0, &item, Vec3::ZERO, CaptureSettings { t_c1: 2.0, ..s }),
            k(
                0,
                &item,
                Vec3::ZERO,
                CaptureSettings {
                    cell_size: 2.0,
                    ..s
                },
            ),
            k(
                0,
                &item,
                Vec3::ZERO,
                CaptureSettings {
                    footprint_px: 2.0,
                    ..s
                },
            ),
            k(
                0,
                &item,
                Vec3::ZERO,
                CaptureSettings {
                    neighbourhood_px: 2,
                    ..s
                },
            ),
        ];
        for (i, key) in others.iter().enumerate() {
            assert_ne!(key.as_ref(), Some(&base), "input {i}");
        }
        let triangles = [0u32];
        let subset = DrawItem {
            triangles: Some(&triangles),
            ..item
        };
        assert_eq!(k(0, &subset, Vec3::ZERO, s), None);
    }
}
