//! glTF files read as scenes (issue 18 item 1): node transforms, mesh reuse,
//! base-colour textures with their UVs and wrap modes, refusals and notes.

use format::albedo::Wrap;
use format::manifest::{parse_manifest_str, SceneSpec};
use glam::{Mat3, Vec3};
use scene::load::gltf_sample::{sample_texture, write_textured_sample};
use scene::load::load_gltf_scene;

#[test]
fn sample_scene_reuses_meshes_and_reads_textures() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_textured_sample(dir.path()).unwrap();
    let scene = load_gltf_scene(&path).unwrap();
    // Three nodes use one two-primitive mesh: textured + plain, direct + mirrored.
    // The node scaled 1.5 shares the models of the unscaled one (issue 29).
    let names: Vec<&str> = scene.models.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "crate-textured",
            "crate-plain",
            "crate-textured-mirrored",
            "crate-plain-mirrored"
        ]
    );
    assert_eq!(scene.instances.len(), 6);
    let models: Vec<u32> = scene.instances.iter().map(|i| i.model).collect();
    assert_eq!(models, [0, 1, 0, 1, 2, 3]);
    // Composed transforms, the uniform scale in the instance: node b (scaled 1.5,
    // rotated) is a scaled rotation of the unscaled crate.
    let b = scene.instances[2].transform;
    assert!((b.w_axis.truncate() - Vec3::new(4.0, 0.0, 0.5)).length() < 1e-6);
    assert!((Mat3::from_mat4(b).determinant() - 1.5f32.powi(3)).abs() < 1e-4);
    // The mirror is in the model, not the instance transform.
    assert!((Mat3::from_mat4(scene.instances[4].transform).determinant() - 1.0).abs() < 1e-4);
    let (lo, hi) = scene.models[0].mesh.bounds().unwrap();
    assert!((hi[1] - lo[1] - 2.0).abs() < 1e-5, "the crate is 2 tall");
    // The textured model: UVs per vertex (seams kept), the texture
    // with the sampler's wrap modes, the factor in the vertex albedo. The cube's 24
    // face corners weld only where position and UV agree (4 corners do): 20.
    let textured = &scene.models[0];
    let map = textured.albedo_map.as_ref().expect("textured");
    assert_eq!(textured.mesh.vertex_count(), 20);
    assert_eq!(map.uvs.len(), 20);
    assert_eq!(map.texture.width, 16);
    assert_eq!(map.texture.rgba, sample_texture());
    assert_eq!(map.texture.wrap, [Wrap::Repeat, Wrap::MirroredRepeat]);
    let srgb = |l: f32| format::srgb::linear_to_srgb_powf(l);
    assert_eq!(textured.mesh.albedo[0], [255, srgb(0.9), srgb(0.8), 255]);
    assert!(scene.models[1].albedo_map.is_none());
    assert_eq!(
        scene.models[1].mesh.albedo[0],
        [srgb(0.8), srgb(0.1), srgb(0.1), 255]
    );
    // Mirrored copies: x negated, winding flipped.
    let mirrored = &scene.models[2];
    let negated: Vec<[f32; 3]> = textured
        .mesh
        .positions
        .iter()
        .map(|p| [-p[0], p[1], p[2]])
        .collect();
    assert_eq!(mirrored.mesh.positions, negated);
    let t = textured.mesh.triangles[0];
    assert_eq!(mirrored.mesh.triangles[0], [t[0], t[2], t[1]]);
    assert!(scene.notes.is_empty(), "{:?}", scene.notes);
}

#[test]
fn manifest_gltf_scene_builds_with_hashes_that_cover_the_texture() {
    let dir = tempfile::tempdir().unwrap();
    write_textured_sample(dir.path()).unwrap();
    let manifest = dir.path().join("m.ron");
    let text = r#"(
        ground: (min: (-10.0, -10.0), max: (10.0, 10.0)),
        scene: Gltf("textured-sample.gltf"),
        cells: (cell_size: 5.0, min_eye_height: 1.0, max_eye_height: 2.0),
    )"#;
    let plan = parse_manifest_str(text, &manifest).unwrap();
    assert!(matches!(&plan.scene, SceneSpec::Gltf(g) if g.file.ends_with("textured-sample.gltf")));
    let scene = scene::build_scene(&plan).unwrap();
    assert_eq!(scene.models.len(), 4);
    assert_eq!(scene.instances.len(), 6);
    let m = &scene.models[0];
    let map = m.albedo_map.as_ref().unwrap();
    assert_eq!(m.content_hash, map.model_hash(&m.mesh.content_hash()));
    assert_ne!(m.content_hash, m.mesh.content_hash());
    assert_eq!(
        scene.models[1].content_hash,
        scene.models[1].mesh.content_hash()
    );
    // Changing one texel changes the hash.
    let mut other = map.clone();
    other.texture.rgba[0] ^= 1;
    assert_ne!(other.model_hash(&m.mesh.content_hash()), m.content_hash);
}

