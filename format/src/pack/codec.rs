//! Section codecs (format/README.md, "Codecs"): raw, zstd, and zstd over a
//! delta + zig-zag + byte-plane pre-coding of u32 index streams. Encoding is
//! deterministic (fixed zstd level, single-threaded, no content-size-dependent
//! options); decoding never allocates more than the entry's `raw_len`, which the
//! table validation has already bounded.

use super::layout::{Codec, MAX_EXPANSION};
use std::io::Read;

/// The zstd level every writer uses. Fixed: the same input must give the same bytes.
/// Level 6, not higher: on a real park-2m cell's 200 capture textures, level 15 is
/// 3% smaller but 6× slower and took half of the bake's CPU time (BENCHMARKS.md).
pub const ZSTD_LEVEL: i32 = 6;

/// A compressed section is kept only if it saves at least 1/16 of the raw size — or
/// 1/4 for sections that prefer to stay raw (vertex arrays, which a memory-mapped
/// reader can hand to the GPU zero-copy; zstd saves only 8-10% on real float
/// positions) — and does not expand by more than [`MAX_EXPANSION`]; otherwise the
/// section is stored raw.
fn pays(raw: usize, stored: usize, prefer_raw: bool) -> bool {
    let (num, den) = if prefer_raw { (3, 4) } else { (15, 16) };
    stored.saturating_mul(den) <= raw.saturating_mul(num)
        && (stored as u64).saturating_mul(MAX_EXPANSION) >= raw as u64
}

/// One zstd frame of `bytes` at [`ZSTD_LEVEL`] (deterministic): the texture store's
/// files (`super::texture_store`).
pub fn zstd_compress(bytes: &[u8]) -> Vec<u8> {
    // Level and parameters fixed; `bulk` compresses in one call without threads.
    zstd::bulk::compress(bytes, ZSTD_LEVEL).expect("zstd compression of an in-memory buffer")
}

/// Zig-zag map of a delta: 0, −1, 1, −2, 2 … → 0, 1, 2, 3, 4 …
pub fn zigzag(d: i32) -> u32 {
    ((d << 1) ^ (d >> 31)) as u32
}

/// Inverse of [`zigzag`].
pub fn unzigzag(z: u32) -> i32 {
    (z >> 1) as i32 ^ -((z & 1) as i32)
}

/// Appends `z` as an LEB128 varint: 7 bits a byte, lowest first, the high bit set on
/// every byte but the last.
pub fn push_leb128(out: &mut Vec<u8>, mut z: u32) {
    loop {
        let b = (z & 0x7f) as u8;
        z >>= 7;
        if z == 0 {
            out.push(b);
            break;
        }
        out.push(b | 0x80);
    }
}

/// Delta + zig-zag + byte planes of a little-endian u32 stream (`bytes.len() % 4 == 0`).
pub fn precode_delta_u32(bytes: &[u8]) -> Vec<u8> {
    let n = bytes.len() / 4;
    let mut out = vec![0u8; n * 4];
    let mut prev = 0u32;
    for (i, c) in bytes.chunks_exact(4).enumerate() {
        let v = u32::from_le_bytes([c[0], c[1], c[2], c[3]]);
        let d = v.wrapping_sub(prev) as i32;
        prev = v;
        let zb = zigzag(d).to_le_bytes();
        for (k, b) in zb.iter().enumerate() {
            out[k * n + i] = *b;
        }
    }
    out
}

/// Inverse of [`precode_delta_u32`]; `None` if the length is not a multiple of 4.
pub fn postdecode_delta_u32(planes: &[u8]) -> Option<Vec<u8>> {
    if !planes.len().is_multiple_of(4) {
        return None;
    }
    let n = planes.len() / 4;
    let mut out = Vec::with_capacity(planes.len());
    let mut prev = 0u32;
    for i in 0..n {
        let z = u32::from_le_bytes([
            planes[i],
            planes[n + i],
            planes[2 * n + i],
            planes[3 * n + i],
        ]);
        let v = prev.wrapping_add(unzigzag(z) as u32);
        prev = v;
        out.extend_from_slice(&v.to_le_bytes());
    }
    Some(out)
}

