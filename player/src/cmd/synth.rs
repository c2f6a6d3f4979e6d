//! `player synth`: writes a synthetic bake of `manifests/demo.ron`'s park
//! ([`crate::testdata::write_synthetic_bake`]) for trying the player without a bake.

use crate::run::RunError;
use std::path::PathBuf;

// The argument of `player synth`.
#[derive(clap::Args, Clone)]
pub struct SynthArgs {
    pub out: PathBuf,
}

/// Writes the synthetic bake into `args.out` and prints its size.
pub fn synth(args: SynthArgs) -> Result<(), RunError> {
    let out = args.out;
    let b = crate::testdata::write_synthetic_bake(&out).map_err(|e| RunError::Write {
        path: out.clone(),
        what: e.to_string(),
    })?;
    println!(
        "{}: {} cells, {} instances, {} triangles",
        out.display(),
        b.cells,
        b.instances,
        b.triangles
    );
    Ok(())
}
