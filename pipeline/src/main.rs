//! `pipeline`: the command a user runs (`pipeline scene|run|status|report|inspect`).

fn main() {
    println!("pipeline {}", env!("CARGO_PKG_VERSION"));
}
