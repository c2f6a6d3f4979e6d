//! Optional `base.pack` sections of textured models (issue 18): `albedo-textures`
//! (0x0109) and `texcoords` (0x010A). Byte layouts in `format/README.md`
//! ("Base pack: albedo textures"). A pack of an untextured scene has neither
//! section and is byte-identical to one written before they existed; readers that
//! do not know them skip them (the models then draw with their vertex albedo).
//!
//! - `albedo-textures`: `u32 texture_count, u32 reserved = 0`, then per texture a
//!   16-byte [`TextureRecord`] (width, height, wrap u, wrap v), then the textures'
//!   RGBA8 sRGB texels, row 0 first, one after another in record order.
//! - `texcoords`: `u32 textured_model_count, u32 reserved = 0`, then per textured
//!   model an 8-byte [`TexcoordRecord`] (model, texture), models strictly
//!   increasing, then per listed model, in record order, one `[f32; 2]` UV per
//!   vertex of the model (its `vertex_count` in `model-table`).
//!
//! Both sections are present or neither. The writer stores each distinct texture
//! once (models of one glTF texture share it).

use super::error::PackError;
use super::layout::SectionKind;
use super::reader::PackFile;
use super::writer::{SectionData, TRY_ZSTD};
use super::{invalid, malformed};
use crate::albedo::{AlbedoMap, AlbedoTexture, Wrap, MAX_TEXTURE_SIDE};
use bytemuck::{Pod, Zeroable};
use std::collections::BTreeMap;

super::pod_records! {
    /// One texture of `albedo-textures` (16 bytes).
    pub struct TextureRecord[16] {
        pub width: u32,
        pub height: u32,
        /// [`Wrap::code`] along u and v.
        pub wrap: [u32; 2],
    }

    /// One textured model of `texcoords` (8 bytes).
    pub struct TexcoordRecord[8] {
        pub model: u32,
        pub texture: u32,
    }
}

/// The two sections for `maps` (one entry per model; vertex counts already checked
/// by the caller); empty when no model is textured.
pub(crate) fn sections(
    maps: &[Option<&AlbedoMap>],
    vertex_counts: &[u32],
) -> Result<Vec<SectionData>, PackError> {
    if maps.iter().all(|m| m.is_none()) {
        return Ok(Vec::new());
    }
    let mut distinct: BTreeMap<[u8; 32], u32> = BTreeMap::new();
    let mut records: Vec<TextureRecord> = Vec::new();
    let mut texels: Vec<u8> = Vec::new();
    let mut uv_records: Vec<TexcoordRecord> = Vec::new();
    let mut uvs: Vec<u8> = Vec::new();
    for (i, map) in maps.iter().enumerate() {
        let Some(map) = map else { continue };
        map.texture
            .validate()
            .map_err(|what| invalid(format!("model {i}: {what}")))?;
        if map.uvs.len() != vertex_counts[i] as usize {
            return Err(invalid(format!(
                "model {i}: {} texture coordinates for {} vertices",
                map.uvs.len(),
                vertex_counts[i]
            )));
        }
        if let Some(v) = map
            .uvs
            .iter()
            .position(|uv| !uv.iter().all(|x| x.is_finite()))
        {
            return Err(invalid(format!(
                "model {i}: texture coordinate of vertex {v} is not finite"
            )));
        }
        let next = records.len() as u32;
        let texture = *distinct
            .entry(map.texture.content_hash())
            .or_insert_with(|| {
                let t = &map.texture;
                records.push(TextureRecord {
                    width: t.width,
                    height: t.height,
                    wrap: t.wrap.map(Wrap::code),
                });
                texels.extend_from_slice(&t.rgba);
                next
            });
        uv_records.push(TexcoordRecord {
            model: i as u32,
            texture,
        });
        uvs.extend_from_slice(bytemuck::cast_slice(&map.uvs));
    }
    let header = |count: usize| {
        let mut h = Vec::with_capacity(8);
        h.extend_from_slice(&(count as u32).to_le_bytes());
        h.extend_from_slice(&0u32.to_le_bytes());
        h
    };
    let mut textures = header(records.len());
    textures.extend_from_slice(bytemuck::cast_slice(&records));
    textures.extend_from_slice(&texels);
    let mut texcoords = header(uv_records.len());
    texcoords.extend_from_slice(bytemuck::cast_slice(&uv_records));
    texcoords.extend_from_slice(&uvs);
    Ok(vec![
        SectionData::new(SectionKind::ALBEDO_TEXTURES, textures, TRY_ZSTD),
        SectionData::new(SectionKind::TEXCOORDS, texcoords, TRY_ZSTD),
    ])
}