#[test]
fn bad_gltf_scenes_are_refused_with_the_reason() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_textured_sample(dir.path()).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    // An extension the file requires and hexbake does not read.
    let required = text.replacen(
        "\"scene\": 0,",
        "\"scene\": 0, \"extensionsUsed\": [\"KHR_draco_mesh_compression\"], \"extensionsRequired\": [\"KHR_draco_mesh_compression\"],",
        1,
    );
    std::fs::write(&path, &required).unwrap();
    let e = load_gltf_scene(&path).unwrap_err().to_string();
    assert!(
        e.contains("KHR_draco_mesh_compression") && e.contains("requires"),
        "{e}"
    );
    // Used but not required: read, with a note naming it.
    let used = text.replacen(
        "\"scene\": 0,",
        "\"scene\": 0, \"extensionsUsed\": [\"KHR_texture_transform\"],",
        1,
    );
    std::fs::write(&path, &used).unwrap();
    let scene = load_gltf_scene(&path).unwrap();
    assert!(
        scene
            .notes
            .iter()
            .any(|n| n.contains("KHR_texture_transform")),
        "{:?}",
        scene.notes
    );
    // A missing texture image names the image.
    std::fs::write(&path, &text).unwrap();
    std::fs::remove_file(dir.path().join("checker.png")).unwrap();
    let e = load_gltf_scene(&path).unwrap_err().to_string();
    assert!(
        e.contains("image 0") && e.contains("textured-sample.gltf"),
        "{e}"
    );
    // The manifest refuses other formats as scenes.
    let e = parse_manifest_str(
        r#"(ground: (min: (0.0, 0.0), max: (1.0, 1.0)), scene: Gltf("x.obj"),
            cells: (cell_size: 1.0, min_eye_height: 1.0, max_eye_height: 2.0))"#,
        &dir.path().join("m.ron"),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains(".gltf or .glb"), "{e}");
}

/// A glTF scene of one triangle mesh used by three nodes: a parent "building" at
/// x = 10 with two mesh children (the second 1 up), and one mesh node at the root.
fn write_grouped_sample(dir: &std::path::Path) -> std::path::PathBuf {
    let positions: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]];
    let bytes: Vec<u8> = positions
        .iter()
        .flatten()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    std::fs::write(dir.join("tri.bin"), &bytes).unwrap();
    let json = r#"{
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 3]}],
        "nodes": [
            {"name": "building", "translation": [10.0, 0.0, 0.0], "children": [1, 2]},
            {"mesh": 0},
            {"mesh": 0, "translation": [0.0, 1.0, 0.0]},
            {"mesh": 0, "translation": [-5.0, 0.0, 0.0]}
        ],
        "meshes": [{"name": "tri", "primitives": [{"attributes": {"POSITION": 0}}]}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                       "min": [0.0, 0.0, -1.0], "max": [1.0, 0.0, 0.0]}],
        "bufferViews": [{"buffer": 0, "byteLength": 36}],
        "buffers": [{"uri": "tri.bin", "byteLength": 36}]
    }"#;
    let path = dir.join("grouped.gltf");
    std::fs::write(&path, json).unwrap();
    path
}

