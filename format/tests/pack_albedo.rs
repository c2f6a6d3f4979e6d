//! Base-pack sections `albedo-textures` (0x0109) and `texcoords` (0x010A) of
//! textured models (issue 18; layouts in format/README.md): golden section bytes,
//! round trips, untextured packs without the sections, and hostile content.

use format::pack::layout::{FileKind, SectionKind};
use format::pack::writer::{assemble, SectionData};
use format::pack::{sample, BasePack, PackFile};

fn textured_base() -> BasePack {
    sample::small_base_textured()
}

fn section(bytes: &[u8], kind: SectionKind) -> Vec<u8> {
    PackFile::from_bytes(bytes)
        .unwrap()
        .section(kind)
        .unwrap()
        .into_owned()
}

#[test]
fn golden_section_bytes() {
    let bytes = textured_base().encode().unwrap();
    // albedo-textures: count 1, reserved, (2, 1, wrap 0, wrap 2), 8 bytes of texels:
    // the shared texture is stored once.
    let mut expected = Vec::new();
    for v in [1u32, 0, 2, 1, 0, 2] {
        expected.extend_from_slice(&v.to_le_bytes());
    }
    expected.extend_from_slice(&[255, 0, 0, 255, 0, 0, 255, 255]);
    assert_eq!(section(&bytes, SectionKind::ALBEDO_TEXTURES), expected);
    // texcoords: count 2, reserved, (model 0, texture 0), (model 1, texture 0), UVs.
    let t = section(&bytes, SectionKind::TEXCOORDS);
    let head: Vec<u32> = t[..24]
        .chunks(4)
        .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    assert_eq!(head, [2, 0, 0, 0, 1, 0]);
    let n0 = sample::small_base().models[0].mesh.vertex_count();
    let n1 = sample::small_base().models[1].mesh.vertex_count();
    assert_eq!(t.len(), 24 + 8 * (n0 + n1));
    assert_eq!(&t[24..32], bytemuck::cast_slice::<f32, u8>(&[0.0, 1.0]));
    assert_eq!(&t[32..40], bytemuck::cast_slice::<f32, u8>(&[0.5, 1.0]));
}

#[test]
fn textured_packs_round_trip_and_untextured_packs_have_no_texture_sections() {
    let base = textured_base();
    let bytes = base.encode().unwrap();
    assert_eq!(BasePack::from_bytes(&bytes).unwrap(), base);
    let plain = sample::small_base().encode().unwrap();
    let pack = PackFile::from_bytes(&plain).unwrap();
    assert!(pack.section_info(SectionKind::ALBEDO_TEXTURES).is_none());
    assert!(pack.section_info(SectionKind::TEXCOORDS).is_none());
    // A reader that drops the two sections (as one that does not know them skips
    // them) gets the untextured models.
    let pack = PackFile::from_bytes(&bytes).unwrap();
    let kept: Vec<SectionData> = pack
        .sections()
        .iter()
        .filter(|s| s.kind != SectionKind::ALBEDO_TEXTURES && s.kind != SectionKind::TEXCOORDS)
        .map(|s| SectionData::new(s.kind, pack.section(s.kind).unwrap().into_owned(), &[]))
        .collect();
    let stripped = assemble(FileKind::Base, &kept).unwrap();
    assert_eq!(
        BasePack::from_bytes(&stripped).unwrap(),
        sample::small_base()
    );
}

/// The pack with section `kind`'s content replaced by `edit(content)`.
fn with_section(bytes: &[u8], kind: SectionKind, edit: impl Fn(&mut Vec<u8>)) -> Vec<u8> {
    let pack = PackFile::from_bytes(bytes).unwrap();
    let sections: Vec<SectionData> = pack
        .sections()
        .iter()
        .map(|s| {
            let mut raw = pack.section(s.kind).unwrap().into_owned();
            if s.kind == kind {
                edit(&mut raw);
            }
            SectionData {
                kind: s.kind,
                raw,
                codecs: &[],
            }
        })
        .collect();
    assemble(FileKind::Base, &sections).unwrap()
}

