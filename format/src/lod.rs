//! Per-model LOD chain files (`<out>/lod/<model content hash>.lod`): the cache of
//! the worker's per-model chains of coarser levels (`worker::lod_chain`, DESIGN.md
//! "Cost structure"). A chain depends only on the model's mesh and the chain
//! parameters, so it is computed once per model and reused by every cell and every
//! rerun; a file that does not decode, was made for another model or chain
//! revision, or is not a chain of the model it names (every level checked against
//! the model: `worker::lod_chain::LodChain::from_file`, issue 32 item 2), is simply
//! rebuilt (it is a cache, never an input of record; its checksum says only that
//! the payload is whole).
//!
//! Layout (little-endian; `format/README.md` "LOD chain files"):
//!
//! ```text
//! 0   magic        8 bytes  "HXBKLOD\0"
//! 8   version      u32      LOD_FILE_VERSION
//! 12  revision     u32      the chain builder's revision (worker)
//! 16  model hash   32 bytes Model::content_hash
//! 48  vertices     u32      the model's vertex count
//! 52  levels       u32      number of levels
//! 56  payload len  u64      bytes of the zstd payload that follows the header
//! 64  checksum     32 bytes blake3 of the zstd payload
//! 96  payload      zstd of, per level: bound f32, max_error f32, triangles u32,
//!                  carried total u32, triangles [u32; 3] × n, carried count u32 × n,
//!                  carried vertex ids u32 × total
//! ```

use thiserror::Error;

pub const LOD_MAGIC: [u8; 8] = *b"HXBKLOD\0";
pub const LOD_FILE_VERSION: u32 = 1;
const HEADER_BYTES: usize = 96;

/// One level of a chain: triangles over the model's original vertex ids and, per
/// triangle, the original vertices its collapses removed and it carries.
#[derive(Clone, Debug, PartialEq)]
pub struct LodLevelData {
    /// The object-space tolerance the level was built with.
    pub bound: f32,
    /// The largest distance (object space) of a removed original vertex from the
    /// level's surface (≤ `bound`).
    pub max_error: f32,
    pub triangles: Vec<[u32; 3]>,
    /// Per triangle, the removed vertices it carries (same length as `triangles`).
    pub carried: Vec<Vec<u32>>,
}

/// A decoded chain file.
#[derive(Clone, Debug, PartialEq)]
pub struct LodChainFile {
    pub revision: u32,
    pub model_hash: [u8; 32],
    pub vertices: u32,
    pub levels: Vec<LodLevelData>,
}

#[derive(Debug, Error, PartialEq)]
pub enum LodFileError {
    #[error("byte {offset}: {what}")]
    Invalid { offset: usize, what: String },
}

fn invalid(offset: usize, what: impl Into<String>) -> LodFileError {
    LodFileError::Invalid {
        offset,
        what: what.into(),
    }
}

impl LodChainFile {
    pub fn encode(&self) -> Vec<u8> {
        let mut payload = Vec::new();
        let mut put = |v: u32| payload.extend_from_slice(&v.to_le_bytes());
        for level in &self.levels {
            put(level.bound.to_bits());
            put(level.max_error.to_bits());
            put(level.triangles.len() as u32);
            put(level.carried.iter().map(|c| c.len() as u32).sum());
            for t in &level.triangles {
                t.iter().for_each(|&v| put(v));
            }
            for c in &level.carried {
                put(c.len() as u32);
            }
            for c in &level.carried {
                c.iter().for_each(|&v| put(v));
            }
        }
        let packed = zstd::bulk::compress(&payload, 3).expect("zstd compresses to memory");
        let mut out = Vec::with_capacity(HEADER_BYTES + packed.len());
        out.extend_from_slice(&LOD_MAGIC);
        out.extend_from_slice(&LOD_FILE_VERSION.to_le_bytes());
        out.extend_from_slice(&self.revision.to_le_bytes());
        out.extend_from_slice(&self.model_hash);
        out.extend_from_slice(&self.vertices.to_le_bytes());
        out.extend_from_slice(&(self.levels.len() as u32).to_le_bytes());
        out.extend_from_slice(&(packed.len() as u64).to_le_bytes());
        out.extend_from_slice(blake3::hash(&packed).as_bytes());
        out.extend_from_slice(&packed);
        out
    }