/// Issue 18: `group_by_parent` (`objects: Parents`) makes the mesh nodes under one
/// parent one object (one model in the parent's frame, one instance); with `objects:
/// Nodes` each mesh node is an instance of the shared mesh; the default
/// (`Hierarchy`, issue 29) groups the top-level "building" likewise. Both through
/// the loader and the manifest.
#[test]
fn mesh_nodes_group_by_parent_when_asked() {
    use scene::load::{load_gltf_scene_with, GltfObjects, GltfOptions};
    let dir = tempfile::tempdir().unwrap();
    let path = write_grouped_sample(dir.path());
    let with = |objects| {
        load_gltf_scene_with(
            &path,
            GltfOptions {
                objects,
                ..GltfOptions::default()
            },
        )
        .unwrap()
    };
    let plain = with(GltfObjects::Nodes);
    assert_eq!(plain.models.len(), 1);
    assert_eq!(plain.instances.len(), 3);
    assert_eq!(
        load_gltf_scene(&path).unwrap(),
        with(GltfObjects::Hierarchy)
    );
    let grouped = with(GltfObjects::Parents);
    assert_eq!(grouped, with(GltfObjects::Hierarchy));
    let names: Vec<&str> = grouped.models.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["building", "tri"]);
    assert_eq!(grouped.instances.len(), 2);
    let building = &grouped.models[0];
    assert_eq!(building.mesh.triangles.len(), 2);
    assert_eq!(
        building.mesh.bounds().unwrap(),
        ([0.0, 0.0, -1.0], [1.0, 1.0, 0.0])
    );
    let i = grouped.instances[0];
    assert_eq!((i.model, i.node), (0, 0));
    assert_eq!(i.transform.w_axis.truncate(), Vec3::new(10.0, 0.0, 0.0));
    assert_eq!(grouped.instances[1].model, 1);
    assert_eq!(
        grouped.instances[1].transform.w_axis.truncate(),
        Vec3::new(-5.0, 0.0, 0.0)
    );
    // The same through the manifest: the old form and the struct form.
    let manifest = dir.path().join("m.ron");
    let scene_of = |scene: &str| {
        let text = format!(
            "(ground: (min: (-10.0, -10.0), max: (20.0, 10.0)), scene: {scene},
              cells: (cell_size: 5.0, min_eye_height: 1.0, max_eye_height: 2.0))"
        );
        let plan = parse_manifest_str(&text, &manifest).unwrap();
        scene::build_scene(&plan).unwrap()
    };
    assert_eq!(scene_of(r#"Gltf("grouped.gltf")"#).instances.len(), 2);
    assert_eq!(
        scene_of(r#"Gltf((file: "grouped.gltf"))"#).instances.len(),
        2
    );
    let s = scene_of(r#"Gltf((file: "grouped.gltf", objects: Nodes))"#);
    assert_eq!((s.models.len(), s.instances.len()), (1, 3));
    let s = scene_of(r#"Gltf((file: "grouped.gltf", group_by_parent: true))"#);
    assert_eq!((s.models.len(), s.instances.len()), (2, 2));
    let s = scene_of(r#"Gltf((file: "grouped.gltf", objects: Parents))"#);
    assert_eq!((s.models.len(), s.instances.len()), (2, 2));
    // Messages name the instance's node (issue 29 item 4).
    assert_eq!(
        s.describe_instance(0),
        "instance 0 (glTF node 0 `building`, model `building`)"
    );
    // Contradicting settings are refused with their position.
    let text = r#"(ground: (min: (-10.0, -10.0), max: (20.0, 10.0)),
        scene: Gltf((file: "grouped.gltf", group_by_parent: true, objects: Nodes)),
        cells: (cell_size: 5.0, min_eye_height: 1.0, max_eye_height: 2.0))"#;
    let e = parse_manifest_str(text, &manifest).unwrap_err().to_string();
    assert!(
        e.contains("`group_by_parent: true` is `objects: Parents`"),
        "{e}"
    );
    // A misspelt field is refused, not ignored.
    let text = r#"(ground: (min: (-10.0, -10.0), max: (20.0, 10.0)),
        scene: Gltf((file: "grouped.gltf", group_by_parnet: true)),
        cells: (cell_size: 5.0, min_eye_height: 1.0, max_eye_height: 2.0))"#;
    assert!(parse_manifest_str(text, &manifest).is_err());
}

/// A glTF scene for issue 29 item 3, of one triangle mesh `tri` (1 × 1) and a
/// "wheel" mesh: trucks (a `body` node using `tri` with two `wheel` children)
/// under transform nodes at scales 1 and 2, one mirrored, a lone `tri` at scales
/// 0.5, 1 and 3, and a `street` empty 40 units wide holding two small houses (each
/// a `tri` node with a `wheel` child), all under one mesh-less `RootNode`.
fn write_hierarchy_sample(dir: &std::path::Path) -> std::path::PathBuf {
    let positions: [[f32; 3]; 6] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0],
        [0.2, 0.0, 0.0],
        [0.0, 0.2, 0.0],
    ];
    let bytes: Vec<u8> = positions
        .iter()
        .flatten()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    std::fs::write(dir.join("h.bin"), &bytes).unwrap();
    let json = r#"{
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [
            {"name": "RootNode", "children": [1, 5, 9, 13, 14, 15, 16]},
            {"name": "truck-0", "translation": [0.0, 0.0, 0.0], "children": [2]},
            {"name": "body", "mesh": 0, "children": [3, 4]},
            {"name": "wheel-l", "mesh": 1, "translation": [0.0, 0.0, 0.5]},
            {"name": "wheel-r", "mesh": 1, "translation": [0.0, 0.0, -0.5]},
            {"name": "truck-1", "translation": [10.0, 0.0, 0.0], "scale": [2.0, 2.0, 2.0], "children": [6]},
            {"name": "body", "mesh": 0, "children": [7, 8]},
            {"name": "wheel-l", "mesh": 1, "translation": [0.0, 0.0, 0.5]},
            {"name": "wheel-r", "mesh": 1, "translation": [0.0, 0.0, -0.5]},
            {"name": "truck-mirrored", "translation": [20.0, 0.0, 0.0], "scale": [-1.0, 1.0, 1.0], "children": [10]},
            {"name": "body", "mesh": 0, "children": [11, 12]},
            {"name": "wheel-l", "mesh": 1, "translation": [0.0, 0.0, 0.5]},
            {"name": "wheel-r", "mesh": 1, "translation": [0.0, 0.0, -0.5]},
            {"name": "tri-half", "mesh": 0, "translation": [0.0, 0.0, 5.0], "scale": [0.5, 0.5, 0.5]},
            {"name": "tri-one", "mesh": 0, "translation": [2.0, 0.0, 5.0]},
            {"name": "tri-three", "mesh": 0, "translation": [4.0, 0.0, 5.0], "scale": [3.0, 3.0, 3.0]},
            {"name": "street", "translation": [0.0, 0.0, 20.0], "children": [17, 19]},
            {"name": "house-a", "mesh": 0, "children": [18]},
            {"name": "porch", "mesh": 1, "translation": [0.5, 0.0, 0.0]},
            {"name": "house-b", "mesh": 0, "translation": [40.0, 0.0, 0.0], "children": [20]},
            {"name": "porch", "mesh": 1, "translation": [0.5, 0.0, 0.0]}
        ],
        "meshes": [
            {"name": "tri", "primitives": [{"attributes": {"POSITION": 0}}]},
            {"name": "wheel", "primitives": [{"attributes": {"POSITION": 1}}]}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]},
            {"bufferView": 0, "byteOffset": 36, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [0.2, 0.2, 0.0]}
        ],
        "bufferViews": [{"buffer": 0, "byteLength": 72}],
        "buffers": [{"uri": "h.bin", "byteLength": 72}]
    }"#;
    let path = dir.join("hierarchy.gltf");
    std::fs::write(&path, json).unwrap();
    path
}

