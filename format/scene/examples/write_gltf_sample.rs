//! Writes the textured sample glTF scene (`scene::load::gltf_sample`) into a folder:
//! the seed corpus of the `gltf_scene` fuzz target (`scripts/fuzz.sh`) and a worked
//! example of what `scene: Gltf(..)` reads.
//!
//!   cargo run -p scene --example write_gltf_sample -- DIR

fn main() {
    let dir = std::env::args().nth(1).unwrap_or_else(|| ".".into());
    let path = scene::load::gltf_sample::write_textured_sample(std::path::Path::new(&dir))
        .unwrap_or_else(|e| {
            eprintln!("write_gltf_sample: {dir}: {e}");
            std::process::exit(1)
        });
    println!("{}", path.display());
}
