//! Loaders on real files of every format (fetched by `scripts/fetch-models.sh`; the
//! tests that need them skip through `testkit::skip` when they are absent, or fail
//! under `HEXBAKE_REQUIRE_MODELS=1`), on hand-made files
//! with exactly known contents, and on broken files — truncated, NaN/inf, bad
//! indices — which must give errors naming the problem, never panics
//! (STYLE.md habit 5).

use format::Mesh;
use scene::load::{load_model, load_model_with_stats, LoadError, Location};
use std::path::{Path, PathBuf};

// `model(name)`: a real model file (`$HEXBAKE_MODELS`, else `<repo>/models`), or
// `None` after a skip (a failure under HEXBAKE_REQUIRE_MODELS=1) when not fetched.
use testkit::model;

/// A real model file loaded with [`load_ok`]: its path, mesh and statistics, or
/// `None` (after a skip) when it was not fetched.
#[track_caller]
fn load_fetched(name: &str) -> Option<(PathBuf, Mesh, scene::load::LoadStats)> {
    let path = model(name)?;
    let (mesh, stats) = load_ok(&path);
    Some((path, mesh, stats))
}

/// A binary STL facet: its normal, then its three corners.
type Facet = [[f32; 3]; 4];

/// The facet (0,0,0), (1,0,0), (0,1,0) facing +z.
const UNIT_FACET: Facet = [
    [0.0, 0.0, 1.0],
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
];

/// A binary STL: `title` padded with `pad` to the 80-byte header, the facet count,
/// then each facet with a zero attribute word.
fn binary_stl(title: &[u8], pad: u8, facets: &[Facet]) -> Vec<u8> {
    let mut bin = title.to_vec();
    bin.resize(80, pad);
    bin.extend_from_slice(&(facets.len() as u32).to_le_bytes());
    for facet in facets {
        for x in facet.as_flattened() {
            bin.extend_from_slice(&x.to_le_bytes());
        }
        bin.extend_from_slice(&[0, 0]);
    }
    bin
}

fn load_ok(path: &Path) -> (Mesh, scene::load::LoadStats) {
    let (mesh, stats) =
        load_model_with_stats(path).unwrap_or_else(|e| panic!("loading failed: {e}"));
    mesh.validate().unwrap();
    println!(
        "{}: {} vertices, {} triangles, {:?}",
        path.file_name().unwrap().to_string_lossy(),
        mesh.vertex_count(),
        mesh.triangle_count(),
        stats
    );
    (mesh, stats)
}

#[test]
fn bunny_obj() {
    let Some((path, mesh, stats)) = load_fetched("bunny.obj") else {
        return;
    };
    assert_eq!(stats.cleanup.input_triangles, 69_666);
    // The bunny is already welded and clean: nothing to merge or drop.
    assert_eq!(mesh.triangle_count(), 69_666);
    assert_eq!(mesh.vertex_count(), 34_835);
    assert!(mesh.edge_topology().is_closed_manifold());
    assert!(!stats.file_colors);
    // The procedural albedo varies at the scale of a few mesh edges: a checker cell
    // spans about five bunny edges, so a fifth of the edges change colour (19.8%).
    let mut differ = 0;
    for t in &mesh.triangles {
        for k in 0..3 {
            differ +=
                usize::from(mesh.albedo[t[k] as usize] != mesh.albedo[t[(k + 1) % 3] as usize]);
        }
    }
    println!(
        "bunny: {differ} of {} edges change colour",
        3 * mesh.triangle_count()
    );
    assert!(differ * 6 > 3 * mesh.triangle_count());
    // Same file, same mesh, byte for byte.
    assert_eq!(
        load_model(&path).unwrap().content_hash(),
        mesh.content_hash()
    );
}

#[test]
fn elephant_off() {
    let Some((_, mesh, _)) = load_fetched("refined_elephant.off") else {
        return;
    };
    assert_eq!(mesh.triangle_count(), 88_928);
    assert_eq!(mesh.vertex_count(), 44_460);
    assert!(mesh.edge_topology().is_closed_manifold());
    assert!(mesh.signed_volume() > 0.0, "outward winding");
}