/// Issue 29 item 3: glTF instances stay instances. Nodes using one mesh at several
/// uniform scales share one model, the scale in the instance transform; by default
/// a top-level node with everything under it is one object (a truck's body and
/// wheels), identical trucks share that object's model at any uniform scale, a
/// mirrored one gets a mirrored model, and an empty wider than the object limit
/// (the manifest's cell size) is not merged: its children are the objects.
#[test]
fn issue29_gltf_instances_stay_instances_and_objects_follow_the_hierarchy() {
    use scene::load::{load_gltf_scene_with, GltfObjects, GltfOptions};
    let dir = tempfile::tempdir().unwrap();
    let path = write_hierarchy_sample(dir.path());
    let options = GltfOptions {
        objects: GltfObjects::Hierarchy,
        max_object_extent: 10.0,
        ..GltfOptions::default()
    };
    let scene = load_gltf_scene_with(&path, options).unwrap();
    let named: Vec<(&str, u32)> = scene
        .instances
        .iter()
        .map(|i| (scene.models[i.model as usize].name.as_str(), i.node))
        .collect();
    assert_eq!(
        named,
        [
            ("truck-0", 1),
            ("truck-0", 5),
            ("truck-mirrored", 9),
            ("tri", 13),
            ("tri", 14),
            ("tri", 15),
            ("house-a", 17),
            ("house-a", 19),
        ]
    );
    assert_eq!(scene.models.len(), 4, "truck, mirrored truck, tri, house");
    // The scales are in the instances: det = s³.
    let det = |k: usize| Mat3::from_mat4(scene.instances[k].transform).determinant();
    for (k, s) in [
        (0, 1.0f32),
        (1, 2.0),
        (2, 1.0),
        (3, 0.5),
        (4, 1.0),
        (5, 3.0),
    ] {
        assert!(
            (det(k) - s.powi(3)).abs() < 1e-4,
            "instance {k}: {}",
            det(k)
        );
    }
    // A truck is one model of its body and both wheels: 3 triangles.
    assert_eq!(scene.models[0].mesh.triangles.len(), 3);
    // World positions agree with the nodes': truck-1's body tip (0, 1, 0) · 2 + x 10.
    let i = scene.instances[1];
    let m = &scene.models[i.model as usize].mesh;
    let top = m
        .positions
        .iter()
        .map(|&p| i.transform.transform_point3(Vec3::from(p)))
        .fold(f32::NEG_INFINITY, |a, p| a.max(p.y));
    assert!((top - 2.0).abs() < 1e-5, "{top}");
    // Every mesh node an object: 3 × 3 + 3 + 2 × 2 instances of two models (tri
    // and wheel) and their mirrored copies.
    let nodes = load_gltf_scene_with(
        &path,
        GltfOptions {
            objects: GltfObjects::Nodes,
            ..options
        },
    )
    .unwrap();
    assert_eq!(nodes.instances.len(), 16);
    assert_eq!(nodes.models.len(), 4);
    // Through a manifest: the cell size is the object limit; 50 merges the street.
    let manifest = dir.path().join("m.ron");
    let text = r#"(ground: (min: (-10.0, -10.0), max: (60.0, 40.0)),
        scene: Gltf("hierarchy.gltf"),
        cells: (cell_size: 50.0, min_eye_height: 1.0, max_eye_height: 2.0))"#;
    let s = scene::build_scene(&parse_manifest_str(text, &manifest).unwrap()).unwrap();
    assert_eq!(s.instances.len(), 7);
    assert_eq!(
        s.describe_instance(6),
        "instance 6 (glTF node 16 `street`, model `street`)"
    );
}

