fn main() {
    for a in std::env::args().skip(1) {
        let t = std::time::Instant::now();
        match format::load::load_model_with_stats(std::path::Path::new(&a)) {
            Ok((m, s)) => println!(
                "{a}: {} v {} t {:?} bounds {:?} {:.2}s valid={:?} topo={:?}",
                m.vertex_count(),
                m.triangle_count(),
                s,
                m.bounds(),
                t.elapsed().as_secs_f32(),
                m.validate(),
                m.edge_topology()
            ),
            Err(e) => println!("{a}: ERR {e}"),
        }
    }
    for n in format::procedural::NAMES {
        let m = format::procedural::build(n).unwrap();
        println!(
            "{n}: {} v {} t vol {} topo {:?} valid {:?}",
            m.vertex_count(),
            m.triangle_count(),
            m.signed_volume(),
            m.edge_topology(),
            m.validate()
        );
    }
}
