//! From a validated [`Plan`] to the [`Scene`] a bake reads (DESIGN.md "Data flow").
//!
//! [`build_scene`] reads as its steps:
//! 1. list the distinct models — a model is (source, pre-rotation, target height) —
//!    in manifest order;
//! 2. load each distinct *source* once (`load::load_model` or `procedural::build`);
//! 3. per model: pre-rotate, normalise ([`normalise`]), hash (`Mesh::content_hash`);
//! 4. place the instances: the explicit list as given, the park generator
//!    (`park::place`) with the normalised footprints, or the city generator
//!    (`city::place`; a city's building variants are generated models, listed after
//!    its props).

use crate::load::{load_model, LoadError};
use crate::park::{self, ParkEntry, ParkError};
use format::manifest::{InstanceSpec, ModelSource, Plan, SceneSpec};
use format::mesh::Mesh;
use format::scene::{Instance, Model, Scene};
use glam::{Mat3, Mat4, Vec3};
use std::collections::BTreeMap;
use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error(transparent)]
    Load(#[from] LoadError),
    #[error("procedural model `{0}` is unknown")]
    UnknownProcedural(String),
    #[error("{model}: {source}")]
    Normalise {
        model: String,
        source: NormaliseError,
    },
    #[error("{}: {source}", manifest.display())]
    Park {
        manifest: PathBuf,
        source: ParkError,
    },
    #[error("{}: {source}", manifest.display())]
    City {
        manifest: PathBuf,
        source: crate::city::CityError,
    },
    /// `--as-instances` of a city or a glTF scene: its models are generated meshes or
    /// parts of one file that no model source names.
    #[error(
        "{}: a city's buildings and a glTF scene's meshes are not model files; the scene \
         cannot be written as an instance list",
        manifest.display()
    )]
    CityAsInstances { manifest: PathBuf },
    /// A `Tiled` scene whose base manifest no longer parses.
    #[error("{}: its tiled manifest: {what}", manifest.display())]
    Tiled { manifest: PathBuf, what: String },
    /// A park's hand-placed object standing on a generated one.
    #[error(
        "{}: scene.placed[{placed}] ({model} at {at:?}) overlaps the park's generated \
         instance {other} ({other_model} at {other_at:?}); move it to free ground",
        manifest.display()
    )]
    PlacedOverlaps {
        manifest: PathBuf,
        placed: usize,
        model: String,
        at: [f32; 3],
        other: usize,
        other_model: String,
        other_at: [f32; 3],
    },
    /// A glTF scene whose coordinates exceed the manifest's limits.
    #[error("{}: {what}", file.display())]
    GltfScene { file: PathBuf, what: String },
}

#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum NormaliseError {
    #[error("the model is flat (height {height} after pre-rotation); cannot scale it to a height")]
    Flat { height: f32 },
    #[error("the model has no vertices")]
    Empty,
    /// Scaled to its target height, the model would reach beyond the manifest's
    /// coordinate limit (a very flat, very wide model).
    #[error(
        "scaled to height {target_height}, the model would be {extent} units wide, beyond \
         the limit of {}",
        format::manifest::MAX_COORDINATE
    )]
    TooWide { target_height: f32, extent: f64 },
}

