//! Triangle order of a proxy member for compact packs (issue 15 item 4).
//!
//! The order of a proxy's triangles is free: the player draws them all, the view
//! masks travel with them. The edge collapse (`simplify.rs`) leaves the survivors in
//! the model's input order, where consecutive triangles often share no vertex; the
//! pack's index codec (`zstd+index-mtf`, format/README.md "Codecs") codes an index it
//! saw among the last 16 in a few bits and a new one as a delta. So before packing,
//! each member's triangles are put in vertex-cache order by meshoptimizer's
//! `optimizeVertexCache` (Forsyth's algorithm as refined by Kapoulkine; deterministic,
//! single-threaded), run on the member's vertices renumbered densely in order of first
//! use, and each triangle's view mask follows it. Vertex order within a triangle
//! (the winding) is kept.

/// Reorders `triangles` (and `masks`, when not empty: one per triangle) into
/// vertex-cache order. The multiset of (triangle, mask) pairs is unchanged.
pub fn cache_order(triangles: Vec<[u32; 3]>, masks: Vec<u8>) -> (Vec<[u32; 3]>, Vec<u8>) {
    if triangles.len() < 3 {
        return (triangles, masks);
    }
    // Dense local ids in order of first use (deterministic; no hash-map order).
    let mut ids: Vec<u32> = triangles.iter().flatten().copied().collect();
    ids.sort_unstable();
    ids.dedup();
    let local = |v: u32| ids.binary_search(&v).expect("vertex of the list") as u32;
    let indices: Vec<u32> = triangles.iter().flatten().map(|&v| local(v)).collect();
    let ordered = meshopt::optimize_vertex_cache(&indices, ids.len());
    // Map each reordered triangle back to an input triangle (each used once; equal
    // triangles are interchangeable but may carry different masks, so take them in
    // input order).
    let mut by_tri: Vec<([u32; 3], usize)> = indices
        .chunks_exact(3)
        .enumerate()
        .map(|(i, t)| ([t[0], t[1], t[2]], i))
        .collect();
    by_tri.sort_unstable();
    let mut taken = vec![false; triangles.len()];
    let mut out_tris = Vec::with_capacity(triangles.len());
    let mut out_masks = Vec::with_capacity(masks.len());
    for t in ordered.chunks_exact(3) {
        let key = [t[0], t[1], t[2]];
        let first = by_tri.partition_point(|(k, _)| *k < key);
        let i = by_tri[first..]
            .iter()
            .take_while(|(k, _)| *k == key)
            .map(|&(_, i)| i)
            .find(|&i| !taken[i])
            .expect("optimizeVertexCache returns a permutation of the triangles");
        taken[i] = true;
        out_tris.push(triangles[i]);
        if !masks.is_empty() {
            out_masks.push(masks[i]);
        }
    }
    (out_tris, out_masks)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// The output is a permutation of the input pairs, windings kept.
        #[test]
        fn permutes_pairs(tris in prop::collection::vec(
            prop::array::uniform3(0u32..40).prop_filter("distinct", |t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2]),
            0..120), seed in any::<u8>()) {
            let masks: Vec<u8> = (0..tris.len()).map(|i| (i as u8).wrapping_mul(seed)).collect();
            let (t2, m2) = cache_order(tris.clone(), masks.clone());
            let mut a: Vec<_> = tris.into_iter().zip(masks).collect();
            let mut b: Vec<_> = t2.into_iter().zip(m2).collect();
            a.sort();
            b.sort();
            prop_assert_eq!(a, b);
        }
    }
}