/// The albedo map of each model (`vertex_counts[i]` vertices), all `None` when the
/// pack has neither section. Every count, size, wrap code, reference and UV is
/// checked.
pub(crate) fn decode(
    pack: &PackFile,
    vertex_counts: &[u32],
) -> Result<Vec<Option<AlbedoMap>>, PackError> {
    let file = pack.path();
    let has_textures = pack.section_info(SectionKind::ALBEDO_TEXTURES).is_some();
    let has_texcoords = pack.section_info(SectionKind::TEXCOORDS).is_some();
    let mut out: Vec<Option<AlbedoMap>> = vec![None; vertex_counts.len()];
    match (has_textures, has_texcoords) {
        (false, false) => return Ok(out),
        (true, false) | (false, true) => {
            let (have, missing) = if has_textures {
                (SectionKind::ALBEDO_TEXTURES, "texcoords")
            } else {
                (SectionKind::TEXCOORDS, "albedo-textures")
            };
            return Err(malformed(
                file,
                have,
                0,
                format!("present without its companion section {missing}"),
            ));
        }
        (true, true) => {}
    }
    // 1. Textures.
    let kind = SectionKind::ALBEDO_TEXTURES;
    let bytes = pack.section(kind)?;
    let (count, records_end) = header(file, kind, &bytes, 16)?;
    let mut textures = Vec::with_capacity(count);
    let mut at = records_end;
    for k in 0..count {
        let off = 8 + k * 16;
        let r: TextureRecord = bytemuck::pod_read_unaligned(&bytes[off..off + 16]);
        let side = 1..=MAX_TEXTURE_SIDE;
        if !(side.contains(&r.width) && side.contains(&r.height)) {
            return Err(malformed(
                file,
                kind,
                off as u64,
                format!(
                    "texture {k}: {} × {} texels, sides must be in 1..={MAX_TEXTURE_SIDE}",
                    r.width, r.height
                ),
            ));
        }
        let wrap = [0, 1].map(|a| Wrap::from_code(r.wrap[a]));
        let [Some(wu), Some(wv)] = wrap else {
            return Err(malformed(
                file,
                kind,
                off as u64 + 8,
                format!("texture {k}: wrap codes {:?}, expected 0, 1 or 2", r.wrap),
            ));
        };
        let len = r.width as usize * r.height as usize * 4;
        let end = data_end(
            file,
            kind,
            &bytes,
            at,
            len,
            || format!("texture {k}"),
            "texels",
        )?;
        textures.push(AlbedoTexture {
            width: r.width,
            height: r.height,
            rgba: bytes[at..end].to_vec(),
            wrap: [wu, wv],
        });
        at = end;
    }
    no_trailing_bytes(file, kind, &bytes, at, "texels")?;
    // 2. Texture coordinates.
    let kind = SectionKind::TEXCOORDS;
    let bytes = pack.section(kind)?;
    let (count, records_end) = header(file, kind, &bytes, 8)?;
    let mut at = records_end;
    let mut previous: Option<u32> = None;
    for k in 0..count {
        let off = 8 + k * 8;
        let r: TexcoordRecord = bytemuck::pod_read_unaligned(&bytes[off..off + 8]);
        if r.model as usize >= vertex_counts.len() || previous.is_some_and(|p| r.model <= p) {
            return Err(malformed(
                file,
                kind,
                off as u64,
                format!(
                    "record {k}: model {} (of {}) after {previous:?}; models must be \
                     strictly increasing and exist",
                    r.model,
                    vertex_counts.len()
                ),
            ));
        }
        previous = Some(r.model);
        let Some(texture) = textures.get(r.texture as usize) else {
            return Err(malformed(
                file,
                kind,
                off as u64 + 4,
                format!("record {k}: texture {} of {}", r.texture, textures.len()),
            ));
        };
        let len = vertex_counts[r.model as usize] as usize * 8;
        let owner = || format!("model {}", r.model);
        let end = data_end(file, kind, &bytes, at, len, owner, "texture coordinates")?;
        let uvs: Vec<[f32; 2]> = bytes[at..end]
            .chunks_exact(8)
            .map(bytemuck::pod_read_unaligned::<[f32; 2]>)
            .collect();
        if let Some(v) = uvs.iter().position(|uv| !uv.iter().all(|x| x.is_finite())) {
            return Err(malformed(
                file,
                kind,
                (at + v * 8) as u64,
                format!(
                    "model {}: texture coordinate of vertex {v} is not finite",
                    r.model
                ),
            ));
        }
        out[r.model as usize] = Some(AlbedoMap {
            uvs,
            texture: texture.clone(),
        });
        at = end;
    }
    no_trailing_bytes(file, kind, &bytes, at, "texture coordinates")?;
    Ok(out)
}