/// Pre-rotates `mesh` by Euler angles (x, y, z degrees, applied x first: R = Rz·Ry·Rx),
/// then normalises it: base on y = 0, bounding box centred on x = z = 0, uniformly
/// scaled so its height is `target_height`. Normals are rotated (uniform scaling
/// keeps them). Computed in f64: the lowest vertex lands exactly on y = 0.
pub fn normalise(
    mesh: &mut Mesh,
    pre_rotation_deg: [f32; 3],
    target_height: f32,
) -> Result<(), NormaliseError> {
    let [rx, ry, rz] = pre_rotation_deg.map(|a| a.to_radians());
    let rotation =
        Mat3::from_rotation_z(rz) * Mat3::from_rotation_y(ry) * Mat3::from_rotation_x(rx);
    let rotation = rotation.as_dmat3();
    if pre_rotation_deg != [0.0; 3] {
        for n in &mut mesh.normals {
            let r = (rotation * glam::DVec3::from(n.map(f64::from))).normalize_or_zero();
            *n = r.as_vec3().to_array();
        }
    }
    let rotated: Vec<glam::DVec3> = mesh
        .positions
        .iter()
        .map(|p| rotation * glam::DVec3::from(p.map(f64::from)))
        .collect();
    let (Some(lo), Some(hi)) = (
        rotated.iter().copied().reduce(glam::DVec3::min),
        rotated.iter().copied().reduce(glam::DVec3::max),
    ) else {
        return Err(NormaliseError::Empty);
    };
    let height = hi.y - lo.y;
    if !(height > 0.0 && height.is_finite()) {
        return Err(NormaliseError::Flat {
            height: height as f32,
        });
    }
    let scale = f64::from(target_height) / height;
    let extent = (hi.x - lo.x).max(hi.z - lo.z) * scale;
    // NaN counts as too wide.
    if extent.is_nan() || extent > f64::from(format::manifest::MAX_COORDINATE) {
        return Err(NormaliseError::TooWide {
            target_height,
            extent,
        });
    }
    let base = glam::DVec3::new((lo.x + hi.x) * 0.5, lo.y, (lo.z + hi.z) * 0.5);
    for (p, r) in mesh.positions.iter_mut().zip(rotated) {
        *p = ((r - base) * scale).as_vec3().to_array();
    }
    Ok(())
}

/// A model as the scene distinguishes it.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
struct ModelKey {
    source: ModelSource,
    pre_rotation_bits: [u32; 3],
    target_height_bits: u32,
}

fn key(source: &ModelSource, pre_rotation_deg: [f32; 3], target_height: f32) -> ModelKey {
    ModelKey {
        source: source.clone(),
        pre_rotation_bits: pre_rotation_deg.map(f32::to_bits),
        target_height_bits: target_height.to_bits(),
    }
}

/// Builds the scene of `plan` (steps in the module docs). Deterministic.
pub fn build_scene(plan: &Plan) -> Result<Scene, SceneError> {
    Ok(build_scene_with_chunks(plan)?.0)
}

/// [`build_scene`], also saying how many objects were split into how many chunks
/// (`pipeline scene`).
pub fn build_scene_with_chunks(
    plan: &Plan,
) -> Result<(Scene, crate::chunk::ChunkStats), SceneError> {
    let mut scene = build_with_placements(plan)?.0;
    let mut stats = crate::chunk::ChunkStats::default();
    // Objects wider than a cell become one chunk per cell (issue 29 item 2).
    let grid = format::grid::HexGrid::try_new(scene.ground, plan.cells.cell_size);
    if let (true, Ok(grid)) = (plan.split_wide_objects, grid) {
        stats = crate::chunk::split_wide_objects(&mut scene, &grid);
    }
    Ok((scene, stats))
}

/// A `Tiled` scene ([`format::manifest::TiledSpec`]): the base manifest's scene, its
/// instances repeated tile by tile (row of tiles by row, each in the base's order)
/// shifted by whole grid periods; the models are the base's, shared.
fn build_tiled_scene(plan: &Plan, spec: &format::manifest::TiledSpec) -> Result<Scene, SceneError> {
    let base_plan =
        format::manifest::parse_manifest(&spec.manifest).map_err(|e| SceneError::Tiled {
            manifest: plan.manifest_path.clone(),
            what: e.to_string(),
        })?;
    let base = build_scene(&base_plan)?;
    let c = f64::from(plan.cells.cell_size);
    let mut instances = Vec::with_capacity(base.instances.len() * (spec.tiles as usize).pow(2));
    let mut labels = Vec::new();
    for j in 0..spec.tiles {
        for i in 0..spec.tiles {
            let shift = glam::Vec3::new(
                (f64::from(i * spec.period[0]) * 1.5 * c) as f32,
                0.0,
                (f64::from(j * spec.period[1]) * 3f64.sqrt() * c) as f32,
            );
            let t = glam::Mat4::from_translation(shift);
            instances.extend(base.instances.iter().map(|inst| format::Instance {
                transform: t * inst.transform,
                ..*inst
            }));
            if !base.instance_labels.is_empty() {
                labels.extend((0..base.instances.len()).map(
                    |k| match base.instance_labels.get(k) {
                        Some(l) => format!("{l} of tile ({i}, {j})"),
                        None => format!("tile ({i}, {j})"),
                    },
                ));
            }
        }
    }
    Ok(Scene {
        models: base.models,
        instances,
        ground: plan.ground,
        model_bounds: Default::default(),
        instance_labels: format::InstanceLabels(labels),
    })
}

