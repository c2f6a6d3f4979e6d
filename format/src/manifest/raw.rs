//! Stage 1 of the manifest parse (STYLE.md habit 8): the raw mirror of the file,
//! serde structs that accept exactly the manifest's syntax (unknown fields refused),
//! and the way back from a plan to a manifest's text ([`write_instances_manifest`]).

use super::*;

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawManifest {
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "bare"
    )]
    pub(super) name: Option<String>,
    /// Required, except for a `Tiled` scene (whose ground is its tiles').
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "bare"
    )]
    pub(super) ground: Option<RawGround>,
    pub(super) scene: RawScene,
    pub(super) cells: RawCells,
    #[serde(default)]
    pub(super) bake: RawBake,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "bare"
    )]
    pub(super) cells_per_job: Option<u32>,
    /// Objects wider than two cells split into per-cell chunks (`scene::chunk`);
    /// default true.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "bare"
    )]
    pub(super) split_wide_objects: Option<bool>,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "bare"
    )]
    pub(super) output: Option<String>,
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawGround {
    pub(super) min: [f32; 2],
    pub(super) max: [f32; 2],
}

#[derive(Deserialize, Serialize)]
pub(super) enum RawScene {
    Park(RawPark),
    Instances(Vec<RawInstance>),
    City(RawCity),
    Gltf(RawGltf),
    Tiled(RawTiled),
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawTiled {
    pub(super) manifest: String,
    pub(super) tiles: u32,
}

/// `Gltf("file.glb")` or `Gltf((file: "file.glb", objects: Parents))`.
#[derive(Serialize)]
#[serde(untagged)]
pub(super) enum RawGltf {
    File(String),
    Spec(RawGltfSpec),
}

/// A string is a file, a struct a [`RawGltfSpec`]. Written out rather than
/// `#[serde(untagged)]`: an untagged enum buffers its input, and a buffered RON
/// enum variant (`objects: Nodes`) reads as a unit, i.e. as no value at all.
impl<'de> Deserialize<'de> for RawGltf {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Either;
        impl<'de> serde::de::Visitor<'de> for Either {
            type Value = RawGltf;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a glTF file name, or (file: \"…\", objects: …)")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<RawGltf, E> {
                Ok(RawGltf::File(v.to_string()))
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<RawGltf, A::Error> {
                RawGltfSpec::deserialize(serde::de::value::MapAccessDeserializer::new(map))
                    .map(RawGltf::Spec)
            }
        }
        d.deserialize_any(Either)
    }
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawGltfSpec {
    pub(super) file: String,
    /// Kept for issue 18's manifests: `true` is `objects: Parents`.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub(super) group_by_parent: bool,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(super) objects: Option<crate::model_source::GltfObjects>,
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawCity {
    pub(super) seed: u64,
    pub(super) block_size: f32,
    pub(super) street_width: f32,
    #[serde(default = "default_buildings_per_block")]
    pub(super) buildings_per_block: u32,
    pub(super) min_height: f32,
    pub(super) max_height: f32,
    #[serde(default = "default_floor_height")]
    pub(super) floor_height: f32,
    #[serde(default = "default_variants")]
    pub(super) variants: u32,
    #[serde(default)]
    pub(super) props: Vec<RawParkModel>,
    #[serde(default = "unit_tint")]
    pub(super) tint_min: [f32; 3],
    #[serde(default = "unit_tint")]
    pub(super) tint_max: [f32; 3],
}

pub(super) fn default_buildings_per_block() -> u32 {
    2
}

pub(super) fn default_floor_height() -> f32 {
    3.5
}

pub(super) fn default_variants() -> u32 {
    16
}

#[derive(Deserialize, Serialize)]
pub(super) enum RawModelSource {
    File(String),
    Procedural(String),
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawPark {
    pub(super) seed: u64,
    pub(super) models: Vec<RawParkModel>,
    #[serde(default = "unit_tint")]
    pub(super) tint_min: [f32; 3],
    #[serde(default = "unit_tint")]
    pub(super) tint_max: [f32; 3],
    #[serde(default)]
    pub(super) placed: Vec<RawInstance>,
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawParkModel {
    pub(super) model: RawModelSource,
    pub(super) count: u32,
    pub(super) target_height: f32,
    #[serde(default)]
    pub(super) pre_rotation_deg: [f32; 3],
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawInstance {
    pub(super) model: RawModelSource,
    pub(super) target_height: f32,
    pub(super) translation: [f32; 3],
    pub(super) rotation_y_deg: f32,
    #[serde(default = "unit_scale")]
    pub(super) scale: f32,
    #[serde(default = "unit_tint")]
    pub(super) tint: [f32; 3],
    #[serde(default)]
    pub(super) pre_rotation_deg: [f32; 3],
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawCells {
    pub(super) cell_size: f32,
    pub(super) min_eye_height: f32,
    pub(super) max_eye_height: f32,
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub(super) struct RawBake {
    pub(super) image_res: u32,
    pub(super) self_occluding_tolerance_px: f32,
    pub(super) edge_length_tolerance_px: f32,
    pub(super) t_c0: f32,
    pub(super) t_c1: f32,
    pub(super) clustering: bool,
    pub(super) occlusion_culling: bool,
    pub(super) max_deviation_px: f32,
    pub(super) far_field: bool,
    pub(super) far_levels: u32,
    pub(super) merge_level: u32,
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "bare")]
    pub(super) quality: Option<RawQuality>,
    pub(super) quality_check: bool,
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub(super) struct RawQuality {
    pub(super) min_psnr_db: f64,
    pub(super) min_ssim: f64,
}

impl Default for RawQuality {
    fn default() -> Self {
        let d = QualityFloor::default();
        RawQuality {
            min_psnr_db: d.min_psnr_db,
            min_ssim: d.min_ssim,
        }
    }
}

impl Default for RawBake {
    fn default() -> Self {
        let d = BakeParams::default();
        RawBake {
            image_res: d.image_res,
            self_occluding_tolerance_px: d.self_occluding_tolerance_px,
            edge_length_tolerance_px: d.edge_length_tolerance_px,
            t_c0: d.t_c0,
            t_c1: d.t_c1,
            clustering: d.clustering,
            occlusion_culling: d.occlusion_culling,
            max_deviation_px: d.max_deviation_px,
            far_field: d.far_field,
            far_levels: d.far_levels,
            merge_level: d.merge_level,
            quality: None,
            quality_check: d.quality_check,
        }
    }
}

pub(super) fn unit_tint() -> [f32; 3] {
    [1.0; 3]
}

pub(super) fn unit_scale() -> f32 {
    1.0
}

/// Writes an `Option` field as its bare value: the parser reads with
/// `implicit_some`, and `skip_serializing_if` leaves out a `None`.
pub(super) fn bare<T: Serialize, S: serde::Serializer>(
    v: &Option<T>,
    s: S,
) -> Result<S::Ok, S::Error> {
    match v {
        Some(v) => v.serialize(s),
        None => s.serialize_none(),
    }
}

impl From<&BakeParams> for RawBake {
    /// Every bake parameter (the destructuring names each field, so a new one cannot
    /// be forgotten by the manifest writer).
    fn from(b: &BakeParams) -> RawBake {
        let BakeParams {
            image_res,
            self_occluding_tolerance_px,
            edge_length_tolerance_px,
            t_c0,
            t_c1,
            clustering,
            occlusion_culling,
            max_deviation_px,
            far_field,
            far_levels,
            merge_level,
            quality,
            quality_check,
        } = *b;
        RawBake {
            image_res,
            self_occluding_tolerance_px,
            edge_length_tolerance_px,
            t_c0,
            t_c1,
            clustering,
            occlusion_culling,
            max_deviation_px,
            far_field,
            far_levels,
            merge_level,
            quality: quality.map(
                |QualityFloor {
                     min_psnr_db,
                     min_ssim,
                 }| RawQuality {
                    min_psnr_db,
                    min_ssim,
                },
            ),
            quality_check,
        }
    }
}

/// A path as the manifest writes it: absolute, so the text works wherever it is put.
pub(super) fn absolute_text(p: &Path) -> String {
    std::path::absolute(p)
        .unwrap_or_else(|_| p.to_path_buf())
        .display()
        .to_string()
}

impl From<&InstanceSpec> for RawInstance {
    fn from(i: &InstanceSpec) -> RawInstance {
        let InstanceSpec {
            model,
            pre_rotation_deg,
            target_height,
            translation,
            rotation_y_deg,
            scale,
            tint,
        } = i;
        RawInstance {
            model: match model {
                ModelSource::File(p) => RawModelSource::File(absolute_text(p)),
                ModelSource::Procedural(n) => RawModelSource::Procedural(n.clone()),
            },
            target_height: *target_height,
            translation: *translation,
            rotation_y_deg: *rotation_y_deg,
            scale: *scale,
            tint: *tint,
            pre_rotation_deg: *pre_rotation_deg,
        }
    }
}

/// The manifest text of `plan` with its scene replaced by `instances` (`pipeline
/// scene --as-instances`): written by serde from the raw types the parser reads, so
/// parsing the text gives back every parameter of `plan` — name, ground, cells,
/// bake (`quality_check` and `quality` included), cells per job, output (absolute)
/// — and the instances. `comment` becomes the first line(s), each prefixed `// `.
/// Numbers are written in Rust's shortest round-trip form, paths absolute.
pub fn write_instances_manifest(plan: &Plan, instances: &[InstanceSpec], comment: &str) -> String {
    let Plan {
        manifest_path: _,
        name,
        scene: _,
        ground,
        cells,
        bake,
        cells_per_job,
        split_wide_objects,
        output,
    } = plan;
    let CellParams {
        cell_size,
        min_eye_height,
        max_eye_height,
    } = *cells;
    let raw = RawManifest {
        name: Some(name.clone()),
        ground: Some(RawGround {
            min: ground.min,
            max: ground.max,
        }),
        scene: RawScene::Instances(instances.iter().map(RawInstance::from).collect()),
        cells: RawCells {
            cell_size,
            min_eye_height,
            max_eye_height,
        },
        bake: RawBake::from(bake),
        cells_per_job: Some(*cells_per_job),
        split_wide_objects: (!split_wide_objects).then_some(false),
        output: Some(absolute_text(output)),
    };
    // Depth 2: each instance, and `quality`, on one line; every other field on its own.
    let config = ron::ser::PrettyConfig::new()
        .depth_limit(2)
        .indentor("    ".to_string());
    let body = ron::ser::to_string_pretty(&raw, config).expect("a manifest serialises");
    let mut text: String = comment.lines().map(|l| format!("// {l}\n")).collect();
    text += &body;
    text.push('\n');
    text
}
