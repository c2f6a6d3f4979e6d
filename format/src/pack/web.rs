//! Files derived from a cell or group pack for the browser viewer (issue 33, "first
//! frame ≤ 1 s and ≤ 2 MB"; format/README.md "Derived files for the browser").
//!
//! Paper 000 §3.2 streams a cell's representations as the viewer moves. A browser
//! pays per request and per byte, and a pack alone does not draw: its proxies'
//! members are triangles over the *model's* vertices (section `member-triangles`),
//! which live in `base.pack`, and its captures live in the texture store, one file
//! each. On park-2m, the first cell's proxies use 14,628 of the 149,684 vertices, but
//! scattered over all eight models (thousands of byte ranges), and its 237 captures
//! are 237 requests: in headless Chromium ≈ 5 ms each on this machine, while
//! the server answers 300 of them in 0.1 s. So, beside each `<pack>`:
//!
//! - `<pack>.vertices`: the vertices its proxies' members use, gathered from
//!   base.pack (ids, positions, normals, colours);
//! - `<pack>.textures`: the textures its views name from the store, in one file.
//!
//! Both are pure functions of the pack, its base and the store, so `pipeline serve`
//! derives them on request and `pipeline web-export` writes them for a static host;
//! a viewer that gets a 404 falls back to base.pack ranges and single store files.

use super::base::BasePack;
#[cfg(test)]
use super::texture_store::texture_path;
use super::texture_store::{pack_refs, read_texture, TextureRef, REF_LEN};
use super::{malformed, PackError, PackFile, SectionKind};
use std::path::Path;

/// Magic of a `.vertices` file.
pub const VERTICES_MAGIC: [u8; 4] = *b"HXVS";
/// Magic of a `.textures` file.
pub const TEXTURES_MAGIC: [u8; 4] = *b"HXTB";
/// Layout version of both files.
pub const WEB_VERSION: u32 = 1;
/// Suffix of a pack's vertex subset.
pub const VERTICES_SUFFIX: &str = ".vertices";
/// Suffix of a pack's texture bundle.
pub const TEXTURES_SUFFIX: &str = ".textures";

/// A pack's vertex subset: global vertex ids (base.pack vertex order: a model's
/// vertices follow those of the models before it), ascending and distinct, with
/// their data.
#[derive(Clone, Debug, PartialEq)]
pub struct VertexSubset {
    pub ids: Vec<u32>,
    pub positions: Vec<[f32; 3]>,
    pub normals: Vec<[f32; 3]>,
    pub colours: Vec<[u8; 4]>,
}

/// The global ids of the vertices `pack`'s proxies' members use, ascending and
/// distinct. Checks every instance and vertex index against `base`.
pub fn proxy_vertex_ids(base: &BasePack, pack: &PackFile) -> Result<Vec<u32>, PackError> {
    let mut start = Vec::with_capacity(base.models.len());
    let mut total = 0u64;
    for m in &base.models {
        start.push(total);
        total += m.mesh.positions.len() as u64;
    }
    if total > u64::from(u32::MAX) {
        return Err(PackError::Invalid {
            what: format!("base pack has {total} vertices, more than u32 ids can name"),
        });
    }
    let members = pack.section(SectionKind::MEMBERS)?;
    let tris = pack.section(SectionKind::MEMBER_TRIANGLES)?;
    if members.len() % 16 != 0 || tris.len() % 12 != 0 {
        return Err(malformed(
            pack.path(),
            SectionKind::MEMBERS,
            0,
            format!(
                "{} member bytes, {} triangle bytes: not whole records",
                members.len(),
                tris.len()
            ),
        ));
    }
    let u32_at = |b: &[u8], o: usize| u32::from_le_bytes(b[o..o + 4].try_into().expect("4 bytes"));
    let mut ids = Vec::new();
    let mut at = 0usize; // triangle index into member-triangles
    for (k, rec) in members.chunks_exact(16).enumerate() {
        let (instance, count) = (u32_at(rec, 0), u32_at(rec, 4) as usize);
        let Some(inst) = base.instances.get(instance as usize) else {
            return Err(malformed(
                pack.path(),
                SectionKind::MEMBERS,
                16 * k as u64,
                format!("instance {instance}, the base has {}", base.instances.len()),
            ));
        };
        let model = inst.model as usize;
        let n = base.models[model].mesh.positions.len() as u32;
        if at + count > tris.len() / 12 {
            return Err(malformed(
                pack.path(),
                SectionKind::MEMBER_TRIANGLES,
                12 * at as u64,
                format!("member {k} needs {count} triangles, fewer are left"),
            ));
        }
        for t in at..at + count {
            for j in 0..3 {
                let v = u32_at(&tris, 12 * t + 4 * j);
                if v >= n {
                    return Err(malformed(
                        pack.path(),
                        SectionKind::MEMBER_TRIANGLES,
                        (12 * t + 4 * j) as u64,
                        format!("vertex {v} of model {model}, which has {n}"),
                    ));
                }
                ids.push((start[model] + u64::from(v)) as u32);
            }
        }
        at += count;
    }
    ids.sort_unstable();
    ids.dedup();
    Ok(ids)
}

