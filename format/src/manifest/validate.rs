//! Stage 2 of the manifest parse: validation and resolution of the raw manifest into
//! a [`Plan`], every error naming its field and its `line:column`
//! ([`crate::field_positions`]).

use super::*;

pub(super) struct Validator<'a> {
    pub(super) path: &'a Path,
    pub(super) positions: &'a FieldPositions,
    /// The `--set` overrides applied to the raw manifest: an error at a field one of
    /// them set names the override instead of a place in the file.
    pub(super) overrides: &'a [Override],
}

impl Validator<'_> {
    /// An error at the field `field` (dotted path): at the last override that set
    /// it, else at its place in the file.
    pub(super) fn error(&self, field: &str, message: String) -> ManifestError {
        match self.overrides.iter().rev().find(|o| o.key == field) {
            Some(o) => self.override_error(o, field, message),
            None => {
                let at = self.positions.nearest_position(field);
                ManifestError::At {
                    path: self.path.to_path_buf(),
                    line: at.line,
                    column: at.column,
                    field: field.to_string(),
                    message: format!("`{field}` {message}"),
                }
            }
        }
    }

    pub(super) fn override_error(
        &self,
        o: &Override,
        field: &str,
        message: String,
    ) -> ManifestError {
        ManifestError::Override {
            path: self.path.to_path_buf(),
            set: o.to_string(),
            field: field.to_string(),
            message: format!("`{field}` {message}"),
        }
    }

    /// A [`Violation`] of a shared rule, at its field.
    pub(super) fn violation(&self, v: Violation) -> ManifestError {
        self.error(&v.field, v.message)
    }

    /// A [`Violation`] of the cell rule: at the override that set its field, else at
    /// the last cell override (eye heights out of order name the max, but setting
    /// the min may be what broke them), else at its place in the file.
    pub(super) fn cell_violation(&self, v: Violation) -> ManifestError {
        let set_field = self.overrides.iter().any(|o| o.key == v.field);
        match self
            .overrides
            .iter()
            .rev()
            .find(|o| o.key.starts_with("cells."))
        {
            Some(o) if !set_field => self.override_error(o, &v.field, v.message),
            _ => self.violation(v),
        }
    }

    /// An object height: > 0, at least [`MIN_LENGTH`], at most [`MAX_COORDINATE`].
    pub(super) fn height(&self, field: &str, v: f32) -> Result<f32, ManifestError> {
        let v = self.positive(field, v)?;
        if !(MIN_LENGTH..=MAX_COORDINATE).contains(&v) {
            return Err(self.error(
                field,
                format!("must be in {MIN_LENGTH}..={MAX_COORDINATE} units, found {v}"),
            ));
        }
        Ok(v)
    }

    /// A position: finite components within ±[`MAX_COORDINATE`].
    pub(super) fn coordinates3(&self, field: &str, v: [f32; 3]) -> Result<[f32; 3], ManifestError> {
        for x in v {
            check_coordinate(field, x).map_err(|e| self.violation(e))?;
        }
        Ok(v)
    }

    pub(super) fn finite(&self, field: &str, v: f32) -> Result<f32, ManifestError> {
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.error(field, format!("must be a finite number, found {v}")))
        }
    }

    pub(super) fn positive(&self, field: &str, v: f32) -> Result<f32, ManifestError> {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(self.error(field, format!("must be > 0, found {v}")))
        }
    }

    pub(super) fn non_negative(&self, field: &str, v: f32) -> Result<f32, ManifestError> {
        if v.is_finite() && v >= 0.0 {
            Ok(v)
        } else {
            Err(self.error(field, format!("must be >= 0, found {v}")))
        }
    }

    pub(super) fn finite3(&self, field: &str, v: [f32; 3]) -> Result<[f32; 3], ManifestError> {
        for x in v {
            self.finite(field, x)?;
        }
        Ok(v)
    }

    pub(super) fn tint(&self, field: &str, v: [f32; 3]) -> Result<[f32; 3], ManifestError> {
        if v.iter()
            .all(|x| x.is_finite() && (0.0..=MAX_TINT).contains(x))
        {
            Ok(v)
        } else {
            Err(self.error(
                field,
                format!("must have components in 0..={MAX_TINT}, found {v:?}"),
            ))
        }
    }

    /// The manifest's folder, against which relative paths resolve.
    pub(super) fn base_dir(&self) -> PathBuf {
        match self.path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        }
    }

    /// One `Instances` entry (or a park's `placed` one) at `at` (`scene[3]`).
    pub(super) fn instance(
        &self,
        at: &str,
        inst: RawInstance,
    ) -> Result<InstanceSpec, ManifestError> {
        let f = |name: &str| format!("{at}.{name}");
        let spec = InstanceSpec {
            model: self.model(&f("model"), inst.model)?,
            pre_rotation_deg: self.finite3(&f("pre_rotation_deg"), inst.pre_rotation_deg)?,
            target_height: self.height(&f("target_height"), inst.target_height)?,
            translation: self.coordinates3(&f("translation"), inst.translation)?,
            rotation_y_deg: self.finite(&f("rotation_y_deg"), inst.rotation_y_deg)?,
            scale: self.positive(&f("scale"), inst.scale)?,
            tint: self.tint(&f("tint"), inst.tint)?,
        };
        // The placed object's height, in f64 so the product cannot overflow.
        let height = f64::from(spec.target_height) * f64::from(spec.scale);
        if !(f64::from(MIN_LENGTH)..=f64::from(MAX_COORDINATE)).contains(&height) {
            return Err(self.error(
                &f("scale"),
                format!(
                    "makes the object {height} units tall (target_height {} × \
                     scale {}), outside {MIN_LENGTH}..={MAX_COORDINATE}",
                    spec.target_height, spec.scale
                ),
            ));
        }
        Ok(spec)
    }

    pub(super) fn model(
        &self,
        field: &str,
        raw: RawModelSource,
    ) -> Result<ModelSource, ManifestError> {
        match raw {
            RawModelSource::File(file) => {
                if file.is_empty() {
                    return Err(self.error(field, "names an empty file path".into()));
                }
                let resolved = self.base_dir().join(&file);
                let supported = crate::model_source::ModelFormat::from_path(&resolved).is_some();
                if !supported {
                    return Err(self.error(
                        field,
                        format!(
                            "names `{file}`, an unsupported model format (expected one of {})",
                            crate::model_source::SUPPORTED_EXTENSIONS.join(", ")
                        ),
                    ));
                }
                if !resolved.is_file() {
                    return Err(self.error(
                        field,
                        format!(
                            "names `{file}`, which does not exist (resolved: {})",
                            resolved.display()
                        ),
                    ));
                }
                Ok(ModelSource::File(resolved))
            }
            RawModelSource::Procedural(name) => {
                if crate::model_source::PROCEDURAL_NAMES.contains(&name.as_str()) {
                    Ok(ModelSource::Procedural(name))
                } else {
                    Err(self.error(
                        field,
                        format!(
                            "names an unknown procedural model `{name}`, expected one of {}",
                            crate::model_source::PROCEDURAL_NAMES.join(", ")
                        ),
                    ))
                }
            }
        }
    }

    /// `bake.quality` (issue 16): PSNR in 0..=100 dB, SSIM in 0..=1.
    pub(super) fn quality(&self, q: RawQuality) -> Result<QualityFloor, ManifestError> {
        check_quality(q.min_psnr_db, q.min_ssim)
            .map_err(|(field, what)| self.error(&format!("bake.quality.{field}"), what))?;
        Ok(QualityFloor {
            min_psnr_db: q.min_psnr_db,
            min_ssim: q.min_ssim,
        })
    }

    /// A glTF scene file: a `.gltf` or `.glb` that exists.
    pub(super) fn gltf(
        &self,
        file: String,
        group_by_parent: bool,
        objects: Option<crate::model_source::GltfObjects>,
    ) -> Result<SceneSpec, ManifestError> {
        use crate::model_source::GltfObjects;
        let objects = match (group_by_parent, objects) {
            (false, objects) => objects.unwrap_or_default(),
            (true, None | Some(GltfObjects::Parents)) => GltfObjects::Parents,
            (true, Some(other)) => {
                return Err(self.error(
                    "scene",
                    format!(
                        "says both `group_by_parent: true` and `objects: {other:?}`; \
                         `group_by_parent: true` is `objects: Parents`: keep one"
                    ),
                ))
            }
        };
        if file.is_empty() {
            return Err(self.error("scene", "names an empty file path".into()));
        }
        let resolved = self.base_dir().join(&file);
        if crate::model_source::ModelFormat::from_path(&resolved)
            != Some(crate::model_source::ModelFormat::Gltf)
        {
            return Err(self.error(
                "scene",
                format!("names `{file}`; a glTF scene must be a .gltf or .glb file"),
            ));
        }
        if !resolved.is_file() {
            return Err(self.error(
                "scene",
                format!(
                    "names `{file}`, which does not exist (resolved: {})",
                    resolved.display()
                ),
            ));
        }
        Ok(SceneSpec::Gltf(GltfSpec {
            file: resolved,
            objects,
        }))
    }

    /// A prop list (park models on the pavements), fields under `scene.props[i]`.
    pub(super) fn props(&self, raw: Vec<RawParkModel>) -> Result<Vec<ParkModel>, ManifestError> {
        let mut models = Vec::with_capacity(raw.len());
        for (i, m) in raw.into_iter().enumerate() {
            let f = |name: &str| format!("scene.props[{i}].{name}");
            models.push(ParkModel {
                model: self.model(&f("model"), m.model)?,
                pre_rotation_deg: self.finite3(&f("pre_rotation_deg"), m.pre_rotation_deg)?,
                count: m.count,
                target_height: self.height(&f("target_height"), m.target_height)?,
            });
        }
        Ok(models)
    }

    /// A `Tiled` scene ([`TiledSpec`]): the base manifest parses, is not tiled
    /// itself, has cell size `cell_size`; and the world's ground.
    pub(super) fn tiled(
        &self,
        raw: &RawTiled,
        cell_size: f32,
    ) -> Result<(TiledSpec, Ground), ManifestError> {
        if !(1..=MAX_TILES).contains(&raw.tiles) {
            return Err(self.error(
                "scene.tiles",
                format!("must be in 1..={MAX_TILES}, found {}", raw.tiles),
            ));
        }
        if raw.manifest.is_empty() {
            return Err(self.error("scene.manifest", "names an empty file path".into()));
        }
        let path = self.base_dir().join(&raw.manifest);
        let base = parse_manifest(&path)
            .map_err(|e| self.error("scene.manifest", format!("`{}`: {e}", raw.manifest)))?;
        if matches!(base.scene, SceneSpec::Tiled(_)) {
            return Err(self.error(
                "scene.manifest",
                format!("`{}` is tiled itself; tile its base manifest", raw.manifest),
            ));
        }
        if base.cells.cell_size != cell_size {
            return Err(self.error(
                "cells.cell_size",
                format!(
                    "must equal the tiled manifest's ({}) so that tiles fall on whole grid periods, found {cell_size}",
                    base.cells.cell_size
                ),
            ));
        }
        let invalid = |what: String| self.error("scene", what);
        let [n, m] = base
            .ground
            .hex_grid_dims(cell_size)
            .ok_or_else(|| invalid("the base manifest's ground makes no grid".into()))?;
        let period = [n + n % 2, m];
        let k = u64::from(raw.tiles) - 1;
        let dims = [n + k * period[0], m + k * period[1]];
        let c = f64::from(cell_size);
        let [w, h] = base.ground.size();
        let min = base.ground.min;
        // Same origin (format::grid: the column strip is centred on the ground).
        let w = f64::from(w) + (dims[0] - n) as f64 * 1.5 * c;
        let h = f64::from(h) + (dims[1] - m) as f64 * 3f64.sqrt() * c;
        let ground = Ground {
            min,
            max: [
                (f64::from(min[0]) + w) as f32,
                (f64::from(min[1]) + h) as f32,
            ],
        };
        if ground.hex_grid_dims(cell_size) != Some(dims) {
            return Err(invalid(format!(
                "{} tiles of a {n} × {m} grid make no whole {} × {} grid (rounding); try another count",
                raw.tiles, dims[0], dims[1]
            )));
        }
        let period = [period[0] as u32, period[1] as u32];
        Ok((
            TiledSpec {
                manifest: path,
                tiles: raw.tiles,
                period,
            },
            ground,
        ))
    }

    /// A `City` scene: lengths positive and within the limits, heights ordered,
    /// whole floors, a bounded number of buildings per block and variants.
    pub(super) fn city(&self, c: RawCity) -> Result<SceneSpec, ManifestError> {
        let block_size = self.height("scene.block_size", c.block_size)?;
        let street_width = self.height("scene.street_width", c.street_width)?;
        if !(1..=16).contains(&c.buildings_per_block) {
            return Err(self.error(
                "scene.buildings_per_block",
                format!("must be in 1..=16, found {}", c.buildings_per_block),
            ));
        }
        if !(1..=256).contains(&c.variants) {
            return Err(self.error(
                "scene.variants",
                format!("must be in 1..=256, found {}", c.variants),
            ));
        }
        let min_height = self.height("scene.min_height", c.min_height)?;
        let max_height = self.height("scene.max_height", c.max_height)?;
        if max_height < min_height {
            return Err(self.error(
                "scene.max_height",
                format!("must be >= `min_height` ({min_height}), found {max_height}"),
            ));
        }
        let floor_height = self.height("scene.floor_height", c.floor_height)?;
        // Floors and windows are geometry: bound them so a building stays a mesh.
        let floors = f64::from(max_height) / f64::from(floor_height);
        let columns = f64::from(block_size) / f64::from(floor_height);
        if floor_height > min_height
            || floors * columns > crate::limits::MAX_WINDOWS_PER_FACADE as f64
        {
            return Err(self.error(
                "scene.floor_height",
                format!(
                    "must be at most `min_height` ({min_height}) and leave at most {} windows \
                     on a façade ({floors:.0} floors × {columns:.0} columns), found {floor_height}",
                    crate::limits::MAX_WINDOWS_PER_FACADE
                ),
            ));
        }
        let props = self.props(c.props)?;
        let tint_min = self.tint("scene.tint_min", c.tint_min)?;
        let tint_max = self.tint("scene.tint_max", c.tint_max)?;
        if (0..3).any(|k| tint_min[k] > tint_max[k]) {
            return Err(self.error(
                "scene.tint_max",
                format!(
                    "must be >= `tint_min` per channel, found min {tint_min:?} max {tint_max:?}"
                ),
            ));
        }
        Ok(SceneSpec::City(CitySpec {
            seed: c.seed,
            block_size,
            street_width,
            buildings_per_block: c.buildings_per_block,
            min_height,
            max_height,
            floor_height,
            variants: c.variants,
            props,
            tint_min,
            tint_max,
        }))
    }

    pub(super) fn plan(&self, raw: RawManifest) -> Result<Plan, ManifestError> {
        // Name: given, else the file stem.
        let name = match raw.name {
            Some(n) if n.trim().is_empty() => {
                return Err(self.error("name", "must not be empty".into()))
            }
            Some(n) => n,
            None => self
                .path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .filter(|s| !s.is_empty())
                .unwrap_or_else(|| "scene".into()),
        };

        // Ground rectangle: given, or a `Tiled` scene's tiles'.
        let tiled = match &raw.scene {
            RawScene::Tiled(t) => Some(self.tiled(t, raw.cells.cell_size)?),
            _ => None,
        };
        let ground = match (&raw.ground, &tiled) {
            (Some(_), Some(_)) => {
                return Err(self.error(
                    "ground",
                    "a Tiled scene's ground is its tiles': leave `ground` out".into(),
                ))
            }
            (None, None) => return Err(self.error("ground", "missing".into())),
            (Some(g), None) => Ground {
                min: g.min,
                max: g.max,
            },
            (None, Some((_, g))) => *g,
        };
        check_ground(&ground).map_err(|e| self.violation(e))?;

        // Scene.
        let scene = match raw.scene {
            RawScene::Park(park) => {
                if park.models.is_empty() {
                    return Err(self.error("scene.models", "must list at least one model".into()));
                }
                let mut models = Vec::with_capacity(park.models.len());
                for (i, m) in park.models.into_iter().enumerate() {
                    let f = |name: &str| format!("scene.models[{i}].{name}");
                    models.push(ParkModel {
                        model: self.model(&f("model"), m.model)?,
                        pre_rotation_deg: self
                            .finite3(&f("pre_rotation_deg"), m.pre_rotation_deg)?,
                        count: m.count,
                        target_height: self.height(&f("target_height"), m.target_height)?,
                    });
                }
                if models.iter().all(|m| m.count == 0) {
                    return Err(self.error(
                        "scene.models",
                        "places no instance: every `count` is 0".into(),
                    ));
                }
                let tint_min = self.tint("scene.tint_min", park.tint_min)?;
                let tint_max = self.tint("scene.tint_max", park.tint_max)?;
                if (0..3).any(|k| tint_min[k] > tint_max[k]) {
                    return Err(self.error(
                        "scene.tint_max",
                        format!("must be >= `tint_min` per channel, found min {tint_min:?} max {tint_max:?}"),
                    ));
                }
                let mut placed = Vec::with_capacity(park.placed.len());
                for (i, inst) in park.placed.into_iter().enumerate() {
                    placed.push(self.instance(&format!("scene.placed[{i}]"), inst)?);
                }
                SceneSpec::Park(ParkSpec {
                    seed: park.seed,
                    models,
                    tint_min,
                    tint_max,
                    placed,
                })
            }
            RawScene::City(city) => self.city(city)?,
            RawScene::Gltf(RawGltf::File(file)) => self.gltf(file, false, None)?,
            RawScene::Gltf(RawGltf::Spec(spec)) => {
                self.gltf(spec.file, spec.group_by_parent, spec.objects)?
            }
            RawScene::Tiled(_) => {
                let (spec, _) = tiled.expect("parsed above");
                SceneSpec::Tiled(spec)
            }
            RawScene::Instances(list) => {
                if list.is_empty() {
                    return Err(self.error("scene", "lists no instance".into()));
                }
                let mut instances = Vec::with_capacity(list.len());
                for (i, inst) in list.into_iter().enumerate() {
                    instances.push(self.instance(&format!("scene[{i}]"), inst)?);
                }
                SceneSpec::Instances(instances)
            }
        };

        // Cells: the grid on the ground, eye heights.
        let cells = CellParams {
            cell_size: raw.cells.cell_size,
            min_eye_height: raw.cells.min_eye_height,
            max_eye_height: raw.cells.max_eye_height,
        };
        check_cells(&ground, &cells).map_err(|e| self.cell_violation(e))?;

        // Bake parameters.
        let b = raw.bake;
        if !(16..=16384).contains(&b.image_res) {
            return Err(self.error(
                "bake.image_res",
                format!("must be in 16..=16384, found {}", b.image_res),
            ));
        }
        let bake = BakeParams {
            image_res: b.image_res,
            self_occluding_tolerance_px: self.positive(
                "bake.self_occluding_tolerance_px",
                b.self_occluding_tolerance_px,
            )?,
            edge_length_tolerance_px: self
                .positive("bake.edge_length_tolerance_px", b.edge_length_tolerance_px)?,
            t_c0: self.positive("bake.t_c0", b.t_c0)?,
            t_c1: self.positive("bake.t_c1", b.t_c1)?,
            clustering: b.clustering,
            occlusion_culling: b.occlusion_culling,
            max_deviation_px: self.non_negative("bake.max_deviation_px", b.max_deviation_px)?,
            far_field: b.far_field,
            far_levels: if b.far_levels <= MAX_FAR_LEVELS {
                b.far_levels
            } else {
                return Err(self.error(
                    "bake.far_levels",
                    format!("must be in 0..={MAX_FAR_LEVELS} (0 = every level the grid needs), found {}", b.far_levels),
                ));
            },
            merge_level: if (1..=MAX_FAR_LEVELS + 1).contains(&b.merge_level) {
                b.merge_level
            } else {
                return Err(self.error(
                    "bake.merge_level",
                    format!(
                        "must be in 1..={} ({} = never merge), found {}",
                        MAX_FAR_LEVELS + 1,
                        MAX_FAR_LEVELS + 1,
                        b.merge_level
                    ),
                ));
            },
            quality: b.quality.map(|q| self.quality(q)).transpose()?,
            quality_check: b.quality_check,
        };

        let cells_per_job = raw.cells_per_job.unwrap_or(DEFAULT_CELLS_PER_JOB);
        if cells_per_job == 0 {
            return Err(self.error("cells_per_job", "must be >= 1, found 0".into()));
        }

        let output = match raw.output {
            Some(o) if o.is_empty() => return Err(self.error("output", "must not be empty".into())),
            Some(o) => lexically_normal(&self.base_dir().join(o)),
            None => lexically_normal(&self.base_dir().join("..").join("out").join(&name)),
        };

        Ok(Plan {
            manifest_path: self.path.to_path_buf(),
            name,
            scene,
            ground,
            cells,
            bake,
            cells_per_job,
            split_wide_objects: raw.split_wide_objects.unwrap_or(true),
            output,
        })
    }
}