#[test]
fn wuson_ascii_ply() {
    let Some((_, mesh, stats)) = load_fetched("wuson.ply") else {
        return;
    };
    assert_eq!(stats.cleanup.input_vertices, 11_184);
    assert_eq!(stats.cleanup.input_triangles, 3_732);
    assert_eq!(mesh.triangle_count(), 3_732);
    // The file repeats vertices per face (normals/UVs): welding merges them.
    assert_eq!(mesh.vertex_count(), 2_117);
    // The same model as STL welds to the same vertex count.
    if let Some((_, from_stl, _)) = load_fetched("wuson.stl") {
        assert_eq!(from_stl.vertex_count(), mesh.vertex_count());
        assert_eq!(from_stl.triangle_count(), mesh.triangle_count());
        assert_eq!(from_stl.bounds(), mesh.bounds());
    }
}

#[test]
fn cube_binary_ply() {
    let Some((_, mesh, _)) = load_fetched("cube_binary.ply") else {
        return;
    };
    assert_eq!(mesh.vertex_count(), 8);
    assert_eq!(mesh.triangle_count(), 12);
    assert_eq!(mesh.bounds(), Some(([0.0; 3], [1.0; 3])));
    assert!(mesh.edge_topology().is_closed_manifold());
}

#[test]
fn float_color_ply_keeps_file_colours() {
    let Some((_, mesh, stats)) = load_fetched("float-color.ply") else {
        return;
    };
    assert!(stats.file_colors);
    assert_eq!(mesh.triangle_count(), 1);
    // red 0, green 0, blue 1 (floats) → pure blue sRGB8.
    assert!(
        mesh.albedo.iter().all(|a| *a == [0, 0, 255, 255]),
        "{:?}",
        mesh.albedo
    );
}

#[test]
fn pig_binary_stl() {
    let Some(path) = model("pig.stl") else { return };
    let bytes = std::fs::read(&path).unwrap();
    let declared = u32::from_le_bytes(bytes[80..84].try_into().unwrap()) as usize;
    assert_eq!(bytes.len(), 84 + 50 * declared, "binary STL");
    let (mesh, stats) = load_ok(&path);
    assert_eq!(stats.cleanup.input_triangles, declared);
    assert_eq!(stats.cleanup.input_vertices, 3 * declared);
    // A triangle soup: welding must merge most corners.
    assert!(
        mesh.vertex_count() < declared,
        "{} vertices",
        mesh.vertex_count()
    );
}

#[test]
fn engine_glb_applies_node_transforms() {
    let Some((path, mesh, stats)) = load_fetched("2CylinderEngine.glb") else {
        return;
    };
    assert!(stats.nodes > 1, "several nodes contribute: {}", stats.nodes);
    assert!(stats.file_colors, "material base colours");
    // Without node transforms the parts would sit within their accessors' bounds;
    // compare with the union of raw POSITION bounds.
    let gltf = gltf::Gltf::open(&path).unwrap();
    let mut raw_lo = [f32::INFINITY; 3];
    let mut raw_hi = [f32::NEG_INFINITY; 3];
    for m in gltf.document.meshes() {
        for p in m.primitives() {
            let b = p.bounding_box();
            for k in 0..3 {
                raw_lo[k] = raw_lo[k].min(b.min[k]);
                raw_hi[k] = raw_hi[k].max(b.max[k]);
            }
        }
    }
    let (lo, hi) = mesh.bounds().unwrap();
    assert_ne!((lo, hi), (raw_lo, raw_hi), "transforms applied");
}

