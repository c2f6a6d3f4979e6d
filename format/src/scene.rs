//! The scene a bake reads: models, instances and the ground (DESIGN.md "Data flow").
//!
//! A `Scene` is what the validated manifest resolves to once every model is loaded
//! and normalised; the worker and the player both see the world through it.

use crate::albedo::AlbedoMap;
use crate::mesh::Mesh;
use glam::{Mat4, Vec3};
use serde::{Deserialize, Serialize};

/// A loaded, normalised model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Model {
    /// Short name (file stem or procedural name), unique within the scene.
    pub name: String,
    /// Where it came from (a path, or `procedural:<name>`), for messages and reports.
    pub source: String,
    pub mesh: Mesh,
    /// blake3 of the loaded mesh's bytes (positions, normals, albedo, triangles);
    /// for a textured model, [`AlbedoMap::model_hash`] of that and the texture; with
    /// a chunk, that hash with its cell and locked ids ([`Model::into_chunk`]).
    pub content_hash: [u8; 32],
    /// Base-colour texture and UVs (models of glTF scenes, issue 18); `None`: the
    /// vertex albedo alone.
    #[serde(default)]
    pub albedo_map: Option<AlbedoMap>,
    /// Vertices (ascending ids) that simplification never removes: no collapse of
    /// the worker's (its LOD chains, SV and MV proxies) moves them, so they stay where
    /// the model puts them in every proxy. A chunk of a split object (`scene::chunk`,
    /// issue 29) locks its cut border, the vertices it shares with the object's other
    /// chunks, so proxies of two neighbouring chunks still meet without a crack.
    /// Empty for every other model.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub locked_vertices: Vec<u32>,
    /// For a chunk of a split object (`scene::chunk`, issue 29): the cell it was cut
    /// for. The split draws a chunk as an original in every cell its footprint
    /// comes near, not only in those it overlaps (worker `grid::
    /// instance_draws_as_original`). `None` for every other model.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub chunk_cell: Option<u32>,
}

impl Model {
    /// A model of `mesh` and, when textured, `albedo_map`, with its content hash: the
    /// mesh's, or for a textured model [`AlbedoMap::model_hash`] of that and the
    /// texture.
    pub fn new(name: String, source: String, mesh: Mesh, albedo_map: Option<AlbedoMap>) -> Model {
        let mesh_hash = mesh.content_hash();
        let content_hash = match &albedo_map {
            Some(map) => map.model_hash(&mesh_hash),
            None => mesh_hash,
        };
        Model {
            name,
            source,
            mesh,
            content_hash,
            albedo_map,
            locked_vertices: Vec::new(),
            chunk_cell: None,
        }
    }

    /// The model as the chunk of a split object cut for `cell`, with `locked`
    /// (vertex ids, any order, repeats allowed: its cut border) as its
    /// [`Model::locked_vertices`], and its content hash extended by both: a model's
    /// LOD chain and proxies are keyed by the hash, and change with what they may
    /// move.
    pub fn into_chunk(mut self, cell: u32, mut locked: Vec<u32>) -> Model {
        locked.sort_unstable();
        locked.dedup();
        let mut h = blake3::Hasher::new();
        h.update(b"hexbake chunk v1\0");
        h.update(&self.content_hash);
        h.update(&cell.to_le_bytes());
        h.update(&(locked.len() as u64).to_le_bytes());
        for v in &locked {
            h.update(&v.to_le_bytes());
        }
        self.content_hash = *h.finalize().as_bytes();
        self.locked_vertices = locked;
        self.chunk_cell = Some(cell);
        self
    }
}

/// One placed copy of a model.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Instance {
    /// Index into `Scene::models`.
    pub model: u32,
    /// Object → world transform (column-major, glam's layout).
    pub transform: Mat4,
    /// Linear RGB multiplier applied to the model's albedo.
    pub tint: Vec3,
}

/// The ground rectangle on y = 0, `min` and `max` in (x, z).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Ground {
    pub min: [f32; 2],
    pub max: [f32; 2],
}

impl Ground {
    /// The ground rectangle as a mesh on y = 0 (world space): two counter-clockwise
    /// triangles seen from above, normals +y, albedo [`crate::shading::GROUND`]. Both
    /// renderers draw it in views of the scene (not in captures of single objects),
    /// so views are not objects floating in the sky (issue 18).
    pub fn mesh(&self) -> Mesh {
        let [x0, z0] = self.min;
        let [x1, z1] = self.max;
        Mesh {
            positions: vec![[x0, 0.0, z0], [x0, 0.0, z1], [x1, 0.0, z1], [x1, 0.0, z0]],
            normals: vec![[0.0, 1.0, 0.0]; 4],
            albedo: vec![crate::shading::GROUND; 4],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
        }
    }

    pub fn size(&self) -> [f32; 2] {
        [self.max[0] - self.min[0], self.max[1] - self.min[1]]
    }