/// Issue 32 item 4: what the gltf crate's validation leaves to the reader is refused
/// before any node is walked, naming the node: a node listed twice (the 40-level
/// "DAG" that made 2⁴⁰ visits, and a 22-level one), a node with two parents, a
/// scene root that is also a child, a zero quaternion, and a glTF 3.0 asset.
#[test]
fn hostile_gltf_node_graphs_are_refused_naming_the_node() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("hostile.gltf");
    let doc = |version: &str, roots: &str, nodes: Vec<String>| {
        format!(
            r#"{{"asset": {{"version": "{version}"}}, "scene": 0, "scenes": [{{"nodes": [{roots}]}}], "nodes": [{}]}}"#,
            nodes.join(", ")
        )
    };
    let refused = |text: String| -> String {
        match scene::load::parse_gltf_scene(&path, text.as_bytes()) {
            Ok(_) => panic!("accepted: {text}"),
            Err(e) => e.to_string(),
        }
    };
    for levels in [40usize, 22] {
        let nodes = (0..levels)
            .map(|i| {
                if i + 1 < levels {
                    format!(r#"{{"name": "n{i}", "children": [{}, {}]}}"#, i + 1, i + 1)
                } else {
                    format!(r#"{{"name": "n{i}"}}"#)
                }
            })
            .collect();
        let e = refused(doc("2.0", "0", nodes));
        assert!(
            e.contains(r#"node 0 ("n0") lists node 1 ("n1") twice"#)
                && e.contains("at most one parent"),
            "{levels} levels: {e}"
        );
        assert!(e.contains("hostile.gltf"), "{e}");
    }
    let two_parents = vec![
        r#"{"children": [2]}"#.to_string(),
        r#"{"children": [2]}"#.to_string(),
        r#"{"name": "shared"}"#.to_string(),
    ];
    let e = refused(doc("2.0", "0, 1", two_parents));
    assert!(
        e.contains(r#"node 2 ("shared") is a child of node 0 and of node 1"#),
        "{e}"
    );
    let root_child = vec![r#"{"children": [1]}"#.to_string(), "{}".to_string()];
    let e = refused(doc("2.0", "0, 1", root_child));
    assert!(
        e.contains("node 1 is a root of scene 0 and a child of node 0"),
        "{e}"
    );
    // Cycles: through the root, and below it.
    let through_root = vec![
        r#"{"children": [1]}"#.to_string(),
        r#"{"children": [0]}"#.to_string(),
    ];
    let e = refused(doc("2.0", "0", through_root));
    assert!(
        e.contains("node 0 is a root of scene 0 and a child of node 1"),
        "{e}"
    );
    let below = vec![
        r#"{"children": [1]}"#.to_string(),
        r#"{"children": [2]}"#.to_string(),
        r#"{"children": [1]}"#.to_string(),
    ];
    let e = refused(doc("2.0", "0", below));
    assert!(
        e.contains("node 1 is a child of node 0 and of node 2"),
        "{e}"
    );
    let zero = vec![r#"{"name": "spin", "rotation": [0.0, 0.0, 0.0, 0.0]}"#.to_string()];
    let e = refused(doc("2.0", "0", zero));
    assert!(
        e.contains(r#"node 0 ("spin"): rotation"#) && e.contains("unit quaternion"),
        "{e}"
    );
    let e = refused(doc("3.0", "0", vec!["{}".to_string()]));
    assert!(e.contains(r#"asset.version "3.0""#), "{e}");
    // The same documents, well formed, read (no meshes: an empty scene).
    let ok = vec![
        r#"{"children": [1], "rotation": [0.0, 0.7071068, 0.0, 0.7071068]}"#.to_string(),
        "{}".to_string(),
    ];
    let text = doc("2.0", "0", ok);
    if let Err(e) = scene::load::parse_gltf_scene(&path, text.as_bytes()) {
        assert!(
            !e.to_string().contains("parent") && !e.to_string().contains("quaternion"),
            "{e}"
        );
    }
}

/// A glTF file `name` in `dir` over one triangle (`tri.bin`: three VEC3 float
/// positions, bytes 0..36; three u16 indices, bytes 36..42): scene roots `roots`,
/// `nodes`, one mesh of one TRIANGLES primitive (POSITION accessor 0, indices
/// accessor 1). `accessors` and `views` replace the default JSON arrays when given.
fn write_triangle_gltf(
    dir: &std::path::Path,
    name: &str,
    roots: &str,
    nodes: &[String],
    accessors: Option<&str>,
    views: Option<&str>,
) -> std::path::PathBuf {
    let positions: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]];
    let mut bytes: Vec<u8> = positions
        .iter()
        .flatten()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    bytes.extend([0u16, 1, 2, 0].iter().flat_map(|i| i.to_le_bytes()));
    std::fs::write(dir.join("tri.bin"), &bytes).unwrap();
    let accessors = accessors.unwrap_or(
        r#"[{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"},
            {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}]"#,
    );
    let views = views.unwrap_or(
        r#"[{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 6}]"#,
    );
    let json = format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [{roots}]}}],
            "nodes": [{}],
            "meshes": [{{"name": "tri", "primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1}}]}}],
            "accessors": {accessors}, "bufferViews": {views},
            "buffers": [{{"uri": "tri.bin", "byteLength": {}}}]}}"#,
        nodes.join(", "),
        bytes.len()
    );
    let path = dir.join(name);
    std::fs::write(&path, json).unwrap();
    path
}

/// Issue 32 item 4: the walk visits each node once. A scene that lists a root twice
/// (which the parent checks do not see: a scene's root list is no parent) was read
/// as two instances of it; it is refused, naming the node.
#[test]
fn issue32_gltf_walk_visits_each_node_once() {
    let dir = tempfile::tempdir().unwrap();
    let nodes = [r#"{"name": "twice", "mesh": 0}"#.to_string()];
    let once = write_triangle_gltf(dir.path(), "once.gltf", "0", &nodes, None, None);
    assert_eq!(load_gltf_scene(&once).unwrap().instances.len(), 1);
    let path = write_triangle_gltf(dir.path(), "twice.gltf", "0, 0", &nodes, None, None);
    let e = load_gltf_scene(&path).unwrap_err().to_string();
    assert!(
        e.contains(r#"node 0 ("twice")"#)
            && e.contains("visited twice")
            && e.contains("twice.gltf"),
        "{e}"
    );
    // Through a parent too: the subtree of a root listed twice.
    let nodes = [
        r#"{"children": [1]}"#.to_string(),
        r#"{"mesh": 0}"#.to_string(),
    ];
    let path = write_triangle_gltf(dir.path(), "subtree.gltf", "0, 0", &nodes, None, None);
    let e = load_gltf_scene(&path).unwrap_err().to_string();
    assert!(e.contains("node 0") && e.contains("visited twice"), "{e}");
    // The model loader walks the same way.
    let e = scene::load::load_model(&path).unwrap_err().to_string();
    assert!(e.contains("node 0") && e.contains("visited twice"), "{e}");
}

/// Issue 32 item 4: caps on what one glTF file makes, each refusal positioned. Five
/// nodes that scale one mesh non-uniformly make five models (the scale is baked into
/// each: a small file can make a mesh's triangles many times over); with a cap of
/// four triangles the fifth read is refused naming the mesh, the primitive and the
/// cap; with a cap of four instances the fifth node is refused by name.
#[test]
fn issue32_gltf_caps_on_triangles_and_instances_are_positioned() {
    use scene::load::{load_gltf_scene_with, GltfCaps, GltfOptions};
    let dir = tempfile::tempdir().unwrap();
    let nodes: Vec<String> = (1..=5)
        .map(|k| format!(r#"{{"name": "n{k}", "mesh": 0, "scale": [1.0, {k}.0, 1.0]}}"#))
        .collect();
    let path = write_triangle_gltf(dir.path(), "five.gltf", "0, 1, 2, 3, 4", &nodes, None, None);
    let read = |caps: GltfCaps| {
        load_gltf_scene_with(
            &path,
            GltfOptions {
                caps,
                ..GltfOptions::default()
            },
        )
    };
    let all = read(GltfCaps::default()).unwrap();
    assert_eq!((all.models.len(), all.instances.len()), (5, 5));
    let e = read(GltfCaps {
        triangles: 4,
        ..GltfCaps::default()
    })
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("mesh 0 primitive 0") && e.contains("5 triangles") && e.contains("cap of 4"),
        "{e}"
    );
    let e = read(GltfCaps {
        instances: 4,
        ..GltfCaps::default()
    })
    .unwrap_err()
    .to_string();
    assert!(
        e.contains(r#"node 4 ("n5")"#) && e.contains("5 instances") && e.contains("cap of 4"),
        "{e}"
    );
    // Vertices count as read, too: each primitive read adds its POSITION count.
    let e = read(GltfCaps {
        vertices: 14,
        ..GltfCaps::default()
    })
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("mesh 0 primitive 0") && e.contains("15 vertices") && e.contains("cap of 14"),
        "{e}"
    );
}

/// Issue 32 item 4: accessor strides and sparse accessors are checked before the
/// gltf crate reads them, each refusal naming the accessor and what was expected.
#[test]
fn issue32_gltf_strides_and_sparse_accessors_are_checked() {
    use scene::load::{load_gltf_scene_with, GltfCaps, GltfOptions};
    let dir = tempfile::tempdir().unwrap();
    let nodes = [r#"{"mesh": 0}"#.to_string()];
    let refused = |name: &str, accessors: &str, views: Option<&str>| -> String {
        let path = write_triangle_gltf(dir.path(), name, "0", &nodes, Some(accessors), views);
        match load_gltf_scene(&path) {
            Ok(s) => panic!("{name} accepted: {} instances", s.instances.len()),
            Err(e) => e.to_string(),
        }
    };
    let indices = r#"{"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}"#;
    // A stride shorter than the element: elements would overlap.
    let e = refused(
        "stride.gltf",
        &format!(
            r#"[{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"}}, {indices}]"#
        ),
        Some(
            r#"[{"buffer": 0, "byteLength": 36, "byteStride": 4}, {"buffer": 0, "byteOffset": 36, "byteLength": 6}]"#,
        ),
    );
    assert!(
        e.contains("accessor 0") && e.contains("stride 4") && e.contains("12 bytes"),
        "{e}"
    );
    // Sparse: more substitutions than elements.
    let sparse = |count: u32, index_view_offset: u32| {
        format!(
            r#"[{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                  "sparse": {{"count": {count},
                             "indices": {{"bufferView": 1, "byteOffset": {index_view_offset}, "componentType": 5123}},
                             "values": {{"bufferView": 0, "byteOffset": 12}}}}}}, {indices}]"#
        )
    };
    let e = refused("sparse-count.gltf", &sparse(5, 0), None);
    assert!(
        e.contains("accessor 0") && e.contains("sparse count 5") && e.contains("3 elements"),
        "{e}"
    );
    // Sparse indices past their view (view 1 has 6 bytes: 2 + 2·2 = 6 fits, 4 + 4 does not).
    let e = refused("sparse-view.gltf", &sparse(2, 4), None);
    assert!(
        e.contains("accessor 0") && e.contains("sparse indices") && e.contains("bufferView 1"),
        "{e}"
    );
    // Sparse indices must increase and stay below the count: view 1 holds 0, 1, 2
    // as u16; read as two u16 from byte 2 they are 1, 2 (fine: positions 1 and 2
    // replaced by themselves, the values at byte 12); the positions' bytes
    // 8..16 read as u32 are 0 and 1065353216 (the bits of 0.0 and 1.0): not below 3.
    let path = write_triangle_gltf(
        dir.path(),
        "sparse-ok.gltf",
        "0",
        &nodes,
        Some(&sparse(2, 2)),
        None,
    );
    load_gltf_scene(&path).unwrap();
    let bad_indices = format!(
        r#"[{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
              "sparse": {{"count": 2,
                         "indices": {{"bufferView": 0, "byteOffset": 8, "componentType": 5125}},
                         "values": {{"bufferView": 0}}}}}}, {indices}]"#
    );
    let e = refused("sparse-index.gltf", &bad_indices, None);
    assert!(
        e.contains("accessor 0") && e.contains("sparse index") && e.contains("below 3"),
        "{e}"
    );
    // An accessor with no view has no bytes to bound its count: the caps do. A sparse
    // POSITION of 1,000 (zero) elements is refused under a cap of 30 vertices.
    let zeros = format!(
        r#"[{{"componentType": 5126, "count": 1000, "type": "VEC3",
              "sparse": {{"count": 1,
                         "indices": {{"bufferView": 1, "componentType": 5123}},
                         "values": {{"bufferView": 0}}}}}}, {indices}]"#
    );
    let path = write_triangle_gltf(dir.path(), "zeros.gltf", "0", &nodes, Some(&zeros), None);
    let capped = load_gltf_scene_with(
        &path,
        GltfOptions {
            caps: GltfCaps {
                vertices: 30,
                ..GltfCaps::default()
            },
            ..GltfOptions::default()
        },
    )
    .unwrap_err()
    .to_string();
    assert!(
        capped.contains("mesh 0 primitive 0")
            && capped.contains("1000 vertices")
            && capped.contains("cap of 30"),
        "{capped}"
    );
    // Every attribute of a primitive has POSITION's count (glTF 2.0 §3.7.2.1): a
    // COLOR_0 of another count is refused before it is read.
    let colours = r#"[{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"},
                      {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"},
                      {"bufferView": 0, "componentType": 5126, "count": 2, "type": "VEC3"}]"#;
    let path = write_triangle_gltf(dir.path(), "colours.gltf", "0", &nodes, Some(colours), None);
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace(r#"{"POSITION": 0}"#, r#"{"POSITION": 0, "COLOR_0": 2}"#);
    std::fs::write(&path, text).unwrap();
    let e = load_gltf_scene(&path).unwrap_err().to_string();
    assert!(
        e.contains("mesh 0 primitive 0")
            && e.contains("COLOR_0")
            && e.contains("2 elements")
            && e.contains("3"),
        "{e}"
    );
}

