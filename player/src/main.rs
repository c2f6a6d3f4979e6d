//! `player`: walks through a bake (paper 000 §3.2). The renderer is issue 7; for
//! now the binary only answers `--version` / `--help`.

use clap::Parser;

#[derive(Parser)]
#[command(
    name = "player",
    version,
    about = "hexbake player (renderer not built yet: issue 7)"
)]
struct Cli {}

fn main() {
    let _cli = Cli::parse();
    println!("player {}", env!("CARGO_PKG_VERSION"));
}