/// The end of the `len` bytes of `what` (of `owner()`, e.g. `texture 3`) at `at` in
/// `bytes`; malformed when they run past the section.
fn data_end(
    file: &std::path::Path,
    kind: SectionKind,
    bytes: &[u8],
    at: usize,
    len: usize,
    owner: impl FnOnce() -> String,
    what: &str,
) -> Result<usize, PackError> {
    at.checked_add(len)
        .filter(|&e| e <= bytes.len())
        .ok_or_else(|| {
            malformed(
                file,
                kind,
                at as u64,
                format!(
                    "{}: {len} bytes of {what}, only {} left",
                    owner(),
                    bytes.len() - at
                ),
            )
        })
}

/// Malformed when bytes follow the `what` that end at `at`.
fn no_trailing_bytes(
    file: &std::path::Path,
    kind: SectionKind,
    bytes: &[u8],
    at: usize,
    what: &str,
) -> Result<(), PackError> {
    if at == bytes.len() {
        return Ok(());
    }
    Err(malformed(
        file,
        kind,
        at as u64,
        format!("{} trailing bytes after the {what}", bytes.len() - at),
    ))
}

/// `(count, end of the record table)` of a section starting with `u32 count, u32
/// reserved = 0` and `count` records of `record` bytes.
fn header(
    file: &std::path::Path,
    kind: SectionKind,
    bytes: &[u8],
    record: usize,
) -> Result<(usize, usize), PackError> {
    if bytes.len() < 8 {
        return Err(malformed(
            file,
            kind,
            0,
            format!("{} bytes, shorter than its 8-byte header", bytes.len()),
        ));
    }
    let count = u32::from_le_bytes(bytes[0..4].try_into().expect("4 bytes")) as usize;
    let reserved = u32::from_le_bytes(bytes[4..8].try_into().expect("4 bytes"));
    if reserved != 0 {
        return Err(malformed(
            file,
            kind,
            4,
            format!("reserved field is {reserved}, expected 0"),
        ));
    }
    let end = count
        .checked_mul(record)
        .and_then(|n| n.checked_add(8))
        .filter(|&e| e <= bytes.len())
        .ok_or_else(|| {
            malformed(
                file,
                kind,
                0,
                format!(
                    "{count} records of {record} bytes do not fit in {} bytes",
                    bytes.len()
                ),
            )
        })?;
    Ok((count, end))
}