#[test]
fn milk_truck_glb() {
    let Some((_, mesh, stats)) = load_fetched("CesiumMilkTruck.glb") else {
        return;
    };
    assert!(stats.nodes > 1, "truck body and wheels: {}", stats.nodes);
    assert!(mesh.triangle_count() > 1000);
    assert_eq!(stats.parts, 5, "body (3 primitives) + the wheel mesh twice");
    // The wheels are one mesh (radius 0.428, centred on the origin) placed by two
    // nodes at (1.486, 0.168, 0) and (-1.256, 0.659, 0): the lowest points are the
    // front wheel's (the body starts at y = 0.267), and the rear wheel reaches below
    // the body near x = -1.256. Untransformed wheels would sit around the origin.
    let below_body: Vec<&[f32; 3]> = mesh.positions.iter().filter(|p| p[1] < 0.26).collect();
    assert!(!below_body.is_empty());
    for p in &below_body {
        let front = (p[0] - 1.4856).hypot(p[1] - 0.1685) < 0.43;
        let rear = (p[0] + 1.2558).hypot(p[1] - 0.6594) < 0.43;
        assert!(front || rear, "{p:?} is on neither placed wheel");
    }
    assert!(below_body.iter().any(|p| p[1] < -0.2), "front wheel bottom");
    assert!(
        below_body.iter().any(|p| (p[0] + 1.2558).abs() < 0.2),
        "rear wheel bottom"
    );
}

fn expect_error(path: &Path) -> LoadError {
    match load_model(path) {
        Ok(m) => panic!(
            "{} loaded ({} triangles) but must fail",
            path.display(),
            m.triangle_count()
        ),
        Err(e) => {
            println!("{e}");
            assert!(e.to_string().contains(&path.display().to_string()), "{e}");
            e
        }
    }
}

#[test]
fn glb_with_infinities_is_rejected() {
    let Some(path) = model("BoxWithInfinites.glb") else {
        return;
    };
    let e = expect_error(&path);
    assert!(e.to_string().contains("non-finite"), "{e}");
    assert!(matches!(e.location(), Location::Element(v) if v.starts_with("vertex")));
}

#[test]
fn gltf_with_index_out_of_range_is_rejected() {
    for name in [
        "IndexOutOfRange/IndexOutOfRange.gltf",
        "IndexOutOfRange/AllIndicesOutOfRange.gltf",
    ] {
        let Some(path) = model(name) else { return };
        let e = expect_error(&path);
        assert!(e.to_string().contains("uses vertex"), "{e}");
        assert!(matches!(e.location(), Location::Element(v) if v.contains("primitive")));
    }
}

// ---------------------------------------------------------------------------------
// Hand-made files.

fn write(dir: &Path, name: &str, contents: &[u8]) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, contents).unwrap();
    path
}

const TETRA_OFF: &str =
    "OFF\n# a tetrahedron\n4 4 6\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";

#[test]
fn off_tetrahedron_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "t.off", TETRA_OFF.as_bytes());
    let (mesh, _) = load_ok(&path);
    assert_eq!(
        mesh.positions,
        [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0]
        ]
    );
    assert_eq!(mesh.triangles, [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]);
    assert!(mesh.edge_topology().is_closed_manifold());
    assert!((mesh.signed_volume() - 1.0 / 6.0).abs() < 1e-9);
    // Smooth normal at the origin: the sum of three axis faces (areas ½ each).
    let s = 1.0 / 3f32.sqrt();
    for k in 0..3 {
        assert!(
            (mesh.normals[0][k] + s).abs() < 1e-6,
            "{:?}",
            mesh.normals[0]
        );
    }
}

#[test]
fn off_quads_colours_welding_and_degenerates() {
    // A unit square as a quad, drawn twice (duplicate), plus a vertex duplicated at
    // the same position (welded), a zero-area face and a COFF colour per vertex.
    let text = "COFF\n6 4 0\n0 0 0 255 0 0\n1 0 0 255 0 0\n1 0 1 255 0 0\n0 0 1 255 0 0\n\
                1 0 0 255 0 0\n2 0 0 0 0 255\n\
                4 0 3 2 1\n4 0 3 2 4\n3 0 1 5\n3 0 4 1\n";
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "q.off", text.as_bytes());
    let (mesh, stats) = load_ok(&path);
    assert!(stats.file_colors);
    assert_eq!(stats.cleanup.welded_vertices, 1);
    assert_eq!(stats.cleanup.duplicate_triangles, 2);
    assert_eq!(
        stats.cleanup.degenerate_triangles, 2,
        "collinear and repeated-index faces"
    );
    assert_eq!(stats.cleanup.unreferenced_vertices, 1);
    assert_eq!(mesh.triangle_count(), 2);
    assert_eq!(mesh.vertex_count(), 4);
    assert!(mesh.albedo.iter().all(|a| *a == [255, 0, 0, 255]));
    assert!(
        mesh.normals.iter().all(|n| *n == [0.0, 1.0, 0.0]),
        "{:?}",
        mesh.normals
    );
}

