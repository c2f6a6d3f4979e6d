//! Fuzz target, structure-aware (issue 32 item 4): the bytes spell a glTF node graph
//! (`scene::load::gltf_sample::node_graph`: trees, DAGs, cycles, deep chains, random
//! edges, roots listed twice), and the scene reader's verdict must be the graph's —
//! accepted with one instance per reachable mesh node, or refused naming a node.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let graph = scene::load::gltf_sample::node_graph(data);
    if let Err(what) = scene::load::gltf_sample::check_node_graph(&graph) {
        panic!("{what}\n{}", graph.json);
    }
});
