//! Fuzz target: the cell-pack reader on arbitrary bytes, then on the same bytes with
//! their checksums resealed (so mutations reach the content validation). Any panic,
//! overflow or out-of-bounds access is a bug: readers must return `PackError`.
#![no_main]

use format::pack::{sample, CellPack};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| sample::exercise_reader(data, CellPack::from_bytes));