/// Length of the move-to-front list of [`precode_index_mtf`].
pub const MTF_LEN: usize = 16;

/// Move-to-front pre-coding of a little-endian u32 index stream (`bytes.len() % 4 ==
/// 0`): `n` code bytes, then the deltas. An index found at position `k` of the list of
/// the [`MTF_LEN`] most recently used indices (initially all 0) codes as `k`; any
/// other codes as [`MTF_LEN`] followed (in the second part) by the zig-zag LEB128
/// difference from the previous such index (initially 0). Either way the index moves
/// to the front. In a triangle list most indices repeat one of the last few
/// triangles' vertices, so the code bytes are small and zstd's entropy stage takes
/// them to 3–4 bits.
pub fn precode_index_mtf(bytes: &[u8]) -> Vec<u8> {
    let n = bytes.len() / 4;
    let mut codes = Vec::with_capacity(n);
    let mut deltas = Vec::new();
    let mut list = [0u32; MTF_LEN];
    let mut last_new = 0u32;
    for c in bytes.chunks_exact(4) {
        let v = u32::from_le_bytes([c[0], c[1], c[2], c[3]]);
        let k = match list.iter().position(|&x| x == v) {
            Some(k) => k,
            None => {
                let d = v.wrapping_sub(last_new) as i32;
                last_new = v;
                push_leb128(&mut deltas, zigzag(d));
                MTF_LEN - 1
            }
        };
        codes.push(if list[k] == v { k as u8 } else { MTF_LEN as u8 });
        list.copy_within(0..k, 1);
        list[0] = v;
    }
    codes.extend_from_slice(&deltas);
    codes
}

/// Inverse of [`precode_index_mtf`] for `n` indices; says why on malformed input (a
/// code above [`MTF_LEN`], a delta cut short or longer than 5 bytes, bytes left over).
pub fn postdecode_index_mtf(pre: &[u8], n: usize) -> Result<Vec<u8>, String> {
    if pre.len() < n {
        return Err(format!("index-mtf: {} bytes for {n} codes", pre.len()));
    }
    let (codes, deltas) = pre.split_at(n);
    let mut at = 0usize;
    let mut out = Vec::with_capacity(n * 4);
    let mut list = [0u32; MTF_LEN];
    let mut last_new = 0u32;
    for (i, &code) in codes.iter().enumerate() {
        let (k, v) = match code as usize {
            k if k < MTF_LEN => (k, list[k]),
            MTF_LEN => {
                let mut z = 0u32;
                let mut shift = 0;
                loop {
                    let b = *deltas.get(at).ok_or_else(|| {
                        format!("index-mtf: index {i}: delta cut short at byte {}", n + at)
                    })?;
                    at += 1;
                    if shift == 28 && b > 0x0f {
                        return Err(format!("index-mtf: index {i}: delta longer than 32 bits"));
                    }
                    z |= ((b & 0x7f) as u32) << shift;
                    if b & 0x80 == 0 {
                        break;
                    }
                    shift += 7;
                }
                last_new = last_new.wrapping_add(unzigzag(z) as u32);
                (MTF_LEN - 1, last_new)
            }
            c => return Err(format!("index-mtf: index {i}: code {c} above {MTF_LEN}")),
        };
        list.copy_within(0..k, 1);
        list[0] = v;
        out.extend_from_slice(&v.to_le_bytes());
    }
    if at != deltas.len() {
        return Err(format!(
            "index-mtf: {} bytes left after {n} indices",
            deltas.len() - at
        ));
    }
    Ok(out)
}

/// Encodes a section with the codec the writer would choose from `candidates`,
/// falling back to [`Codec::Raw`] when no compression pays. Returns the codec and the
/// stored bytes.
pub fn encode_best(raw: &[u8], candidates: &[Codec]) -> (Codec, Vec<u8>) {
    encode_best_with(raw, candidates, false)
}