    /// Decodes and checks a chain file: header, checksum, every length, every vertex
    /// id below the vertex count, each level's carried lists one per triangle.
    pub fn decode(bytes: &[u8]) -> Result<LodChainFile, LodFileError> {
        if bytes.len() < HEADER_BYTES {
            return Err(invalid(
                bytes.len(),
                format!("truncated header: {} of {HEADER_BYTES} bytes", bytes.len()),
            ));
        }
        if bytes[..8] != LOD_MAGIC {
            return Err(invalid(0, "not a hexbake LOD chain file (bad magic)"));
        }
        let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes"));
        let version = u32_at(8);
        if version != LOD_FILE_VERSION {
            return Err(invalid(
                8,
                format!("version {version}, this hexbake reads {LOD_FILE_VERSION}"),
            ));
        }
        let revision = u32_at(12);
        let model_hash: [u8; 32] = bytes[16..48].try_into().expect("32 bytes");
        let vertices = u32_at(48);
        let level_count = u32_at(52);
        let payload_len = u64::from_le_bytes(bytes[56..64].try_into().expect("8 bytes"));
        let packed = &bytes[HEADER_BYTES..];
        if packed.len() as u64 != payload_len {
            return Err(invalid(
                56,
                format!(
                    "payload of {payload_len} bytes announced, {} present",
                    packed.len()
                ),
            ));
        }
        if blake3::hash(packed).as_bytes()[..] != bytes[64..96] {
            return Err(invalid(64, "checksum of the payload does not match"));
        }
        // Bounded: a level needs at least 16 bytes, so the payload cannot claim
        // more than 64 MiB per announced compressed byte … cap it plainly.
        const MAX_PAYLOAD: usize = 1 << 31;
        let payload = zstd::bulk::decompress(packed, MAX_PAYLOAD)
            .map_err(|e| invalid(HEADER_BYTES, format!("zstd payload: {e}")))?;
        let mut at = 0usize;
        let mut next = |what: &str| -> Result<u32, LodFileError> {
            let end = at
                .checked_add(4)
                .filter(|&e| e <= payload.len())
                .ok_or_else(|| invalid(HEADER_BYTES, format!("payload ends inside {what}")))?;
            let v = u32::from_le_bytes(payload[at..end].try_into().expect("4 bytes"));
            at = end;
            Ok(v)
        };
        let mut levels = Vec::new();
        for _ in 0..level_count {
            let bound = f32::from_bits(next("a level header")?);
            let max_error = f32::from_bits(next("a level header")?);
            if !(bound.is_finite() && max_error.is_finite() && max_error >= 0.0) {
                return Err(invalid(HEADER_BYTES, "a level's bound is not finite"));
            }
            let n = next("a level header")? as usize;
            let total = next("a level header")? as usize;
            // Each announced entry needs 4 payload bytes: refuse before allocating.
            let need = n.saturating_mul(16).saturating_add(total.saturating_mul(4));
            if need > payload.len() {
                return Err(invalid(
                    HEADER_BYTES,
                    format!("a level announces {n} triangles and {total} carried ids, the payload is shorter"),
                ));
            }
            let mut check = |v: u32| {
                if v < vertices {
                    Ok(v)
                } else {
                    Err(invalid(
                        HEADER_BYTES,
                        format!("vertex id {v}, the model has {vertices}"),
                    ))
                }
            };
            let mut triangles = Vec::with_capacity(n);
            for _ in 0..n {
                triangles.push([
                    check(next("a triangle")?)?,
                    check(next("a triangle")?)?,
                    check(next("a triangle")?)?,
                ]);
            }
            let counts = (0..n)
                .map(|_| next("carried counts").map(|c| c as usize))
                .collect::<Result<Vec<_>, _>>()?;
            if counts.iter().sum::<usize>() != total {
                return Err(invalid(HEADER_BYTES, "carried counts do not add up"));
            }
            let mut carried = Vec::with_capacity(n);
            for c in counts {
                carried.push(
                    (0..c)
                        .map(|_| next("carried ids").and_then(&mut check))
                        .collect::<Result<Vec<_>, _>>()?,
                );
            }
            levels.push(LodLevelData {
                bound,
                max_error,
                triangles,
                carried,
            });
        }
        if at != payload.len() {
            return Err(invalid(
                HEADER_BYTES,
                format!("{} trailing payload bytes", payload.len() - at),
            ));
        }
        Ok(LodChainFile {
            revision,
            model_hash,
            vertices,
            levels,
        })
    }
}