/// The vertex subset of `pack`'s proxies, encoded (format/README.md).
pub fn vertices_file(base: &BasePack, pack: &PackFile) -> Result<Vec<u8>, PackError> {
    let ids = proxy_vertex_ids(base, pack)?;
    // Global id → (model, local) by walking the ascending ids with the models.
    let mut positions = Vec::with_capacity(ids.len());
    let mut normals = Vec::with_capacity(ids.len());
    let mut colours = Vec::with_capacity(ids.len());
    let (mut model, mut first) = (0usize, 0u32);
    for &id in &ids {
        while id - first >= base.models[model].mesh.positions.len() as u32 {
            first += base.models[model].mesh.positions.len() as u32;
            model += 1;
        }
        let mesh = &base.models[model].mesh;
        let v = (id - first) as usize;
        positions.push(mesh.positions[v]);
        normals.push(mesh.normals[v]);
        colours.push(mesh.albedo[v]);
    }
    Ok(encode_vertices(&VertexSubset {
        ids,
        positions,
        normals,
        colours,
    }))
}

/// Encodes a subset: magic, version, n, id-stream length, the ids as LEB128 gaps
/// (the first id, then each id − previous − 1), zero padding to 4 bytes, then n
/// positions, n normals (`[f32; 3]` each) and n colours (`[u8; 4]`).
pub fn encode_vertices(s: &VertexSubset) -> Vec<u8> {
    let mut stream = Vec::with_capacity(2 * s.ids.len());
    let mut prev: Option<u32> = None;
    for &id in &s.ids {
        let gap = match prev {
            None => id,
            Some(p) => id - p - 1,
        };
        prev = Some(id);
        super::codec::push_leb128(&mut stream, gap);
    }
    let mut out = Vec::with_capacity(16 + stream.len() + 3 + 28 * s.ids.len());
    out.extend_from_slice(&VERTICES_MAGIC);
    out.extend_from_slice(&WEB_VERSION.to_le_bytes());
    out.extend_from_slice(&(s.ids.len() as u32).to_le_bytes());
    out.extend_from_slice(&(stream.len() as u32).to_le_bytes());
    out.extend_from_slice(&stream);
    out.resize(out.len().next_multiple_of(4), 0);
    out.extend_from_slice(bytemuck::cast_slice(&s.positions));
    out.extend_from_slice(bytemuck::cast_slice(&s.normals));
    out.extend_from_slice(bytemuck::cast_slice(&s.colours));
    out
}

/// A `.vertices` file's error: `Invalid` naming the file and byte offset.
fn bad(file: &Path, offset: usize, what: impl std::fmt::Display) -> PackError {
    PackError::Invalid {
        what: format!("{}: byte {offset}: {what}", file.display()),
    }
}

