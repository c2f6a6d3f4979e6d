//! The JSON files hexbake writes besides its packs, one definition each, used by
//! their writers and readers (STYLE.md habit 14): the compare report ([`compare`]).

pub mod compare;