/// The scene of `plan` as an `Instances` manifest (RON): its ground, cells, bake
/// parameters and every instance with its model, height, pre-rotation, translation,
/// yaw and tint, so a generated park becomes an editable list (move one statue and
/// rebake: only its proxies are derived again, issue 13). Building the written
/// manifest gives the same models and, for parks, the same instance transforms;
/// parsing it gives every other parameter of `plan` back
/// ([`format::manifest::write_instances_manifest`], serde over the parser's types).
pub fn instances_manifest(plan: &Plan) -> Result<String, SceneError> {
    let (_, placements) = build_with_placements(plan)?;
    let instances: Vec<InstanceSpec> = match (&plan.scene, placements) {
        (SceneSpec::Park(spec), Some(placements)) => placements
            .iter()
            .map(|p| {
                let m = &spec.models[p.model_entry];
                InstanceSpec {
                    model: m.model.clone(),
                    pre_rotation_deg: m.pre_rotation_deg,
                    target_height: m.target_height,
                    translation: p.translation,
                    rotation_y_deg: p.yaw_deg,
                    scale: 1.0,
                    tint: p.tint,
                }
            })
            .chain(spec.placed.iter().cloned())
            .collect(),
        (SceneSpec::Instances(list), _) => list.clone(),
        (SceneSpec::Park(_), None) => unreachable!("a park scene has placements"),
        (SceneSpec::City(_), _) | (SceneSpec::Gltf(_), _) | (SceneSpec::Tiled(_), _) => {
            return Err(SceneError::CityAsInstances {
                manifest: plan.manifest_path.clone(),
            })
        }
    };
    Ok(format::manifest::write_instances_manifest(
        plan,
        &instances,
        &format!(
            "{} as an instance list (`pipeline scene {} --as-instances`).",
            plan.name,
            plan.manifest_path.display()
        ),
    ))
}

