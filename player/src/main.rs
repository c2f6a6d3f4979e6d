//! `player`: walks through a bake (paper 000 §3.2). For now it only prints its version.

fn main() {
    println!("player {}", env!("CARGO_PKG_VERSION"));
}