#[test]
fn off_with_nan_names_the_line() {
    let text = TETRA_OFF.replace("1 0 0\n", "1 nan 0\n");
    let dir = tempfile::tempdir().unwrap();
    let e = expect_error(&write(dir.path(), "nan.off", text.as_bytes()));
    assert_eq!(e.location(), Location::Line(5), "{e}");
    assert!(
        e.to_string()
            .contains("vertex 1 has a non-finite coordinate"),
        "{e}"
    );
}

#[test]
fn off_with_bad_index_names_the_line() {
    let text = TETRA_OFF.replace("3 1 2 3\n", "3 1 2 4\n");
    let dir = tempfile::tempdir().unwrap();
    let e = expect_error(&write(dir.path(), "bad.off", text.as_bytes()));
    assert_eq!(e.location(), Location::Line(11), "{e}");
    assert!(e.to_string().contains("face 3 uses vertex 4"), "{e}");
}

#[test]
fn obj_with_nan_names_the_vertex() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 NaN 0\nf 1 2 3\n";
    let dir = tempfile::tempdir().unwrap();
    let e = expect_error(&write(dir.path(), "nan.obj", text.as_bytes()));
    assert!(
        e.to_string()
            .contains("vertex 2 has a non-finite coordinate"),
        "{e}"
    );
    let text = "v 0 0 0\nv 1 0 0\nv 0 inf 0\nf 1 2 3\n";
    let e = expect_error(&write(dir.path(), "inf.obj", text.as_bytes()));
    assert!(e.to_string().contains("non-finite"), "{e}");
}

/// Issue 19: finite but absurd coordinates (beyond ±1e12 file units) are refused,
/// naming the file and the vertex (the line too, where the format has lines the
/// loader reads itself).
#[test]
fn absurd_coordinates_name_the_file_and_the_vertex() {
    let dir = tempfile::tempdir().unwrap();
    let text = "v 0 0 0\nv 1 0 0\nv 0 3e38 0\nf 1 2 3\n";
    let path = write(dir.path(), "far.obj", text.as_bytes());
    let e = expect_error(&path);
    assert_eq!(e.location(), Location::Element("vertex 2".into()), "{e}");
    let shown = e.to_string();
    assert!(shown.starts_with(&path.display().to_string()), "{shown}");
    assert!(
        shown.contains("vertex 2 has a coordinate beyond"),
        "{shown}"
    );

    let text = TETRA_OFF.replace("0 0 1\n", "0 0 -2e12\n");
    let e = expect_error(&write(dir.path(), "far.off", text.as_bytes()));
    assert_eq!(e.location(), Location::Line(7), "{e}");
    assert!(
        e.to_string().contains("vertex 3 has a coordinate beyond"),
        "{e}"
    );

    // A binary STL: the clean-up names the vertex after welding's input order.
    let bin = binary_stl(
        b"",
        b' ',
        &[[
            [0.0, 0.0, 1.0],
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1e30, 0.0],
        ]],
    );
    let e = expect_error(&write(dir.path(), "far.stl", &bin));
    assert_eq!(e.location(), Location::Element("vertex 2".into()), "{e}");
    // 1e12 itself is allowed.
    let text = "v 0 0 0\nv 1e12 0 0\nv 0 1 0\nf 1 2 3\n";
    load_ok(&write(dir.path(), "edge.obj", text.as_bytes()));
}

#[test]
fn obj_with_bad_index_is_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n";
    expect_error(&write(dir.path(), "bad.obj", text.as_bytes()));
}