/// As [`encode_best`]; `prefer_raw` demands a saving of 1/4 before giving up raw.
pub fn encode_best_with(raw: &[u8], candidates: &[Codec], prefer_raw: bool) -> (Codec, Vec<u8>) {
    let mut best: (Codec, Vec<u8>) = (Codec::Raw, raw.to_vec());
    for &c in candidates {
        let stored = match c {
            Codec::Raw => continue,
            Codec::Zstd => zstd_compress(raw),
            Codec::ZstdDeltaU32 => {
                if !raw.len().is_multiple_of(4) {
                    continue;
                }
                zstd_compress(&precode_delta_u32(raw))
            }
            Codec::ZstdIndexMtf => {
                if !raw.len().is_multiple_of(4) {
                    continue;
                }
                zstd_compress(&precode_index_mtf(raw))
            }
        };
        if pays(raw.len(), stored.len(), prefer_raw) && stored.len() < best.1.len() {
            best = (c, stored);
        }
    }
    best
}

/// Decodes stored bytes into exactly `raw_len` bytes, or says why not.
pub fn decode(codec: Codec, stored: &[u8], raw_len: u64) -> Result<Vec<u8>, String> {
    match codec {
        Codec::Raw => {
            if stored.len() as u64 != raw_len {
                return Err(format!(
                    "raw section of {} bytes, table says {raw_len}",
                    stored.len()
                ));
            }
            Ok(stored.to_vec())
        }
        Codec::Zstd => zstd_decompress(stored, raw_len),
        Codec::ZstdDeltaU32 => {
            if !raw_len.is_multiple_of(4) {
                return Err(format!(
                    "delta-u32 section raw length {raw_len} is not a multiple of 4"
                ));
            }
            let planes = zstd_decompress(stored, raw_len)?;
            postdecode_delta_u32(&planes).ok_or_else(|| "bad delta-u32 length".to_string())
        }
        Codec::ZstdIndexMtf => {
            if !raw_len.is_multiple_of(4) {
                return Err(format!(
                    "index-mtf section raw length {raw_len} is not a multiple of 4"
                ));
            }
            // n code bytes plus at most 5 delta bytes per index.
            let n = raw_len / 4;
            let pre = zstd_decompress_at_most(stored, n.saturating_mul(6))?;
            postdecode_index_mtf(&pre, n as usize)
        }
    }
}

fn zstd_decompress(stored: &[u8], raw_len: u64) -> Result<Vec<u8>, String> {
    let out = zstd_decompress_at_most(stored, raw_len)?;
    if out.len() as u64 != raw_len {
        return Err(format!(
            "decompressed to {} bytes, table says {raw_len}",
            out.len()
        ));
    }
    Ok(out)
}

/// Decompresses one frame of at most `max` bytes (one more is an error).
fn zstd_decompress_at_most(stored: &[u8], max: u64) -> Result<Vec<u8>, String> {
    let raw_len = max;
    // Stream into a buffer that grows with the real output, never past raw_len + 1:
    // a frame lying about its size cannot make us allocate more than that.
    let mut decoder = zstd::stream::read::Decoder::with_buffer(stored)
        .map_err(|e| e.to_string())?
        .single_frame();
    // Reserve what a typical section needs up front (no regrowth), but never more
    // than 64x the stored bytes + 1 MiB before the output is actually produced.
    let reserve = raw_len.min(
        (stored.len() as u64)
            .saturating_mul(64)
            .saturating_add(1 << 20),
    );
    let mut out = Vec::with_capacity(reserve as usize);
    (&mut decoder)
        .take(raw_len.saturating_add(1))
        .read_to_end(&mut out)
        .map_err(|e| e.to_string())?;
    if out.len() as u64 > raw_len {
        return Err(format!(
            "decompressed to more than the {raw_len} bytes the table allows"
        ));
    }
    Ok(out)
}