/// Decodes a `.vertices` file, checking every length, that the ids ascend and that
/// nothing is left over. `file` names it in errors.
pub fn decode_vertices(bytes: &[u8], file: &Path) -> Result<VertexSubset, PackError> {
    let word = |o: usize| -> Result<u32, PackError> {
        bytes
            .get(o..o + 4)
            .map(|b| u32::from_le_bytes(b.try_into().expect("4 bytes")))
            .ok_or_else(|| bad(file, o, "file ends inside the 16-byte head"))
    };
    if bytes.get(0..4) != Some(&VERTICES_MAGIC[..]) {
        return Err(bad(file, 0, "not a hexbake vertex subset (magic \"HXVS\")"));
    }
    let version = word(4)?;
    if version != WEB_VERSION {
        return Err(bad(
            file,
            4,
            format!("version {version}, this reader knows {WEB_VERSION}"),
        ));
    }
    let (n, stream_len) = (word(8)? as usize, word(12)? as usize);
    let stream_end = 16usize.saturating_add(stream_len);
    let data = stream_end.next_multiple_of(4);
    let want = (n as u64) * 28 + data as u64;
    if bytes.len() as u64 != want {
        return Err(bad(
            file,
            bytes.len(),
            format!(
                "{n} vertices and {stream_len} id bytes need {want} bytes, the file has {}",
                bytes.len()
            ),
        ));
    }
    let mut ids = Vec::with_capacity(n);
    let mut o = 16;
    let mut prev: Option<u32> = None;
    for _ in 0..n {
        let mut gap = 0u64;
        let mut shift = 0;
        loop {
            if o >= stream_end || shift > 28 {
                return Err(bad(file, o, "id gap cut short or longer than 32 bits"));
            }
            let b = bytes[o];
            o += 1;
            gap |= u64::from(b & 0x7f) << shift;
            shift += 7;
            if b & 0x80 == 0 {
                break;
            }
        }
        let id = match prev {
            None => gap,
            Some(p) => u64::from(p) + gap + 1,
        };
        let id = u32::try_from(id).map_err(|_| bad(file, o, format!("vertex id {id} past u32")))?;
        ids.push(id);
        prev = Some(id);
    }
    if o != stream_end {
        return Err(bad(file, o, "bytes left over after the ids"));
    }
    if bytes[stream_end..data].iter().any(|&b| b != 0) {
        return Err(bad(file, stream_end, "padding not zero"));
    }
    let p = data + 12 * n;
    let c = p + 12 * n;
    Ok(VertexSubset {
        ids,
        positions: bytemuck::pod_collect_to_vec(&bytes[data..p]),
        normals: bytemuck::pod_collect_to_vec(&bytes[p..c]),
        colours: bytemuck::pod_collect_to_vec(&bytes[c..]),
    })
}

/// The texture bundle of a pack read from `<bake>/cells/` or `<bake>/groups/`: magic,
/// version, n, then n records (`ref [u8; 32]`, `len u32`) of the distinct references
/// of its `texture-refs` in first-use order, then those textures' encoded bytes (what
/// a `textures` section would hold for their views: BC1 blocks, RGBA8 …), read from
/// the store and checked against their hashes. Not compressed: `pipeline serve` sends
/// it with `Content-Encoding: zstd` to a browser that accepts it, which decodes it
/// natively (and one frame over all of them is smaller than a frame each: 673 KB
/// against 714 KB for park-2m's cell 253). A pack with inline textures has n = 0.
pub fn textures_file(pack: &PackFile, bake: &Path) -> Result<Vec<u8>, PackError> {
    let refs = pack_refs(pack)?;
    let lens = super::cell::view_data_lens(pack)?;
    if !refs.is_empty() && refs.len() != lens.len() {
        return Err(malformed(
            pack.path(),
            SectionKind::TEXTURE_REFS,
            0,
            format!("{} references for {} views", refs.len(), lens.len()),
        ));
    }
    let mut seen = std::collections::HashSet::new();
    let mut table = Vec::new();
    let mut body = Vec::new();
    for (r, &len) in refs.iter().zip(&lens) {
        if !seen.insert(*r) {
            continue;
        }
        let data = read_texture(bake, r, len)?;
        table.extend_from_slice(r);
        let len = u32::try_from(data.len()).map_err(|_| PackError::Invalid {
            what: format!("texture of {} bytes", data.len()),
        })?;
        table.extend_from_slice(&len.to_le_bytes());
        body.extend_from_slice(&data);
    }
    let mut out = Vec::with_capacity(12 + table.len() + body.len());
    out.extend_from_slice(&TEXTURES_MAGIC);
    out.extend_from_slice(&WEB_VERSION.to_le_bytes());
    out.extend_from_slice(&(seen.len() as u32).to_le_bytes());
    out.extend_from_slice(&table);
    out.extend_from_slice(&body);
    Ok(out)
}

