//! `base.pack`: everything every cell shares — the models (positions, normals, vertex
//! colours, triangles), the instance table, the hex-grid parameters and the scene
//! fingerprint (DESIGN.md, "Data flow" and "Representations"). Cell packs refer to
//! instances by index into this file's instance table and to vertices by index into
//! the instance's model, so geometry is stored once (paper 000 §3.1.3.3: half-edge
//! collapse keeps original vertices, so a proxy is just a new index buffer).

use super::error::{BadValue, PackError};
use super::layout::{FileKind, SectionKind};
use super::reader::{pod_vec, PackFile};
use super::writer::{
    assemble, SectionData, RAW_ONLY, TRY_TRIANGLES, TRY_ZSTD, TRY_ZSTD_PREFER_RAW,
};
use super::{invalid, malformed};
use crate::manifest::{check_cells, check_ground, CellParams, MAX_COORDINATE, MAX_TINT};
use crate::mesh::Mesh;
use crate::scene::{Ground, Scene};
use bytemuck::{Pod, Zeroable};

super::pod_records! {
    /// Hex-grid parameters the player needs to find the current cell (DESIGN.md,
    /// "Conventions": flat-top hexagons, cell id = row · n_cols + col); stored as they
    /// are, 36 bytes at offset 32 of `base-meta` ([`BaseMetaRecord`]).
    #[derive(PartialEq)]
    pub struct GridParams[36] {
        pub ground_min: [f32; 2],
        pub ground_max: [f32; 2],
        /// Centre-to-corner distance of a cell (the paper's |VV'|).
        pub cell_size: f32,
        pub min_eye_height: f32,
        pub max_eye_height: f32,
        pub n_cols: u32,
        pub n_rows: u32,
    }
}

impl GridParams {
    /// Checks the grid as the manifest's own rules do (`format::manifest::check_ground`
    /// and `check_cells`: finite, bounded ground; cell size > 0 with at most
    /// `MAX_CELLS` cells; `0 <= min_eye_height <= max_eye_height`, all within
    /// `MAX_COORDINATE`) and that `n_cols × n_rows` is the grid they make
    /// (`Ground::hex_grid_dims`). On failure: the byte offset in `base-meta` of the
    /// offending field and what is wrong.
    pub fn validate(&self) -> Result<(), (u64, String)> {
        let ground = Ground {
            min: self.ground_min,
            max: self.ground_max,
        };
        let offset_of = |field: &str| match field {
            "ground.min" => 32,
            "ground.max" => 40,
            "cells.cell_size" => 48,
            "cells.min_eye_height" => 52,
            _ => 56,
        };
        check_ground(&ground).map_err(|v| (offset_of(&v.field), format!("grid: {v}")))?;
        let cells = CellParams {
            cell_size: self.cell_size,
            min_eye_height: self.min_eye_height,
            max_eye_height: self.max_eye_height,
        };
        check_cells(&ground, &cells).map_err(|v| (offset_of(&v.field), format!("grid: {v}")))?;
        let expected = ground.hex_grid_dims(self.cell_size);
        if expected != Some([u64::from(self.n_cols), u64::from(self.n_rows)]) {
            let [n, m] = expected.unwrap_or_default();
            return Err((
                60,
                format!(
                    "grid of {} × {} cells, but cell size {} on the ground {:?}..{:?} \
                     makes {n} × {m}",
                    self.n_cols, self.n_rows, self.cell_size, self.ground_min, self.ground_max
                ),
            ));
        }
        Ok(())
    }
}

/// How far from 1 a stored normal's length may be: normals are unit vectors in f32
/// (issue 32: a zero or unnormalised normal is refused; the shading divides by none).
pub const NORMAL_LENGTH_TOLERANCE: f32 = 0.01;

fn is_unit(n: &[f32; 3]) -> bool {
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    len.is_finite() && (len - 1.0).abs() <= NORMAL_LENGTH_TOLERANCE
}

