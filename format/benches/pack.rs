//! Open + decode of a cell pack of realistic size (issue 5 item 8). No bake exists
//! yet, so the pack is synthetic (format::pack::sample::synthetic_cell): 20 proxies,
//! ~60k proxy triangles (runs of real-order grid triangles), 2 MvMesh proxies with 3
//! views and 18 SvMesh with 1, 24 capture-like textures of 128² to 256². Prints the
//! bytes by section kind once, then times open (mmap + full validation: header, table,
//! every checksum) + decode of the whole cell, as time and MB/s of file.
//!
//!     cargo bench -p format --bench pack
//!
//! `HEXBAKE_BENCH_PACK=out/park-2m/cells/<id>.pack` benches a real baked cell pack
//! instead of the synthetic one.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use format::pack::{sample, CellPack, PackFile};
use std::time::Duration;

fn bench(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let (cell, path) = match std::env::var_os("HEXBAKE_BENCH_PACK") {
        Some(p) => {
            let path = std::path::PathBuf::from(p);
            (CellPack::read(&path).unwrap(), path)
        }
        None => {
            let cell = sample::synthetic_cell(20, 60_000, 10, 128);
            let path = dir.path().join("42.pack");
            cell.write(&path).unwrap();
            (cell, path)
        }
    };
    let bytes = std::fs::read(&path).unwrap();
    let textures: usize = cell.proxies.iter().map(|p| p.views.len()).sum();
    eprintln!(
        "cell {}: {} proxies, {} triangles, {textures} textures, file {} bytes",
        path.display(),
        cell.proxies.len(),
        cell.triangle_count(),
        bytes.len()
    );
    eprintln!("| section | codec | stored bytes | raw bytes | share of file |");
    eprintln!("|---|---|---|---|---|");
    let pack = PackFile::open(&path).unwrap();
    for s in pack.sections() {
        eprintln!(
            "| {} | {} | {} | {} | {:.1}% |",
            s.kind.name().unwrap_or("unknown"),
            s.codec.name(),
            s.stored_len,
            s.raw_len,
            100.0 * s.stored_len as f64 / bytes.len() as f64
        );
    }
    drop(pack);

    let mut g = c.benchmark_group("cell_pack");
    g.sample_size(20)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(4));
    g.throughput(Throughput::Bytes(bytes.len() as u64));
    g.bench_function("open_mmap_validate", |b| {
        b.iter(|| PackFile::open(&path).unwrap())
    });
    g.bench_function("open_mmap_validate_decode", |b| {
        b.iter(|| CellPack::decode(&PackFile::open(&path).unwrap()).unwrap())
    });
    g.bench_function("decode_from_memory", |b| {
        b.iter(|| CellPack::from_bytes(&bytes).unwrap())
    });
    g.bench_function("decode_and_decode_textures_to_rgba8", |b| {
        b.iter(|| {
            let c = CellPack::decode(&PackFile::open(&path).unwrap()).unwrap();
            c.proxies
                .iter()
                .flat_map(|p| &p.views)
                .map(|v| v.texture.to_rgba8().unwrap().len())
                .sum::<usize>()
        })
    });
    g.throughput(Throughput::Bytes(cell.encode().unwrap().len() as u64));
    g.sample_size(10);
    g.bench_function("encode", |b| b.iter(|| cell.encode().unwrap()));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