#[test]
fn hostile_texture_sections_are_rejected_with_the_section_named() {
    let bytes = textured_base().encode().unwrap();
    let t = SectionKind::ALBEDO_TEXTURES;
    let c = SectionKind::TEXCOORDS;
    let set = |off: usize, v: u32| {
        move |raw: &mut Vec<u8>| raw[off..off + 4].copy_from_slice(&v.to_le_bytes())
    };
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        (
            "texture count",
            with_section(&bytes, t, set(0, 2)),
            "albedo-textures",
        ),
        ("reserved", with_section(&bytes, t, set(4, 1)), "reserved"),
        ("zero width", with_section(&bytes, t, set(8, 0)), "sides"),
        (
            "huge width",
            with_section(&bytes, t, set(8, u32::MAX)),
            "sides",
        ),
        ("wrap code", with_section(&bytes, t, set(16, 9)), "wrap"),
        (
            "trailing texel",
            with_section(&bytes, t, |r| r.push(0)),
            "trailing",
        ),
        (
            "short texels",
            with_section(&bytes, t, |r| {
                r.pop();
            }),
            "texels",
        ),
        (
            "truncated header",
            with_section(&bytes, t, |r| r.truncate(5)),
            "header",
        ),
        ("uv count", with_section(&bytes, c, set(0, 3)), "texcoords"),
        (
            "model order",
            with_section(&bytes, c, set(16, 0)),
            "increasing",
        ),
        (
            "model range",
            with_section(&bytes, c, set(16, 99)),
            "increasing",
        ),
        (
            "texture ref",
            with_section(&bytes, c, set(12, 5)),
            "texture 5",
        ),
        (
            "nan uv",
            with_section(&bytes, c, set(24, f32::NAN.to_bits())),
            "not finite",
        ),
        (
            "short uvs",
            with_section(&bytes, c, |r| r.truncate(r.len() - 8)),
            "left",
        ),
        (
            "trailing uv",
            with_section(&bytes, c, |r| r.extend_from_slice(&[0; 8])),
            "trailing",
        ),
    ];
    for (what, pack, needle) in cases {
        let e = BasePack::from_bytes(&pack).unwrap_err().to_string();
        assert!(e.contains(needle), "{what}: {e}");
    }
    // One section without the other.
    let pack = PackFile::from_bytes(&bytes).unwrap();
    let without_uvs: Vec<SectionData> = pack
        .sections()
        .iter()
        .filter(|s| s.kind != c)
        .map(|s| SectionData::new(s.kind, pack.section(s.kind).unwrap().into_owned(), &[]))
        .collect();
    let e = BasePack::from_bytes(&assemble(FileKind::Base, &without_uvs).unwrap())
        .unwrap_err()
        .to_string();
    assert!(e.contains("companion"), "{e}");
}

#[test]
fn the_writer_refuses_what_the_reader_would() {
    type Edit = fn(&mut BasePack);
    let edits: [(Edit, &str); 3] = [
        (
            |b| {
                b.models[0].albedo_map.as_mut().unwrap().uvs.pop();
            },
            "texture coordinates",
        ),
        (
            |b| b.models[0].albedo_map.as_mut().unwrap().uvs[0] = [f32::INFINITY, 0.0],
            "not finite",
        ),
        (
            |b| {
                b.models[1].albedo_map.as_mut().unwrap().texture.rgba.pop();
            },
            "RGBA8",
        ),
    ];
    for (edit, says) in edits {
        let mut base = textured_base();
        edit(&mut base);
        let e = base.encode().unwrap_err().to_string();
        assert!(e.contains(says), "expected {says:?} in: {e}");
    }
}

#[test]
fn random_bytes_in_the_texture_sections_never_panic() {
    let bytes = textured_base().encode().unwrap();
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    for kind in [SectionKind::ALBEDO_TEXTURES, SectionKind::TEXCOORDS] {
        for _ in 0..300 {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let s = state;
            let pack = with_section(&bytes, kind, |raw| {
                let i = (s >> 33) as usize % raw.len();
                raw[i] = (s >> 13) as u8;
            });
            let _ = BasePack::from_bytes(&pack);
        }
    }
}