#[test]
fn obj_quads_are_triangulated_with_colours() {
    let dir = tempfile::tempdir().unwrap();
    let text = "o quad\nv 0 0 0 1 0 0\nv 1 0 0 1 0 0\nv 1 1 0 1 0 0\nv 0 1 0 1 0 0\nf 1 2 3 4\n";
    let (mesh, stats) = load_ok(&write(dir.path(), "quad.obj", text.as_bytes()));
    assert_eq!(mesh.triangle_count(), 2);
    assert!(stats.file_colors);
    assert!(mesh.albedo.iter().all(|a| *a == [255, 0, 0, 255]));
    assert!(mesh.normals.iter().all(|n| *n == [0.0, 0.0, 1.0]));
}

#[test]
fn ascii_stl_and_binary_stl_with_solid_header() {
    let dir = tempfile::tempdir().unwrap();
    let ascii = "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n";
    let (mesh, _) = load_ok(&write(dir.path(), "a.stl", ascii.as_bytes()));
    assert_eq!(mesh.triangle_count(), 1);
    // A binary STL whose header starts with "solid " (as many exporters write).
    let bin = binary_stl(b"solid but binary", b' ', &[UNIT_FACET]);
    let (mesh, _) = load_ok(&write(dir.path(), "b.stl", &bin));
    assert_eq!(
        mesh.positions,
        [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    );
}

/// A glTF with one triangle mesh used by three nodes: a root translated by
/// (10, 0, 0) with a child scaled ×2, and a mirrored sibling; checks every world
/// position and that the mirrored copy keeps its outward winding.
#[test]
fn gltf_node_transforms_compose() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Vec::new();
    for v in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        for x in v {
            bin.extend_from_slice(&x.to_le_bytes());
        }
    }
    for i in [0u16, 1, 2, 0] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    std::fs::write(dir.path().join("t.bin"), &bin).unwrap();
    let json = r#"{
      "asset": {"version": "2.0"},
      "scene": 0,
      "scenes": [{"nodes": [0, 2]}],
      "nodes": [
        {"mesh": 0, "translation": [10, 0, 0], "children": [1]},
        {"mesh": 0, "scale": [2, 2, 2], "translation": [0, 0, 5]},
        {"mesh": 0, "scale": [-1, 1, 1], "translation": [0, 0, -5]}
      ],
      "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
      "buffers": [{"uri": "t.bin", "byteLength": 44}],
      "bufferViews": [
        {"buffer": 0, "byteOffset": 0, "byteLength": 36},
        {"buffer": 0, "byteOffset": 36, "byteLength": 6}
      ],
      "accessors": [
        {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
         "min": [0, 0, 0], "max": [1, 1, 0]},
        {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}
      ]
    }"#;
    let path = write(dir.path(), "t.gltf", json.as_bytes());
    let (mesh, stats) = load_ok(&path);
    assert_eq!(stats.nodes, 3);
    assert_eq!(mesh.triangle_count(), 3);
    let tri = |t: usize| mesh.triangles[t].map(|i| mesh.positions[i as usize]);
    assert_eq!(
        tri(0),
        [[10.0, 0.0, 0.0], [11.0, 0.0, 0.0], [10.0, 1.0, 0.0]]
    );
    // Child: parent translation ∘ (translate (0,0,5) ∘ scale 2).
    assert_eq!(
        tri(1),
        [[10.0, 0.0, 5.0], [12.0, 0.0, 5.0], [10.0, 2.0, 5.0]]
    );
    // Mirrored in x: winding flipped so the face still points +z.
    let t = tri(2);
    assert!(t.contains(&[-1.0, 0.0, -5.0]) && t.contains(&[0.0, 1.0, -5.0]));
    let n = mesh.normals[mesh.triangles[2][0] as usize];
    assert_eq!(n, [0.0, 0.0, 1.0]);
    assert_eq!(mesh.normals[mesh.triangles[0][0] as usize], [0.0, 0.0, 1.0]);
    // Truncated JSON, or a buffer shorter than declared, are errors.
    for cut in [0, 1, json.len() / 3, json.len() / 2, json.len() - 2] {
        expect_error(&write(dir.path(), "cut.gltf", &json.as_bytes()[..cut]));
    }
    std::fs::write(dir.path().join("t.bin"), &bin[..30]).unwrap();
    expect_error(&path);
    // A missing buffer file is an error, not a panic.
    std::fs::remove_file(dir.path().join("t.bin")).unwrap();
    expect_error(&path);
}