/// Issue 32 item 4, the structure-aware fuzz mode as a test: 600 random node graphs
/// (`gltf_sample::node_graph`) each get the verdict their structure calls for, and
/// the generator reaches every kind of graph (accepted, and each refusal).
#[test]
fn issue32_random_node_graphs_get_the_expected_verdict() {
    use format::pack::sample::SplitMix;
    use scene::load::gltf_sample::{check_node_graph, node_graph, GraphFault};
    let mut rng = SplitMix(32);
    let mut seen = std::collections::BTreeSet::new();
    for run in 0..600 {
        let choices: Vec<u8> = (0..512).map(|_| rng.next_u64() as u8).collect();
        let graph = node_graph(&choices);
        if let Err(what) = check_node_graph(&graph) {
            panic!("graph {run}: {what}\n{}", graph.json);
        }
        seen.insert(format!("{:?}", graph.expected.map(|_| ())));
    }
    for fault in [
        GraphFault::TwoParents,
        GraphFault::RootWithParent,
        GraphFault::ZeroRotation,
        GraphFault::VisitedTwice,
        GraphFault::TooDeep,
        GraphFault::NoMesh,
    ] {
        let key = format!("{:?}", Err::<(), _>(fault));
        assert!(seen.contains(&key), "no graph was {fault:?}: {seen:?}");
    }
    assert!(seen.contains("Ok(())"), "{seen:?}");
}
