//! Objects larger than a cell, split along the hex grid at import (issue 29 item 2).
//!
//! The paper's split (000 §3.1.1) decides per object: inside a cell, drawn as it is,
//! or outside, replaced by a proxy. An object wider than a cell — a terrain, a long
//! building block — overlaps many cells, so every one of them draws it whole as an
//! original, and no cell can replace its far parts by a proxy. Splitting it into one
//! chunk per cell lets each cell draw the chunks under and beside it and proxy the
//! rest, like any other objects.
//!
//! **The rule.** An instance whose world footprint (its box's x–z extent) is wider
//! than [`MAX_OBJECT_WIDTH_CELLS`] cell widths (2c each) in x or z is split: each
//! triangle goes, whole, to the chunk of the cell under its world-space centroid (the
//! nearest cell for centroids off the grid). A chunk keeps the original vertices it
//! uses, with their positions, normals, albedo and UVs bit for bit, so a border edge
//! shared by two chunks has the same two vertices on both sides: no crack, no
//! T-junction, nothing moves. Chunks are models of their own (object space unchanged,
//! the instance's transform and tint), each an object for the split, the proxies and
//! the far field. An instance that would make a single chunk is left alone, as is
//! every instance of a scene without a grid to split along.
//!
//! **Locked cut borders (issue 29).** Each chunk is simplified on its own, for its
//! proxies and its LOD chain. Were its border free, a border vertex could merge
//! along the border or into an interior vertex of lower weight in one chunk and not
//! in its neighbour, and two proxied chunks would no longer share their border:
//! one-pixel cracks of sky between them (80 of the terrain walk's 317 frames). So a
//! chunk's vertices on the cut, those whose position the triangles of another chunk
//! of the same object also use, are its [`Model::locked_vertices`]: the worker's
//! simplification never removes them (`worker/src/simplify.rs`, "Rejected
//! collapses"), and every representation of a chunk keeps its cut border bit for
//! bit. Open boundaries the object had before the split (a terrain's outer edge)
//! stay free, as they are for any other model.
//!
//! **Chunks near a cell (issue 29).** A chunk's footprint may stop a sliver short
//! of a neighbouring cell's hexagon (its triangles are those whose centroids lie in
//! its own cell); a chunk records its cell ([`Model::chunk_cell`]) and the worker's
//! split draws it as an original in every cell it comes within half a cell of
//! (worker `grid::instance_draws_as_original`), so the ground next to the viewer is
//! never a proxy.
//!
//! Determinism: chunks are formed in ascending cell order, vertices in ascending
//! original order; a split model no instance uses any more is dropped and the rest
//! keep their order. A scene with nothing to split is left exactly as it was.

use format::albedo::AlbedoMap;
use format::grid::HexGrid;
use format::{Instance, InstanceLabels, Mesh, Model, Scene};
use glam::{Vec2, Vec3};
use std::collections::{BTreeMap, HashMap};

/// An instance wider than this many cell widths (2c, the hexagon's corner-to-corner
/// width) in x or z is split. One cell width would split most objects that straddle
/// a border; two keeps objects of a few cells' size whole, as the paper's statues
/// and the city's buildings are.
pub const MAX_OBJECT_WIDTH_CELLS: f32 = 2.0;

/// What [`split_wide_objects`] did, for `pipeline scene` and reports.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct ChunkStats {
    /// Instances split.
    pub split_objects: u32,
    /// Chunks they became (instances in their place).
    pub chunks: u32,
}

/// Splits every instance of `scene` wider than [`MAX_OBJECT_WIDTH_CELLS`] cells of
/// `grid` into one chunk per cell (module docs). Instances keep their order, a split
/// one replaced in place by its chunks; labels follow (`… chunk of cell N`).
pub fn split_wide_objects(scene: &mut Scene, grid: &HexGrid) -> ChunkStats {
    let max_width = MAX_OBJECT_WIDTH_CELLS * 2.0 * grid.cell_size();
    let mut stats = ChunkStats::default();
    let mut models = std::mem::take(&mut scene.models);
    let old_instances = std::mem::take(&mut scene.instances);
    let old_labels = std::mem::take(&mut scene.instance_labels);
    let mut instances = Vec::with_capacity(old_instances.len());
    let mut labels = Vec::new();
    let mut split_models = Vec::new();
    for (i, inst) in old_instances.iter().enumerate() {
        let label = old_labels.get(i).map(str::to_string);
        let chunks = models
            .get(inst.model as usize)
            .filter(|m| footprint_width(&m.mesh, inst) > max_width)
            .map(|m| chunk_model(m, inst, grid, i))
            .filter(|chunks| chunks.len() > 1);
        let Some(chunks) = chunks else {
            instances.push(*inst);
            if !old_labels.is_empty() {
                labels.push(label.unwrap_or_default());
            }
            continue;
        };
        stats.split_objects += 1;
        stats.chunks += chunks.len() as u32;
        split_models.push(inst.model);
        for (cell, model) in chunks {
            instances.push(Instance {
                model: models.len() as u32,
                ..*inst
            });
            models.push(model);
            if !old_labels.is_empty() {
                labels.push(match &label {
                    Some(l) => format!("{l}, chunk of cell {cell}"),
                    None => format!("instance {i}, chunk of cell {cell}"),
                });
            }
        }
    }
    // Drop the split models no instance uses any more, keeping the order (a model
    // the manifest lists with no instances stays, as without splitting).
    let mut used = vec![true; models.len()];
    for &m in &split_models {
        used[m as usize] = false;
    }
    for inst in &instances {
        used[inst.model as usize] = true;
    }
    let mut new_index = vec![u32::MAX; models.len()];
    let mut kept = Vec::with_capacity(models.len());
    for (k, model) in models.into_iter().enumerate() {
        if used[k] {
            new_index[k] = kept.len() as u32;
            kept.push(model);
        }
    }
    for inst in &mut instances {
        inst.model = new_index[inst.model as usize];
    }
    scene.models = kept;
    scene.instances = instances;
    scene.instance_labels = InstanceLabels(labels);
    scene.model_bounds = Default::default();
    stats
}