fn build_with_placements(plan: &Plan) -> Result<(Scene, Option<Vec<park::Placement>>), SceneError> {
    if let SceneSpec::Gltf(spec) = &plan.scene {
        return Ok((build_gltf_scene(plan, spec)?, None));
    }
    if let SceneSpec::Tiled(spec) = &plan.scene {
        return Ok((build_tiled_scene(plan, spec)?, None));
    }
    // Step 1: distinct models in manifest order.
    let wanted: Vec<(ModelSource, [f32; 3], f32)> = match &plan.scene {
        SceneSpec::Gltf(_) | SceneSpec::Tiled(_) => unreachable!("built above"),
        SceneSpec::Park(p) => p
            .models
            .iter()
            .map(|m| (m.model.clone(), m.pre_rotation_deg, m.target_height))
            .chain(
                p.placed
                    .iter()
                    .map(|i| (i.model.clone(), i.pre_rotation_deg, i.target_height)),
            )
            .collect(),
        SceneSpec::Instances(list) => list
            .iter()
            .map(|i| (i.model.clone(), i.pre_rotation_deg, i.target_height))
            .collect(),
        SceneSpec::City(c) => c
            .props
            .iter()
            .map(|m| (m.model.clone(), m.pre_rotation_deg, m.target_height))
            .collect(),
    };
    let mut model_index: BTreeMap<ModelKey, u32> = BTreeMap::new();
    let mut distinct: Vec<(ModelSource, [f32; 3], f32)> = Vec::new();
    let mut entry_model: Vec<u32> = Vec::with_capacity(wanted.len());
    for (source, rot, height) in &wanted {
        let next = distinct.len() as u32;
        let id = *model_index
            .entry(key(source, *rot, *height))
            .or_insert_with(|| {
                distinct.push((source.clone(), *rot, *height));
                next
            });
        entry_model.push(id);
    }

    // Steps 2–3: load each source once, normalise and hash each model.
    let mut loaded: BTreeMap<ModelSource, Mesh> = BTreeMap::new();
    let mut models: Vec<Model> = Vec::with_capacity(distinct.len());
    let mut names_used: BTreeMap<String, u32> = BTreeMap::new();
    for (source, rot, height) in &distinct {
        if !loaded.contains_key(source) {
            let mesh = match source {
                ModelSource::File(path) => load_model(path)?,
                ModelSource::Procedural(name) => crate::procedural::build(name)
                    .ok_or_else(|| SceneError::UnknownProcedural(name.clone()))?,
            };
            loaded.insert(source.clone(), mesh);
        }
        let mut mesh = loaded[source].clone();
        normalise(&mut mesh, *rot, *height).map_err(|e| SceneError::Normalise {
            model: source.describe(),
            source: e,
        })?;
        let base_name = match source {
            ModelSource::File(p) => p
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "model".into()),
            ModelSource::Procedural(name) => name.clone(),
        };
        let uses = names_used.entry(base_name.clone()).or_insert(0);
        *uses += 1;
        let name = if *uses == 1 {
            base_name
        } else {
            format!("{base_name}#{uses}")
        };
        models.push(Model::new(name, source.describe(), mesh, None));
    }

    // Step 3b: a city's building variants, generated (models after the props).
    let city_params = match &plan.scene {
        SceneSpec::City(c) => Some(crate::city::CityParams {
            seed: c.seed,
            block_size: c.block_size,
            street_width: c.street_width,
            buildings_per_block: c.buildings_per_block,
            min_height: c.min_height,
            max_height: c.max_height,
            floor_height: c.floor_height,
            variants: c.variants,
            tint_min: c.tint_min,
            tint_max: c.tint_max,
        }),
        _ => None,
    };
    let first_building = models.len() as u32;
    if let Some(params) = &city_params {
        for v in 0..params.variants {
            let mesh = crate::city::building_mesh(&crate::city::BuildingStyle::draw(params, v));
            models.push(Model::new(
                format!("building-{v}"),
                format!("city:{}:building-{v}", params.seed),
                mesh,
                None,
            ));
        }
    }

    // Step 4: instances.
    let mut placed = None;
    let instances =
        match &plan.scene {
            SceneSpec::Instances(list) => list
                .iter()
                .zip(&entry_model)
                .map(|(spec, &model)| listed_instance(spec, model))
                .collect(),
            SceneSpec::Park(spec) => {
                let entries: Vec<ParkEntry> = spec
                    .models
                    .iter()
                    .zip(&entry_model)
                    .map(|(m, &model)| ParkEntry {
                        count: m.count,
                        footprint: footprint(&models[model as usize].mesh),
                    })
                    .collect();
                let (_grid, placements) = park::place(
                    spec.seed,
                    &entries,
                    spec.tint_min,
                    spec.tint_max,
                    &plan.ground,
                )
                .map_err(|source| SceneError::Park {
                    manifest: plan.manifest_path.clone(),
                    source,
                })?;
                let mut instances: Vec<Instance> = placements
                    .iter()
                    .map(|p| Instance {
                        model: entry_model[p.model_entry],
                        transform: park_transform(p),
                        tint: Vec3::from(p.tint),
                    })
                    .collect();
                let generated = instances.len();
                // Each model's footprint radius, once (the test below runs for every
                // placed × generated pair).
                let reach: Vec<f32> = models.iter().map(|m| footprint_radius(&m.mesh)).collect();
                for (j, (inst, &model)) in spec
                    .placed
                    .iter()
                    .zip(&entry_model[spec.models.len()..])
                    .enumerate()
                {
                    let new = listed_instance(inst, model);
                    if let Some(k) =
                        (0..generated).find(|&k| footprints_overlap(&reach, &instances[k], &new))
                    {
                        return Err(SceneError::PlacedOverlaps {
                            manifest: plan.manifest_path.clone(),
                            placed: j,
                            model: inst.model.describe(),
                            at: inst.translation,
                            other: k,
                            other_model: spec.models[placements[k].model_entry].model.describe(),
                            other_at: placements[k].translation,
                        });
                    }
                    instances.push(new);
                }
                placed = Some(placements.clone());
                instances
            }
            SceneSpec::Gltf(_) | SceneSpec::Tiled(_) => unreachable!("built above"),
            SceneSpec::City(spec) => {
                let props: Vec<crate::city::PropEntry> = spec
                    .props
                    .iter()
                    .zip(&entry_model)
                    .map(|(m, &model)| crate::city::PropEntry {
                        count: m.count,
                        footprint: footprint(&models[model as usize].mesh),
                    })
                    .collect();
                let params = city_params.as_ref().expect("a city has its parameters");
                let (_layout, placements) = crate::city::place(params, &props, &plan.ground)
                    .map_err(|source| SceneError::City {
                        manifest: plan.manifest_path.clone(),
                        source,
                    })?;
                placements
                    .iter()
                    .map(|p| Instance {
                        model: match p.kind {
                            crate::city::PlacedKind::Building(v) => first_building + v,
                            crate::city::PlacedKind::Prop(k) => entry_model[k],
                        },
                        transform: Mat4::from_translation(Vec3::from(p.translation))
                            * Mat4::from_rotation_y(p.yaw_deg.to_radians()),
                        tint: Vec3::from(p.tint),
                    })
                    .collect()
            }
        };
    // Labels for messages (issue 29 item 4): the manifest entries a user wrote.
    let labels = match &plan.scene {
        SceneSpec::Instances(list) => (0..list.len())
            .map(|k| format!("manifest `scene` entry {k}"))
            .collect(),
        SceneSpec::Park(spec) if !spec.placed.is_empty() => {
            let generated = instances.len() - spec.placed.len();
            (0..instances.len())
                .map(|k| match k.checked_sub(generated) {
                    Some(j) => format!("manifest `placed` entry {j}"),
                    None => String::new(),
                })
                .collect()
        }
        _ => Vec::new(),
    };
    Ok((
        Scene {
            models,
            instances,
            ground: plan.ground,
            model_bounds: Default::default(),
            instance_labels: format::InstanceLabels(labels),
        },
        placed,
    ))
}