#[test]
fn unsupported_and_missing_files_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let e = expect_error(&write(dir.path(), "x.fbx", b"whatever"));
    assert!(matches!(e, LoadError::Unsupported { .. }));
    let e = expect_error(&dir.path().join("missing.obj"));
    assert!(matches!(e, LoadError::Io { .. }));
}

// ---------------------------------------------------------------------------------
// Truncated files.

/// Loads `bytes` cut at many lengths: each cut must give an error or a valid mesh
/// (a text file may end at a line boundary), never a panic escaping the loader;
/// cuts in `must_fail` must give an error. Returns how many cuts were errors.
fn truncations(name: &str, bytes: &[u8], must_fail: &[usize]) -> usize {
    let dir = tempfile::tempdir().unwrap();
    let len = bytes.len();
    let mut cuts: Vec<usize> = vec![0, 1, 2, 5, 11, 40, 80, 83, 84, 100, 134, 200, 512];
    cuts.extend([
        len / 7,
        len / 3,
        len / 2,
        2 * len / 3,
        len - len / 50,
        len - 2,
        len - 1,
    ]);
    cuts.extend_from_slice(must_fail);
    cuts.retain(|&c| c < len);
    cuts.sort_unstable();
    cuts.dedup();
    let mut errors = 0;
    for cut in cuts {
        let path = write(dir.path(), name, &bytes[..cut]);
        match load_model(&path) {
            Ok(mesh) => {
                mesh.validate().unwrap();
                assert!(
                    !must_fail.contains(&cut),
                    "{name} cut at {cut}/{len} loaded"
                );
            }
            Err(e) => {
                errors += 1;
                assert!(
                    !matches!(e, LoadError::ParserPanic { .. }),
                    "{name} cut at {cut}: parser panicked: {e}"
                );
            }
        }
    }
    errors
}

#[test]
fn truncated_files_are_errors_not_panics() {
    let real = [
        ("cube_binary.ply", "t.ply"),
        ("wuson.ply", "t.ply"),
        ("pig.stl", "t.stl"),
        ("wuson.stl", "t.stl"),
        ("CesiumMilkTruck.glb", "t.glb"),
        ("refined_elephant.off", "t.off"),
        ("bunny.obj", "t.obj"),
    ];
    for (file, name) in real {
        let Some(path) = model(file) else { continue };
        let bytes = std::fs::read(&path).unwrap();
        let len = bytes.len();
        // Formats with counts must notice any cut in the middle.
        let must_fail: Vec<usize> = if name.ends_with(".obj") {
            vec![0]
        } else {
            vec![0, 1, len / 3, len / 2, 2 * len / 3]
        };
        let errors = truncations(name, &bytes, &must_fail);
        println!("{file}: {errors} of the cuts were errors");
    }
    // Hand-made files of every format, always available.
    let errors = truncations("t.off", TETRA_OFF.as_bytes(), &[0, 10, 30, 50]);
    assert!(errors >= 4);
    for (name, bytes) in hostile::seeds() {
        let len = bytes.len();
        let must_fail = if name.ends_with(".obj") {
            vec![0]
        } else {
            vec![0, len / 2, len - 3]
        };
        let errors = truncations(name, &bytes, &must_fail);
        assert!(errors >= must_fail.len(), "{name}: {errors}");
    }
}

mod hostile {
    use super::*;
    use proptest::prelude::*;