/// Splits a texture bundle into (reference, encoded texture bytes), checking lengths.
pub fn decode_textures(bytes: &[u8], file: &Path) -> Result<Vec<(TextureRef, Vec<u8>)>, PackError> {
    if bytes.get(0..4) != Some(&TEXTURES_MAGIC[..]) {
        return Err(bad(
            file,
            0,
            "not a hexbake texture bundle (magic \"HXTB\")",
        ));
    }
    let word = |o: usize| -> Result<u32, PackError> {
        bytes
            .get(o..o + 4)
            .map(|b| u32::from_le_bytes(b.try_into().expect("4 bytes")))
            .ok_or_else(|| bad(file, o, "file ends inside the table"))
    };
    let version = word(4)?;
    if version != WEB_VERSION {
        return Err(bad(
            file,
            4,
            format!("version {version}, this reader knows {WEB_VERSION}"),
        ));
    }
    let n = word(8)? as usize;
    let rec = REF_LEN + 4;
    let table_end = 12u64 + n as u64 * rec as u64;
    if table_end > bytes.len() as u64 {
        return Err(bad(
            file,
            bytes.len(),
            format!("{n} records need {table_end} bytes"),
        ));
    }
    let mut out = Vec::with_capacity(n);
    let mut at = table_end as usize;
    for k in 0..n {
        let o = 12 + k * rec;
        let r: TextureRef = bytes[o..o + REF_LEN].try_into().expect("32 bytes");
        let len = word(o + REF_LEN)? as usize;
        let Some(body) = bytes.get(at..at + len) else {
            return Err(bad(
                file,
                at,
                format!("texture {k} needs {len} bytes, fewer are left"),
            ));
        };
        out.push((r, body.to_vec()));
        at += len;
    }
    if at != bytes.len() {
        return Err(bad(file, at, "bytes left over after the textures"));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pack::sample;
    use proptest::prelude::*;

    /// The global ids a cell's proxies use, from the decoded value (not the bytes).
    fn expected_ids(base: &BasePack, cell: &crate::pack::CellPack) -> Vec<u32> {
        let mut start = vec![0u32];
        for m in &base.models {
            start.push(start.last().unwrap() + m.mesh.positions.len() as u32);
        }
        let mut ids: Vec<u32> = cell
            .proxies
            .iter()
            .flat_map(|p| &p.members)
            .flat_map(|m| {
                let s = start[base.instances[m.instance as usize].model as usize];
                m.triangles.iter().flatten().map(move |&v| s + v)
            })
            .collect();
        ids.sort_unstable();
        ids.dedup();
        ids
    }

    #[test]
    fn vertices_are_the_members_vertices_with_the_base_data() {
        let base = sample::small_base();
        let cell = sample::small_cell();
        let pack = PackFile::from_bytes(&cell.encode().unwrap()).unwrap();
        let file = vertices_file(&base, &pack).unwrap();
        let s = decode_vertices(&file, Path::new("t.vertices")).unwrap();
        assert_eq!(s.ids, expected_ids(&base, &cell));
        assert!(!s.ids.is_empty());
        let all: Vec<_> = base
            .models
            .iter()
            .flat_map(|m| m.mesh.positions.iter())
            .collect();
        let nrm: Vec<_> = base
            .models
            .iter()
            .flat_map(|m| m.mesh.normals.iter())
            .collect();
        let col: Vec<_> = base
            .models
            .iter()
            .flat_map(|m| m.mesh.albedo.iter())
            .collect();
        for (k, &id) in s.ids.iter().enumerate() {
            assert_eq!(s.positions[k], *all[id as usize]);
            assert_eq!(s.normals[k], *nrm[id as usize]);
            assert_eq!(s.colours[k], *col[id as usize]);
        }
    }

    #[test]
    fn a_pack_of_another_base_is_refused() {
        let cell = sample::small_cell();
        let pack = PackFile::from_bytes(&cell.encode().unwrap()).unwrap();
        let mut base = sample::small_base();
        base.instances.truncate(0);
        let e = vertices_file(&base, &pack).unwrap_err().to_string();
        assert!(e.contains("members") && e.contains("instance"), "{e}");
        let mut base = sample::small_base();
        for m in &mut base.models {
            m.mesh.positions.truncate(1);
        }
        let e = vertices_file(&base, &pack).unwrap_err().to_string();
        assert!(
            e.contains("member-triangles") && e.contains("which has 1"),
            "{e}"
        );
    }

    #[test]
    fn textures_are_each_distinct_capture_once_in_first_use_order() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join("cells")).unwrap();
        let mut cell = sample::small_cell();
        // The first view's capture again on a later view: sent once.
        let first = cell.proxies[0].views[0].clone();
        cell.proxies.last_mut().unwrap().views.push(first);
        let bytes = cell.encode_reusing(false, None, Some(dir.path())).unwrap();
        let path = dir.path().join("cells/1.pack");
        std::fs::write(&path, &bytes).unwrap();
        let pack = PackFile::open(&path).unwrap();
        let out = decode_textures(&textures_file(&pack, dir.path()).unwrap(), &path).unwrap();
        let mut want: Vec<&[u8]> = Vec::new();
        for v in cell.proxies.iter().flat_map(|p| &p.views) {
            if !want.contains(&&v.texture.data[..]) {
                want.push(&v.texture.data);
            }
        }
        let got: Vec<&[u8]> = out.iter().map(|(_, d)| &d[..]).collect();
        assert_eq!(got, want);
        for (r, d) in &out {
            assert_eq!(*r, crate::pack::texture_store::texture_ref(d));
        }
        // A damaged store file is an error naming it, never a wrong texture.
        let victim = texture_path(dir.path(), &out[0].0);
        std::fs::write(&victim, crate::pack::codec::zstd_compress(b"other")).unwrap();
        let e = textures_file(&pack, dir.path()).unwrap_err().to_string();
        assert!(e.contains(&*victim.to_string_lossy()), "{e}");
    }

    #[test]
    fn every_cut_or_damaged_file_is_an_error_not_a_panic() {
        let s = VertexSubset {
            ids: vec![0, 1, 5, 300, u32::MAX],
            positions: vec![[1.0, 2.0, 3.0]; 5],
            normals: vec![[0.0, 1.0, 0.0]; 5],
            colours: vec![[9, 8, 7, 255]; 5],
        };
        let v = encode_vertices(&s);
        assert_eq!(decode_vertices(&v, Path::new("v")).unwrap(), s);
        let t = {
            let mut t = TEXTURES_MAGIC.to_vec();
            t.extend_from_slice(&1u32.to_le_bytes());
            t.extend_from_slice(&1u32.to_le_bytes());
            t.extend_from_slice(&[7; 32]);
            t.extend_from_slice(&3u32.to_le_bytes());
            t.extend_from_slice(b"abc");
            t
        };
        assert_eq!(
            decode_textures(&t, Path::new("t")).unwrap(),
            vec![([7; 32], b"abc".to_vec())]
        );
        for n in 0..v.len() {
            assert!(
                decode_vertices(&v[..n], Path::new("v")).is_err(),
                "cut at {n}"
            );
        }
        for n in 0..t.len() {
            assert!(
                decode_textures(&t[..n], Path::new("t")).is_err(),
                "cut at {n}"
            );
        }
        let mut longer = t.clone();
        longer.push(0);
        assert!(decode_textures(&longer, Path::new("t")).is_err());
        for i in 0..v.len() {
            let mut d = v.clone();
            d[i] ^= 0x80;
            let _ = decode_vertices(&d, Path::new("v")); // any answer but a panic
        }
    }

    proptest! {
        #[test]
        fn vertex_subsets_round_trip(mut ids in proptest::collection::vec(any::<u32>(), 0..200)) {
            ids.sort_unstable();
            ids.dedup();
            let n = ids.len();
            let s = VertexSubset {
                positions: (0..n).map(|i| [i as f32, -(i as f32), 0.5]).collect(),
                normals: (0..n).map(|_| [0.0, 0.0, 1.0]).collect(),
                colours: (0..n).map(|i| [i as u8, 1, 2, 255]).collect(),
                ids,
            };
            let bytes = encode_vertices(&s);
            prop_assert_eq!(bytes.len() % 4, 0);
            prop_assert_eq!(decode_vertices(&bytes, Path::new("p")).unwrap(), s);
        }
    }
}
