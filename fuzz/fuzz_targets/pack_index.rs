//! Fuzz target: the index-pack reader on arbitrary bytes, then on the same bytes with
//! their checksums resealed (so mutations reach the content validation). Any panic,
//! overflow or out-of-bounds access is a bug: readers must return `PackError`.
#![no_main]

use format::pack::{sample, Index, PackFile};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = Index::from_bytes(data);
    if let Ok(pack) = PackFile::from_bytes(data) {
        for s in pack.sections() {
            let _ = pack.section(s.kind);
        }
    }
    let mut resealed = data.to_vec();
    if sample::reseal(&mut resealed) {
        let _ = Index::from_bytes(&resealed);
    }
    // Structure-aware (issue 19): a decoded field set to an interesting value, the
    // pack re-assembled with valid checksums.
    let pick = data.iter().fold(0u64, |h, &b| h.rotate_left(5) ^ u64::from(b));
    if let Some(edited) = sample::mutate_decoded(data, pick) {
        let _ = Index::from_bytes(&edited);
    }
});
