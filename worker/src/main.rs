//! `worker`: runs one job of a manifest (what a Slurm array task calls) and the
//! per-cell diagnostic commands.

fn main() {
    println!("worker {}", env!("CARGO_PKG_VERSION"));
}