/// Positions are finite and within ±`MAX_COORDINATE` (normalised models are at most
/// that tall and wide); normals are finite unit vectors. `first` is the index of `positions[0]` in
/// the whole `positions` section.
fn check_vertices(
    positions: &[[f32; 3]],
    normals: &[[f32; 3]],
    first: usize,
) -> Result<(), BadValue> {
    if let Some((k, p)) = positions
        .iter()
        .enumerate()
        .find(|(_, p)| !p.iter().all(|x| x.is_finite() && x.abs() <= MAX_COORDINATE))
    {
        let v = first + k;
        return Err(BadValue(
            SectionKind::POSITIONS,
            (v * 12) as u64,
            format!("vertex {v}: position {p:?} is not finite or beyond ±{MAX_COORDINATE}"),
        ));
    }
    if let Some((k, n)) = normals.iter().enumerate().find(|(_, n)| !is_unit(n)) {
        let v = first + k;
        return Err(BadValue(
            SectionKind::NORMALS,
            (v * 12) as u64,
            format!("vertex {v}: normal {n:?} is not a finite unit vector (length 1 ± {NORMAL_LENGTH_TOLERANCE})"),
        ));
    }
    Ok(())
}

/// Smallest |determinant| of an instance transform's 3 × 3 part: the smallest normal
/// f32, so that only a zero (or subnormal) scale is refused — a uniform scale of 10⁻¹²
/// still passes (manifests bound an object's height to 0.001..=10⁶ units, but a
/// glTF node may scale a model by any amount).
pub const MIN_DETERMINANT: f32 = f32::MIN_POSITIVE;

/// An instance's transform is finite with a translation within ±`MAX_COORDINATE` and
/// an invertible 3 × 3 part; its tint components are in `0..=MAX_TINT`.
fn check_instance(i: usize, transform: &[f32; 16], tint: &[f32; 3]) -> Result<(), BadValue> {
    let record = (i * std::mem::size_of::<InstanceRecord>()) as u64;
    let translation_ok = transform[12..15].iter().all(|x| x.abs() <= MAX_COORDINATE);
    if !(transform.iter().all(|x| x.is_finite()) && translation_ok) {
        return Err(BadValue(
            SectionKind::INSTANCES,
            record,
            format!(
                "instance {i}: transform {transform:?} is not finite or translates beyond \
                 ±{MAX_COORDINATE}"
            ),
        ));
    }
    // The linear part must be invertible: an all-zero or scale-0 transform collapses
    // the model to a point or a plane (issue 32 item 3), and the player's normal
    // matrix divides by it.
    let linear = glam::Mat3::from_cols_array(&[
        transform[0],
        transform[1],
        transform[2],
        transform[4],
        transform[5],
        transform[6],
        transform[8],
        transform[9],
        transform[10],
    ]);
    let det = linear.determinant();
    if det.is_nan() || det.abs() < MIN_DETERMINANT {
        return Err(BadValue(
            SectionKind::INSTANCES,
            record,
            format!(
                "instance {i}: transform {transform:?} is singular (determinant {} of its \
                 3 × 3 part): a model drawn at scale 0",
                det
            ),
        ));
    }
    if !tint.iter().all(|x| (0.0..=MAX_TINT).contains(x)) {
        return Err(BadValue(
            SectionKind::INSTANCES,
            record + 64,
            format!("instance {i}: tint {tint:?} outside 0..={MAX_TINT}"),
        ));
    }
    Ok(())
}

/// One model: its name, content hash and mesh (model space).
#[derive(Clone, Debug, PartialEq)]
pub struct PackedModel {
    pub name: String,
    /// blake3 of the loaded mesh (`format::Model::content_hash`).
    pub content_hash: [u8; 32],
    pub mesh: Mesh,
    /// Base-colour texture and UVs (issue 18; sections `albedo-textures` and
    /// `texcoords`), `None` for an untextured model.
    pub albedo_map: Option<crate::albedo::AlbedoMap>,
}

/// One placed copy of a model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PackedInstance {
    /// Index into [`BasePack::models`].
    pub model: u32,
    /// Object → world, column-major.
    pub transform: [f32; 16],
    /// Linear RGB multiplier of the model's albedo.
    pub tint: [f32; 3],
}

/// The content of `base.pack`.
#[derive(Clone, Debug, PartialEq)]
pub struct BasePack {
    pub scene_fingerprint: [u8; 32],
    pub grid: GridParams,
    pub models: Vec<PackedModel>,
    pub instances: Vec<PackedInstance>,
    /// Optional per-model patch data (issue 17, sections 0x010B–0x010D): `None` when
    /// the pack has none.
    pub patches: Option<super::patches::PatchSet>,
}

