//! The `player` binary's subcommands (issue 28: a thin `main`), one function each,
//! with its clap arguments beside it: [`render`], [`compare`], [`view`] (feature
//! `view`), [`synth`]; [`args`] holds the argument groups they share. `main.rs`
//! holds the clap entry point, refuses the replaced `HEXBAKE_*` variables and
//! dispatches; nothing here reads the environment.

pub mod args;
pub mod compare;
pub mod render;
pub mod synth;
#[cfg(feature = "view")]
pub mod view;

pub use compare::{compare, CompareArgs};
pub use render::{render, RenderArgs};
pub use synth::{synth, SynthArgs};
#[cfg(feature = "view")]
pub use view::{view, ViewArgs};
