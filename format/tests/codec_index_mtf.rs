//! The move-to-front triangle codec (`zstd+index-mtf`, format version 3, issue 15 item
//! 4): exact round trips for any u32 stream, clear errors on malformed pre-coded
//! input, and its size against the other index codecs on real packs (run by hand).

use format::pack::codec::{decode, encode_best, postdecode_index_mtf, precode_index_mtf};
use format::pack::Codec;
use proptest::prelude::*;

fn le(v: &[u32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

proptest! {
    /// Any u32 stream survives pre-coding and the full codec, bit for bit.
    #[test]
    fn round_trip(values in prop::collection::vec(any::<u32>(), 0..600)) {
        let raw = le(&values);
        let pre = precode_index_mtf(&raw);
        prop_assert_eq!(postdecode_index_mtf(&pre, values.len()).unwrap(), raw.clone());
        let (codec, stored) = encode_best(&raw, &[Codec::ZstdIndexMtf]);
        prop_assert_eq!(decode(codec, &stored, raw.len() as u64).unwrap(), raw);
    }

    /// Triangle lists with shared vertices (the codec's case) round-trip too.
    #[test]
    fn round_trip_strips(start in 0u32..1_000_000, n in 1usize..400, seed in any::<u64>()) {
        let mut v = Vec::new();
        let mut s = seed;
        for i in 0..n as u32 {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let a = start + i;
            v.extend_from_slice(&[a, a + 1 + (s >> 62) as u32, a + 2]);
        }
        let raw = le(&v);
        prop_assert_eq!(postdecode_index_mtf(&precode_index_mtf(&raw), v.len()).unwrap(), raw);
    }

    /// Malformed pre-coded bytes give an error, never a panic.
    #[test]
    fn hostile_precoded(bytes in prop::collection::vec(any::<u8>(), 0..200), n in 0usize..100) {
        let _ = postdecode_index_mtf(&bytes, n);
    }
}

/// A strip-ordered grid mesh whose vertices are numbered at random (as a simplified
/// mesh's surviving original vertices are, seen from its triangle order) costs well
/// under the 12 bytes per triangle of its raw list, and less than the delta codec.
#[test]
fn smaller_than_delta_on_a_grid_mesh() {
    let side = 60u32;
    let mut id: Vec<u32> = (0..side * side).collect();
    let mut s = 12345u64;
    for i in (1..id.len()).rev() {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        id.swap(i, (s >> 33) as usize % (i + 1));
    }
    let mut tris = Vec::new();
    for y in 0..side - 1 {
        for x in 0..side - 1 {
            let v = y * side + x;
            let q = [v, v + 1, v + side, v + 1, v + side + 1, v + side];
            tris.extend(q.map(|k| id[k as usize]));
        }
    }
    let raw = le(&tris);
    let (_, mtf) = encode_best(&raw, &[Codec::ZstdIndexMtf]);
    let (_, delta) = encode_best(&raw, &[Codec::ZstdDeltaU32]);
    let per_tri = mtf.len() as f64 / (tris.len() / 3) as f64;
    assert!(
        mtf.len() < delta.len(),
        "mtf {} vs delta {}",
        mtf.len(),
        delta.len()
    );
    assert!(per_tri < 3.0, "{per_tri} bytes per triangle");
}

#[test]
fn malformed_precoded_input_is_named() {
    // A code above 16.
    let e = postdecode_index_mtf(&[17], 1).unwrap_err();
    assert!(e.contains("code 17"), "{e}");
    // A new index whose delta is missing.
    let e = postdecode_index_mtf(&[16], 1).unwrap_err();
    assert!(e.contains("cut short"), "{e}");
    // A delta of more than 32 bits.
    let e = postdecode_index_mtf(&[16, 0xff, 0xff, 0xff, 0xff, 0x7f], 1).unwrap_err();
    assert!(e.contains("longer than 32 bits"), "{e}");
    // Bytes left over.
    let e = postdecode_index_mtf(&[0, 5], 1).unwrap_err();
    assert!(e.contains("left"), "{e}");
    // Fewer bytes than codes.
    let e = postdecode_index_mtf(&[0], 2).unwrap_err();
    assert!(e.contains("for 2 codes"), "{e}");
    // A frame whose content is longer than the table allows.
    let (_, stored) = encode_best(&le(&[7; 64]), &[Codec::ZstdIndexMtf]);
    assert!(decode(Codec::ZstdIndexMtf, &stored, 8).is_err());
    // A raw length that is not a multiple of 4.
    assert!(decode(Codec::ZstdIndexMtf, &stored, 7).is_err());
}

/// Bytes of each index codec on the `member-triangles` of real cell packs (run by
/// hand: `HEXBAKE_MTF_PACKS="a.pack b.pack" cargo test --release -p format --test
/// codec_index_mtf real_packs -- --ignored --nocapture`).
#[test]
#[ignore]
fn real_packs() {
    use format::pack::{PackFile, SectionKind};
    let Some(list) = std::env::var_os("HEXBAKE_MTF_PACKS") else {
        return;
    };
    let (mut tris, mut zstd, mut delta, mut mtf) = (0usize, 0usize, 0usize, 0usize);
    for path in list.to_str().unwrap().split_whitespace() {
        let pack = PackFile::open(std::path::Path::new(path)).unwrap();
        let raw = pack.section(SectionKind::MEMBER_TRIANGLES).unwrap();
        tris += raw.len() / 12;
        zstd += encode_best(&raw, &[Codec::Zstd]).1.len();
        delta += encode_best(&raw, &[Codec::ZstdDeltaU32]).1.len();
        mtf += encode_best(&raw, &[Codec::ZstdIndexMtf]).1.len();
    }
    let per = |b: usize| b as f64 / tris.max(1) as f64;
    println!(
        "{tris} triangles: zstd {zstd} B ({:.2}/tri), delta {delta} B ({:.2}/tri), mtf {mtf} B ({:.2}/tri)",
        per(zstd),
        per(delta),
        per(mtf)
    );
}