/// Messages about what a glTF scene ignores, printed once per file and process
/// (every job of a bake builds the scene).
static GLTF_NOTES_SHOWN: std::sync::Mutex<std::collections::BTreeSet<PathBuf>> =
    std::sync::Mutex::new(std::collections::BTreeSet::new());

/// The scene of a `Gltf` manifest (`load::load_gltf_scene`): its models as they are
/// (file units, not normalised), one instance per node and model, tint 1. Model
/// names are made unique with `#k` as for other scenes; textured models hash their
/// texture and UVs into the content hash.
fn build_gltf_scene(plan: &Plan, spec: &format::manifest::GltfSpec) -> Result<Scene, SceneError> {
    let file = spec.file.as_path();
    let options = crate::load::GltfOptions {
        objects: spec.objects,
        max_object_extent: plan.cells.cell_size,
        ..crate::load::GltfOptions::default()
    };
    let gltf = crate::load::load_gltf_scene_with(file, options)?;
    if !gltf.notes.is_empty() {
        let mut shown = GLTF_NOTES_SHOWN.lock().unwrap_or_else(|e| e.into_inner());
        if shown.insert(file.to_path_buf()) {
            for note in &gltf.notes {
                eprintln!("{}: note: {note}", file.display());
            }
        }
    }
    let limit = format::manifest::MAX_COORDINATE;
    let too_far = |what: String| SceneError::GltfScene {
        file: file.to_path_buf(),
        what,
    };
    let mut names_used: BTreeMap<String, u32> = BTreeMap::new();
    let mut models = Vec::with_capacity(gltf.models.len());
    for m in gltf.models {
        if let Some((lo, hi)) = m.mesh.bounds() {
            if lo.iter().chain(&hi).any(|x| x.abs() > limit) {
                return Err(too_far(format!(
                    "mesh `{}` reaches beyond ±{limit} units ({lo:?} to {hi:?})",
                    m.name
                )));
            }
        }
        let uses = names_used.entry(m.name.clone()).or_insert(0);
        *uses += 1;
        let name = if *uses == 1 {
            m.name.clone()
        } else {
            format!("{}#{uses}", m.name)
        };
        models.push(Model::new(
            name,
            format!("{}:{}", file.display(), m.name),
            m.mesh,
            m.albedo_map,
        ));
    }
    let mut instances = Vec::with_capacity(gltf.instances.len());
    let mut labels = Vec::with_capacity(gltf.instances.len());
    for i in &gltf.instances {
        labels.push(match gltf.node_names.get(i.node as usize) {
            Some(Some(name)) => format!("glTF node {} `{name}`", i.node),
            _ => format!("glTF node {}", i.node),
        });
        let t = i.transform.w_axis.truncate();
        if t.abs().max_element() > limit {
            return Err(too_far(format!(
                "node {} is placed at {t}, beyond ±{limit} units",
                i.node
            )));
        }
        instances.push(Instance {
            model: i.model,
            transform: i.transform,
            tint: Vec3::ONE,
        });
    }
    Ok(Scene {
        models,
        instances,
        ground: plan.ground,
        model_bounds: Default::default(),
        instance_labels: format::InstanceLabels(labels),
    })
}