super::pod_records! {
    /// Section `base-meta` (80 bytes).
    pub struct BaseMetaRecord[80] {
        pub scene_fingerprint: [u8; 32],
        pub grid: GridParams,
        pub model_count: u32,
        pub instance_count: u32,
        pub reserved: u32,
    }

    /// One entry of section `model-table` (48 bytes). A model's vertices and triangles
    /// follow those of the models before it in `positions`/`normals`/`vertex-colours` and
    /// `triangles`.
    pub struct ModelRecord[48] {
        pub vertex_count: u32,
        pub triangle_count: u32,
        /// Byte range of the name in `model-names` (UTF-8).
        pub name_offset: u32,
        pub name_len: u32,
        pub content_hash: [u8; 32],
    }

    /// One entry of section `instances` (80 bytes).
    pub struct InstanceRecord[80] {
        pub transform: [f32; 16],
        pub tint: [f32; 3],
        pub model: u32,
    }
}

impl BasePack {
    /// The base pack of a scene.
    pub fn from_scene(scene: &Scene, grid: GridParams, scene_fingerprint: [u8; 32]) -> BasePack {
        BasePack {
            scene_fingerprint,
            grid,
            models: scene
                .models
                .iter()
                .map(|m| PackedModel {
                    name: m.name.clone(),
                    content_hash: m.content_hash,
                    mesh: m.mesh.clone(),
                    albedo_map: m.albedo_map.clone(),
                })
                .collect(),
            instances: scene
                .instances
                .iter()
                .map(|i| PackedInstance {
                    model: i.model,
                    transform: i.transform.to_cols_array(),
                    tint: i.tint.to_array(),
                })
                .collect(),
            patches: None,
        }
    }

    /// The pack's bytes (deterministic).
    pub fn encode(&self) -> Result<Vec<u8>, PackError> {
        // 1. Check what the format cannot express, and what the reader would refuse.
        let refuse = |BadValue(section, _, what): BadValue| invalid(format!("{section}: {what}"));
        self.grid
            .validate()
            .map_err(|(_, what)| invalid(format!("base-meta: {what}")))?;
        let model_count =
            u32::try_from(self.models.len()).map_err(|_| invalid("more than 2^32 models"))?;
        let instance_count =
            u32::try_from(self.instances.len()).map_err(|_| invalid("more than 2^32 instances"))?;
        let mut records = Vec::with_capacity(self.models.len());
        let mut names = Vec::new();
        let (mut positions, mut normals, mut colours, mut triangles) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for (i, m) in self.models.iter().enumerate() {
            let mesh = &m.mesh;
            let n = mesh.positions.len();
            if mesh.normals.len() != n || mesh.albedo.len() != n {
                return Err(invalid(format!(
                    "model {i} ({}): {n} positions but {} normals and {} colours",
                    m.name,
                    mesh.normals.len(),
                    mesh.albedo.len()
                )));
            }
            let vertex_count =
                u32::try_from(n).map_err(|_| invalid(format!("model {i}: too many vertices")))?;
            if let Some(t) = mesh
                .triangles
                .iter()
                .find(|t| t.iter().any(|&v| v >= vertex_count))
            {
                return Err(invalid(format!(
                    "model {i} ({}): triangle {t:?} indexes past {n} vertices",
                    m.name
                )));
            }
            check_vertices(&mesh.positions, &mesh.normals, positions.len() / 12).map_err(refuse)?;
            records.push(ModelRecord {
                vertex_count,
                triangle_count: u32::try_from(mesh.triangles.len())
                    .map_err(|_| invalid(format!("model {i}: too many triangles")))?,
                name_offset: u32::try_from(names.len())
                    .map_err(|_| invalid("model names too long"))?,
                name_len: u32::try_from(m.name.len())
                    .map_err(|_| invalid("model name too long"))?,
                content_hash: m.content_hash,
            });
            names.extend_from_slice(m.name.as_bytes());
            positions.extend_from_slice(bytemuck::cast_slice::<_, u8>(&mesh.positions));
            normals.extend_from_slice(bytemuck::cast_slice::<_, u8>(&mesh.normals));
            colours.extend_from_slice(bytemuck::cast_slice::<_, u8>(&mesh.albedo));
            triangles.extend_from_slice(bytemuck::cast_slice::<_, u8>(&mesh.triangles));
        }
        if let Some((i, inst)) = self
            .instances
            .iter()
            .enumerate()
            .find(|(_, x)| x.model >= model_count)
        {
            return Err(invalid(format!(
                "instance {i} refers to model {} of {model_count}",
                inst.model
            )));
        }
        for (i, inst) in self.instances.iter().enumerate() {
            check_instance(i, &inst.transform, &inst.tint).map_err(refuse)?;
        }
        let meta = BaseMetaRecord {
            scene_fingerprint: self.scene_fingerprint,
            grid: self.grid,
            model_count,
            instance_count,
            reserved: 0,
        };
        let instances: Vec<InstanceRecord> = self
            .instances
            .iter()
            .map(|i| InstanceRecord {
                transform: i.transform,
                tint: i.tint,
                model: i.model,
            })
            .collect();

        if let Some(set) = &self.patches {
            let counts: Vec<u32> = records.iter().map(|r| r.triangle_count).collect();
            super::patches::check(set, &counts).map_err(refuse)?;
        }

        // 2. Sections; positions and normals stay raw unless zstd pays (zero-copy).
        let mut sections = vec![
            SectionData::of_records(SectionKind::BASE_META, &[meta], RAW_ONLY),
            SectionData::of_records(SectionKind::MODEL_TABLE, &records, TRY_ZSTD),
            SectionData::new(SectionKind::MODEL_NAMES, names, TRY_ZSTD),
            SectionData::new(SectionKind::POSITIONS, positions, TRY_ZSTD_PREFER_RAW),
            SectionData::new(SectionKind::NORMALS, normals, TRY_ZSTD_PREFER_RAW),
            SectionData::new(SectionKind::VERTEX_COLOURS, colours, TRY_ZSTD),
            SectionData::new(SectionKind::TRIANGLES, triangles, TRY_TRIANGLES),
            SectionData::of_records(SectionKind::INSTANCES, &instances, TRY_ZSTD),
        ];
        // Optional albedo textures and UVs (issue 18), absent for untextured scenes.
        let maps: Vec<_> = self.models.iter().map(|m| m.albedo_map.as_ref()).collect();
        let vertex_counts: Vec<u32> = records.iter().map(|r| r.vertex_count).collect();
        sections.extend(super::albedo_maps::sections(&maps, &vertex_counts)?);
        if let Some(set) = &self.patches {
            sections.extend(super::patches::sections(set));
        }
        assemble(FileKind::Base, &sections)
    }