/// The wider of the x and z extents of the instance's world box.
fn footprint_width(mesh: &Mesh, inst: &Instance) -> f32 {
    let Some((lo, hi)) = mesh.bounds() else {
        return 0.0;
    };
    let (mut wlo, mut whi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for k in 0..8 {
        let corner = Vec3::new(
            if k & 1 == 0 { lo[0] } else { hi[0] },
            if k & 2 == 0 { lo[1] } else { hi[1] },
            if k & 4 == 0 { lo[2] } else { hi[2] },
        );
        let w = inst.transform.transform_point3(corner);
        wlo = wlo.min(w);
        whi = whi.max(w);
    }
    (whi.x - wlo.x).max(whi.z - wlo.z)
}

/// The chunks of `model` placed by `inst`, by cell (ascending).
fn chunk_model(model: &Model, inst: &Instance, grid: &HexGrid, i: usize) -> Vec<(u32, Model)> {
    let mesh = &model.mesh;
    let mut by_cell: BTreeMap<u32, Vec<[u32; 3]>> = BTreeMap::new();
    for &t in &mesh.triangles {
        let c = t
            .iter()
            .map(|&v| Vec3::from(mesh.positions[v as usize]))
            .sum::<Vec3>()
            / 3.0;
        let w = inst.transform.transform_point3(c);
        let xz = Vec2::new(w.x, w.z);
        let cell = grid
            .cell_at(xz)
            .or_else(|| grid.nearest_cell(xz))
            .unwrap_or(0);
        by_cell.entry(cell).or_default().push(t);
    }
    let border = cut_border(mesh, &by_cell);
    by_cell
        .into_iter()
        .map(|(cell, triangles)| (cell, sub_model(model, &triangles, &border, cell, i)))
        .collect()
}

/// Per vertex of `mesh`: whether it lies on a cut, i.e. the triangles of more than one
/// chunk use its position (bit-equal, −0 = +0, so a UV seam along the cut counts).
fn cut_border(mesh: &Mesh, by_cell: &BTreeMap<u32, Vec<[u32; 3]>>) -> Vec<bool> {
    let key = |v: u32| mesh.positions[v as usize].map(|x| (x + 0.0).to_bits());
    // Per position: the first chunk that uses it, and whether another one does.
    let mut users: HashMap<[u32; 3], (u32, bool)> = HashMap::new();
    for (&cell, triangles) in by_cell {
        for &v in triangles.iter().flatten() {
            let entry = users.entry(key(v)).or_insert((cell, false));
            entry.1 |= entry.0 != cell;
        }
    }
    (0..mesh.positions.len() as u32)
        .map(|v| users.get(&key(v)).is_some_and(|&(_, shared)| shared))
        .collect()
}

/// The model of `triangles` of `model`: the vertices they use, in ascending original
/// order, copied bit for bit (with their UVs when textured), those on the cut
/// (`border`, by original id) locked.
fn sub_model(model: &Model, triangles: &[[u32; 3]], border: &[bool], cell: u32, i: usize) -> Model {
    let mesh = &model.mesh;
    let mut remap = vec![u32::MAX; mesh.positions.len()];
    for t in triangles {
        for &v in t {
            remap[v as usize] = 0;
        }
    }
    let mut kept = Vec::new();
    for (v, slot) in remap.iter_mut().enumerate() {
        if *slot == 0 {
            *slot = kept.len() as u32;
            kept.push(v);
        }
    }
    let sub = Mesh {
        positions: kept.iter().map(|&v| mesh.positions[v]).collect(),
        normals: kept.iter().map(|&v| mesh.normals[v]).collect(),
        albedo: kept.iter().map(|&v| mesh.albedo[v]).collect(),
        triangles: triangles
            .iter()
            .map(|t| t.map(|v| remap[v as usize]))
            .collect(),
    };
    let albedo_map = model.albedo_map.as_ref().map(|m| AlbedoMap {
        uvs: kept
            .iter()
            .map(|&v| m.uvs.get(v).copied().unwrap_or_default())
            .collect(),
        texture: m.texture.clone(),
    });
    let locked = (0..kept.len() as u32)
        .filter(|&k| border[kept[k as usize]])
        .collect();
    Model::new(
        format!("{}@{i}#{cell}", model.name),
        model.source.clone(),
        sub,
        albedo_map,
    )
    .into_chunk(cell, locked)
}