/// Object → world transform of a park placement: translate · rotate_y.
pub fn park_transform(p: &park::Placement) -> Mat4 {
    Mat4::from_translation(Vec3::from(p.translation))
        * Mat4::from_rotation_y(p.yaw_deg.to_radians())
}

/// x–z extent (width, depth) of a normalised mesh.
/// An instance listed in the manifest (`Instances`, a park's `placed`).
fn listed_instance(spec: &InstanceSpec, model: u32) -> Instance {
    Instance {
        model,
        transform: Mat4::from_translation(Vec3::from(spec.translation))
            * Mat4::from_rotation_y(spec.rotation_y_deg.to_radians())
            * Mat4::from_scale(Vec3::splat(spec.scale)),
        tint: Vec3::from(spec.tint),
    }
}

/// Whether the x–z circles around two instances' footprints meet: each circle is
/// centred on the instance's base and has its model's [`footprint_radius`] (`reach`,
/// per model) times its scale as radius, so it holds the footprint at any yaw.
/// Conservative: two objects whose circles meet may still stand clear of each other.
fn footprints_overlap(reach: &[f32], a: &Instance, b: &Instance) -> bool {
    let radius = |i: &Instance| reach[i.model as usize] * i.transform.x_axis.truncate().length();
    let (pa, pb) = (a.transform.w_axis, b.transform.w_axis);
    (pa.x - pb.x).hypot(pa.z - pb.z) < radius(a) + radius(b)
}

/// Half the diagonal of a normalised model's x–z [`footprint`]: the radius of the
/// circle around its base centre that holds it at any yaw.
fn footprint_radius(mesh: &Mesh) -> f32 {
    let [w, d] = footprint(mesh);
    0.5 * w.hypot(d)
}

pub fn footprint(mesh: &Mesh) -> [f32; 2] {
    mesh.bounds()
        .map_or([0.0; 2], |(lo, hi)| [hi[0] - lo[0], hi[2] - lo[2]])
}