    /// Decodes a validated pack (every reference and value is checked — the grid
    /// against the manifest's rules, positions, normals, transforms and tints — and
    /// unknown sections are skipped).
    pub fn decode(pack: &PackFile) -> Result<BasePack, PackError> {
        pack.expect_kind(FileKind::Base)?;
        let file = pack.path();
        // 1. Fixed-size metadata.
        let meta: BaseMetaRecord = pack.section_record(SectionKind::BASE_META)?;
        if meta.reserved != 0 {
            return Err(malformed(
                file,
                SectionKind::BASE_META,
                76,
                format!("reserved field is {}, expected 0", meta.reserved),
            ));
        }
        let grid = meta.grid;
        grid.validate()
            .map_err(|(offset, what)| malformed(file, SectionKind::BASE_META, offset, what))?;
        let reject =
            |BadValue(section, offset, what): BadValue| malformed(file, section, offset, what);
        // 2. Tables, checked against the counts.
        let records: Vec<ModelRecord> = pack.section_table(
            SectionKind::MODEL_TABLE,
            meta.model_count,
            "models",
            "base-meta",
        )?;
        let instances: Vec<InstanceRecord> = pack.section_table(
            SectionKind::INSTANCES,
            meta.instance_count,
            "instances",
            "base-meta",
        )?;
        let names = pack.section(SectionKind::MODEL_NAMES)?;
        let positions: Vec<[f32; 3]> = pack.section_vec(SectionKind::POSITIONS)?;
        let normals: Vec<[f32; 3]> = pack.section_vec(SectionKind::NORMALS)?;
        let colours: Vec<[u8; 4]> = pack.section_vec(SectionKind::VERTEX_COLOURS)?;
        let triangles: Vec<[u32; 3]> = pack_triangles(pack, SectionKind::TRIANGLES)?;
        let total_vertices: u64 = records.iter().map(|r| r.vertex_count as u64).sum();
        let total_triangles: u64 = records.iter().map(|r| r.triangle_count as u64).sum();
        for (kind, len) in [
            (SectionKind::POSITIONS, positions.len()),
            (SectionKind::NORMALS, normals.len()),
            (SectionKind::VERTEX_COLOURS, colours.len()),
        ] {
            if len as u64 != total_vertices {
                return Err(malformed(
                    file,
                    kind,
                    0,
                    format!("{len} vertices, the model table says {total_vertices}"),
                ));
            }
        }
        if triangles.len() as u64 != total_triangles {
            return Err(malformed(
                file,
                SectionKind::TRIANGLES,
                0,
                format!(
                    "{} triangles, the model table says {total_triangles}",
                    triangles.len()
                ),
            ));
        }

        check_vertices(&positions, &normals, 0).map_err(reject)?;

        // 3. Models: split the shared arrays, check names and vertex references;
        // optional albedo textures and UVs (issue 18).
        let vertex_counts: Vec<u32> = records.iter().map(|r| r.vertex_count).collect();
        let mut albedo_maps = super::albedo_maps::decode(pack, &vertex_counts)?.into_iter();
        let mut models = Vec::with_capacity(records.len());
        let (mut v0, mut t0) = (0usize, 0usize);
        for (i, r) in records.iter().enumerate() {
            let rec_off = (i * std::mem::size_of::<ModelRecord>()) as u64;
            let name_bytes = super::range_of(&names, r.name_offset as usize, r.name_len as usize)
                .ok_or_else(|| {
                malformed(
                    file,
                    SectionKind::MODEL_TABLE,
                    rec_off,
                    format!("model {i}: name range outside model-names"),
                )
            })?;
            let name = std::str::from_utf8(name_bytes)
                .map_err(|e| {
                    malformed(
                        file,
                        SectionKind::MODEL_NAMES,
                        r.name_offset as u64,
                        format!("model {i}: {e}"),
                    )
                })?
                .to_string();
            let (v1, t1) = (v0 + r.vertex_count as usize, t0 + r.triangle_count as usize);
            let tris = &triangles[t0..t1];
            if let Some(k) = tris
                .iter()
                .position(|t| t.iter().any(|&v| v >= r.vertex_count))
            {
                return Err(malformed(
                    file,
                    SectionKind::TRIANGLES,
                    ((t0 + k) * 12) as u64,
                    format!(
                        "model {i}: triangle {:?} indexes past {} vertices",
                        tris[k], r.vertex_count
                    ),
                ));
            }
            models.push(PackedModel {
                name,
                content_hash: r.content_hash,
                mesh: Mesh {
                    positions: positions[v0..v1].to_vec(),
                    normals: normals[v0..v1].to_vec(),
                    albedo: colours[v0..v1].to_vec(),
                    triangles: tris.to_vec(),
                },
                albedo_map: albedo_maps.next().flatten(),
            });
            (v0, t0) = (v1, t1);
        }

        // 4. Instances.
        let mut out_instances = Vec::with_capacity(instances.len());
        for (i, r) in instances.iter().enumerate() {
            if r.model >= meta.model_count {
                return Err(malformed(
                    file,
                    SectionKind::INSTANCES,
                    (i * std::mem::size_of::<InstanceRecord>() + 76) as u64,
                    format!(
                        "instance {i} refers to model {} of {}",
                        r.model, meta.model_count
                    ),
                ));
            }
            check_instance(i, &r.transform, &r.tint).map_err(reject)?;
            out_instances.push(PackedInstance {
                model: r.model,
                transform: r.transform,
                tint: r.tint,
            });
        }
        // 5. Optional patch data (issue 17).
        let patches = super::patches::decode(pack, records.len()).map_err(reject)?;
        if let Some(set) = &patches {
            let counts: Vec<u32> = records.iter().map(|r| r.triangle_count).collect();
            super::patches::check(set, &counts).map_err(reject)?;
        }
        Ok(BasePack {
            scene_fingerprint: meta.scene_fingerprint,
            grid,
            models,
            instances: out_instances,
            patches,
        })
    }
}

super::pack_file_methods!(BasePack);

/// A u32 index section as triangles.
pub(crate) fn pack_triangles(
    pack: &PackFile,
    kind: SectionKind,
) -> Result<Vec<[u32; 3]>, PackError> {
    let bytes = pack.section(kind)?;
    pod_vec(&bytes, pack.path(), kind)
}