    /// Small valid files of every format, to mutate.
    pub(super) fn seeds() -> Vec<(&'static str, Vec<u8>)> {
        let stl = binary_stl(b"binary", 0, &[UNIT_FACET; 2]);
        let ply_ascii = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
                         property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n\
                         element face 2\nproperty list uchar int vertex_indices\nend_header\n\
                         0 0 0 255 0 0\n1 0 0 0 255 0\n1 1 0 0 0 255\n0 1 0 9 9 9\n3 0 1 2\n3 0 2 3\n";
        let mut ply_bin =
            b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n\
                            property float y\nproperty float z\nelement face 1\n\
                            property list uchar int vertex_indices\nend_header\n"
                .to_vec();
        for x in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
            ply_bin.extend_from_slice(&x.to_le_bytes());
        }
        ply_bin.push(3);
        for i in [0i32, 1, 2] {
            ply_bin.extend_from_slice(&i.to_le_bytes());
        }
        vec![
            ("m.off", TETRA_OFF.as_bytes().to_vec()),
            (
                "m.obj",
                b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
                    .to_vec(),
            ),
            ("m.stl", stl),
            ("m.ply", ply_ascii.as_bytes().to_vec()),
            ("m.ply", ply_bin),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(96))]

        /// Random byte edits of valid files: the loader returns (a valid mesh or an
        /// error) and never lets a panic escape.
        #[test]
        fn mutated_files_never_escape(
            which in 0usize..5,
            edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..6),
            cut in any::<prop::sample::Index>(),
            do_cut in any::<bool>(),
        ) {
            let (name, mut bytes) = seeds().swap_remove(which);
            for (at, value) in edits {
                let i = at.index(bytes.len());
                bytes[i] = value;
            }
            if do_cut {
                bytes.truncate(cut.index(bytes.len() + 1));
            }
            let dir = tempfile::tempdir().unwrap();
            let path = write(dir.path(), name, &bytes);
            if let Ok(mesh) = load_model(&path) {
                prop_assert!(mesh.validate().is_ok());
            }
        }
    }
}

/// A glTF file of 12 vertices and `count` u16 indices (i mod 12) in TRIANGLES mode,
/// whose index view holds `view_indices` of them; the buffer beside it.
fn gltf_with_indices(dir: &Path, count: usize, view_indices: usize) -> PathBuf {
    let mut bin: Vec<u8> = Vec::new();
    for k in 0..12u32 {
        let a = k as f32 * 0.5;
        for c in [a.cos(), (k % 3) as f32, a.sin()] {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    let positions_len = bin.len();
    for i in 0..view_indices {
        bin.extend_from_slice(&((i % 12) as u16).to_le_bytes());
    }
    std::fs::write(dir.join("b.bin"), &bin).unwrap();
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
        "nodes":[{{"mesh":0}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1,"mode":4}}]}}],
        "buffers":[{{"uri":"b.bin","byteLength":{total}}}],
        "bufferViews":[{{"buffer":0,"byteLength":{positions_len}}},
                       {{"buffer":0,"byteOffset":{positions_len},"byteLength":{index_len}}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":12,"type":"VEC3",
                       "min":[-1,0,-1],"max":[1,2,1]}},
                     {{"bufferView":1,"componentType":5123,"count":{count},"type":"SCALAR"}}]}}"#,
        total = bin.len(),
        index_len = 2 * view_indices,
    );
    write(dir, "m.gltf", json.as_bytes())
}

/// Issue 32 item 4: an index accessor longer than its buffer view was read as the
/// triangles that fit (2 of 12); a TRIANGLES count that is not a multiple of 3 lost
/// its tail. Both are refused, naming the accessor or the count.
#[test]
fn gltf_accessors_are_checked_against_their_views() {
    let dir = tempfile::tempdir().unwrap();
    // 36 indices i mod 12: four triangles, each listed three times (the clean-up
    // keeps one of each).
    let (mesh, _) = load_ok(&gltf_with_indices(dir.path(), 36, 36));
    assert_eq!(mesh.triangle_count(), 4);

    let e = expect_error(&gltf_with_indices(dir.path(), 36, 6));
    assert!(
        e.to_string()
            .contains("need 72 bytes of bufferView 1, which has 12"),
        "{e}"
    );
    assert!(matches!(e.location(), Location::Element(v) if v == "accessor 1"));

    let e = expect_error(&gltf_with_indices(dir.path(), 35, 35));
    assert!(e.to_string().contains("35 indices"), "{e}");
}