    /// `[N, M]`, the columns and rows of the hex grid of cell size `cell_size` on this
    /// ground (DESIGN.md "Hex grid"): `N = ceil(W / 1.5c)`, `M = ceil(H / √3c + 1/2)`,
    /// each at least 1. The one home of the count: the worker's `HexGrid`, the
    /// manifest's limits and the base-pack reader all use it. Computed in f64 with a
    /// 1e-6 tolerance so an exact fit (1650 / 75 = 22) does not round up through float
    /// noise; counts beyond `u64` saturate. `None` when the cell size is not positive
    /// and finite or the ground is not a finite, non-empty rectangle.
    pub fn hex_grid_dims(&self, cell_size: f32) -> Option<[u64; 2]> {
        let [w, h] = self.size();
        let finite = self.min.iter().chain(&self.max).all(|v| v.is_finite());
        if !(cell_size.is_finite() && cell_size > 0.0 && finite && w > 0.0 && h > 0.0) {
            return None;
        }
        let c = f64::from(cell_size);
        let eps = 1e-6;
        let n_cols = ((f64::from(w) / (1.5 * c)) - eps).ceil().max(1.0) as u64;
        let n_rows = ((f64::from(h) / (3f64.sqrt() * c)) + 0.5 - eps)
            .ceil()
            .max(1.0) as u64;
        Some([n_cols, n_rows])
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Scene {
    pub models: Vec<Model>,
    pub instances: Vec<Instance>,
    pub ground: Ground,
    /// Each model's mesh bounds, computed on first use by [`Scene::instance_bounds`]
    /// (a bake asks for every instance's bounds in every cell: scanning the vertices
    /// each time was 9 % of an incremental rebake). Not serialised; never part of
    /// equality.
    #[serde(skip)]
    pub model_bounds: ModelBoundsCache,
    /// Per instance, where it comes from in the user's terms (issue 29 item 4): a
    /// glTF scene's node (its index and name), a manifest's `Instances` entry or a
    /// park's `placed` entry; empty where nothing names it (generated placements, a
    /// scene built in code). Read by [`Scene::describe_instance`] for messages only:
    /// never hashed, never part of equality.
    #[serde(default, skip_serializing_if = "InstanceLabels::is_empty")]
    pub instance_labels: InstanceLabels,
}

/// Where each instance of a [`Scene`] comes from (see `instance_labels`): one label
/// per instance, or none at all. Two scenes are equal whatever their labels.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(transparent)]
pub struct InstanceLabels(pub Vec<String>);

impl InstanceLabels {
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// The label of instance `i`, if it has a non-empty one.
    pub fn get(&self, i: usize) -> Option<&str> {
        self.0.get(i).map(String::as_str).filter(|l| !l.is_empty())
    }
}

impl PartialEq for InstanceLabels {
    /// Labels are for messages: two scenes are equal whatever their labels.
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

/// The lazily computed per-model bounds of a [`Scene`] (see `model_bounds`).
#[derive(Clone, Debug, Default)]
pub struct ModelBoundsCache(std::sync::OnceLock<Vec<([f32; 3], [f32; 3])>>);

impl PartialEq for ModelBoundsCache {
    /// A cache of derived data: two scenes are equal whatever their caches hold.
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl Scene {
    pub fn triangle_count(&self) -> u64 {
        self.instances
            .iter()
            .map(|i| self.models[i.model as usize].mesh.triangle_count() as u64)
            .sum()
    }

    /// Instance `i` in the user's terms, for messages (issue 29 item 4): its label
    /// (`instance_labels`) and its model's name, else its model's name and source —
    /// e.g. ``instance 0 (glTF node 2 `Ground`, model `Ground-mesh`)``.
    pub fn describe_instance(&self, i: usize) -> String {
        let Some(inst) = self.instances.get(i) else {
            return format!("instance {i} (not in the scene)");
        };
        let model = match self.models.get(inst.model as usize) {
            Some(m) => format!("model `{}`", m.name),
            None => format!("model {} (missing)", inst.model),
        };
        match self.instance_labels.get(i) {
            Some(label) => format!("instance {i} ({label}, {model})"),
            None => match self.models.get(inst.model as usize) {
                Some(m) if m.source != m.name => {
                    format!("instance {i} ({model} from {})", m.source)
                }
                _ => format!("instance {i} ({model})"),
            },
        }
    }

    /// World-space axis-aligned bounds of one instance.
    pub fn instance_bounds(&self, instance: usize) -> (Vec3, Vec3) {
        let inst = &self.instances[instance];
        let bounds = self.model_bounds.0.get_or_init(|| {
            self.models
                .iter()
                .map(|m| m.mesh.bounds().unwrap_or(([0.0; 3], [0.0; 3])))
                .collect()
        });
        let (lo, hi) = bounds[inst.model as usize];
        let mut wlo = Vec3::splat(f32::INFINITY);
        let mut whi = Vec3::splat(f32::NEG_INFINITY);
        for k in 0..8 {
            let c = Vec3::new(
                if k & 1 == 0 { lo[0] } else { hi[0] },
                if k & 2 == 0 { lo[1] } else { hi[1] },
                if k & 4 == 0 { lo[2] } else { hi[2] },
            );
            let w = inst.transform.transform_point3(c);
            wlo = wlo.min(w);
            whi = whi.max(w);
        }
        (wlo, whi)
    }
}
