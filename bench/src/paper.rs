//! The paper's published numbers (000 §4, Tables 2–8): `bench/data/paper-tables.ron`,
//! one typed field per row, each row carrying the paper's row caption and each table
//! its number and title, so every figure BENCHMARKS.md sets beside ours names where
//! it comes from. The file is compiled in ([`paper`]); [`PaperTables::parse`] checks
//! that every row has one value per column of its table.

use serde::Deserialize;
use std::sync::OnceLock;

/// The data file, as compiled in.
pub const PAPER_TABLES_RON: &str = include_str!("../data/paper-tables.ron");

/// One row of a paper table: the paper's caption and its values, one per column.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PaperRow<T = f64> {
    pub row: String,
    pub values: Vec<T>,
}

/// Our scene name and the paper's (`park-2m` ↔ `2M`).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneName {
    pub ours: String,
    pub paper: String,
}

/// The scene totals (§4.1, the scenes of Table 2).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenePolygons {
    pub table: String,
    pub title: String,
    pub columns: Vec<String>,
    pub total: PaperRow,
}

/// Tables 3, 4 and 5: one parameter swept on the 4M scene, a column per value.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepTable {
    pub table: String,
    pub title: String,
    /// The paper's scene-setting name, e.g. `4M-50-T_s-4.5`.
    pub setting: String,
    pub columns: Vec<String>,
    /// The swept value of each column.
    pub parameter: PaperRow,
    /// Table 3 only.
    #[serde(default)]
    pub sv_clustered_percent: Option<PaperRow>,
    #[serde(default)]
    pub sv_single_percent: Option<PaperRow>,
    #[serde(default)]
    pub mv_percent: Option<PaperRow>,
    /// Table 5 only: the grid of each cell size.
    #[serde(default)]
    pub viewcells: Option<PaperRow<String>>,
    pub polygons_inside_a_viewcell: PaperRow,
    pub polygons_sv_and_mv: PaperRow,
    pub polygons_for_a_viewcell: PaperRow,
    /// "Simplified:original" as 1:x.
    pub simplified_to_original: PaperRow,
    pub fps: PaperRow,
    pub psnr_db: PaperRow,
    /// "Avg. polygon count inside view frustum" (outside the parenthesis).
    pub polygons_in_frustum: PaperRow,
}

impl SweepTable {
    /// The column of the swept value `v`, if the paper has one.
    pub fn column_of(&self, v: f64) -> Option<usize> {
        self.parameter
            .values
            .iter()
            .position(|p| (p - v).abs() < 1e-6)
    }
}

/// Table 6: configurations A, B, C on the 8M scene.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Table6 {
    pub table: String,
    pub title: String,
    pub columns: Vec<String>,
    pub polygons: PaperRow,
    pub frame_time_ms: PaperRow,
    pub fps: PaperRow,
    pub speedup: PaperRow,
}

/// Table 7: configuration C on the 2M, 4M and 8M scenes.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Table7 {
    pub table: String,
    pub title: String,
    pub columns: Vec<String>,
    pub polygons_inside_a_viewcell: PaperRow,
    pub polygons_sv_and_mv: PaperRow,
    pub polygons_for_a_viewcell: PaperRow,
    pub simplified_to_original: PaperRow,
    pub fps: PaperRow,
    pub psnr_db: PaperRow,
    pub texture_kb_in_frustum: PaperRow,
    pub polygons_in_frustum: PaperRow,
}

/// Table 8: storage and cell load time on the 2M, 4M and 8M scenes.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Table8 {
    pub table: String,
    pub title: String,
    pub columns: Vec<String>,
    pub sv_mv_mb: PaperRow,
    pub textures_mb: PaperRow,
    pub total_mb: PaperRow,
    pub original_meshes_mb: PaperRow,
    pub cell_polygons_kb: PaperRow,
    pub cell_textures_kb: PaperRow,
    pub cell_total_kb: PaperRow,
    pub load_ms_55: PaperRow,
    pub load_ms_35: PaperRow,
}

/// Every number of the paper the tables use.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PaperTables {
    pub source: String,
    /// Our park scenes and the paper's names, in the paper's column order.
    pub scenes: Vec<SceneName>,
    pub scene_polygons: ScenePolygons,
    pub table3: SweepTable,
    pub table4: SweepTable,
    pub table5: SweepTable,
    pub table6: Table6,
    pub table7: Table7,
    pub table8: Table8,
}

/// A data file that does not read or does not add up.
#[derive(Debug, thiserror::Error)]
pub enum PaperError {
    #[error("paper-tables.ron: {0}")]
    Parse(#[from] ron::error::SpannedError),
    #[error("paper-tables.ron: {table} row {row:?} has {found} values for {expected} columns")]
    Columns {
        table: String,
        row: String,
        expected: usize,
        found: usize,
    },
}

impl PaperTables {
    /// Parses and checks a data file (see `bench/data/paper-tables.ron`).
    pub fn parse(text: &str) -> Result<PaperTables, PaperError> {
        let t: PaperTables = ron::from_str(text)?;
        t.check()?;
        Ok(t)
    }

    fn check(&self) -> Result<(), PaperError> {
        fn rows<T>(
            table: &str,
            columns: usize,
            rows: &[Option<&PaperRow<T>>],
        ) -> Result<(), PaperError> {
            for r in rows.iter().flatten() {
                if r.values.len() != columns {
                    return Err(PaperError::Columns {
                        table: table.to_string(),
                        row: r.row.clone(),
                        expected: columns,
                        found: r.values.len(),
                    });
                }
            }
            Ok(())
        }
        let scenes = self.scenes.len();
        let p = &self.scene_polygons;
        rows(&p.table, scenes, &[Some(&p.total)])?;
        for t in [&self.table3, &self.table4, &self.table5] {
            let n = t.columns.len();
            rows(
                &t.table,
                n,
                &[
                    Some(&t.parameter),
                    t.sv_clustered_percent.as_ref(),
                    t.sv_single_percent.as_ref(),
                    t.mv_percent.as_ref(),
                    Some(&t.polygons_inside_a_viewcell),
                    Some(&t.polygons_sv_and_mv),
                    Some(&t.polygons_for_a_viewcell),
                    Some(&t.simplified_to_original),
                    Some(&t.fps),
                    Some(&t.psnr_db),
                    Some(&t.polygons_in_frustum),
                ],
            )?;
            rows(&t.table, n, &[t.viewcells.as_ref()])?;
        }
        let t = &self.table6;
        rows(
            &t.table,
            t.columns.len(),
            &[
                Some(&t.polygons),
                Some(&t.frame_time_ms),
                Some(&t.fps),
                Some(&t.speedup),
            ],
        )?;
        let t = &self.table7;
        rows(
            &t.table,
            scenes,
            &[
                Some(&t.polygons_inside_a_viewcell),
                Some(&t.polygons_sv_and_mv),
                Some(&t.polygons_for_a_viewcell),
                Some(&t.simplified_to_original),
                Some(&t.fps),
                Some(&t.psnr_db),
                Some(&t.texture_kb_in_frustum),
                Some(&t.polygons_in_frustum),
            ],
        )?;
        let t = &self.table8;
        rows(
            &t.table,
            scenes,
            &[
                Some(&t.sv_mv_mb),
                Some(&t.textures_mb),
                Some(&t.total_mb),
                Some(&t.original_meshes_mb),
                Some(&t.cell_polygons_kb),
                Some(&t.cell_textures_kb),
                Some(&t.cell_total_kb),
                Some(&t.load_ms_55),
                Some(&t.load_ms_35),
            ],
        )?;
        Ok(())
    }

    /// The scene-indexed values of a row as the three columns 2M, 4M, 8M.
    pub fn per_scene(row: &PaperRow) -> [f64; 3] {
        [row.values[0], row.values[1], row.values[2]]
    }
}

/// The compiled-in data file, parsed once (a unit test proves it parses).
pub fn paper() -> &'static PaperTables {
    static PAPER: OnceLock<PaperTables> = OnceLock::new();
    PAPER.get_or_init(|| {
        PaperTables::parse(PAPER_TABLES_RON).unwrap_or_else(|e| panic!("built-in {e}"))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_data_file_reads_and_adds_up() {
        let p = PaperTables::parse(PAPER_TABLES_RON).unwrap();
        assert_eq!(p.scenes.len(), 3);
        assert_eq!(p.scenes[1].ours, "park-4m");
        assert_eq!(p.table7.psnr_db.values, [44.92, 39.54, 37.34]);
        assert_eq!(p.table7.psnr_db.row, "Avg. PSNR (dB)");
        assert_eq!(p.table8.total_mb.values[2], 1260.0);
        assert_eq!(
            p.table5.viewcells.as_ref().unwrap().values,
            ["22 × 24", "11 × 12"]
        );
        assert_eq!(p.table3.column_of(5.0), Some(1));
        assert_eq!(p.table4.column_of(4.5), Some(1));
        assert_eq!(p.table5.column_of(75.0), None);
        assert!(p.table4.sv_clustered_percent.is_none());
    }

    /// The values the generator used when they were Rust constants (pipeline
    /// bench_tables.rs up to issue 14), spot-checked per table.
    #[test]
    fn the_numbers_are_the_former_constants() {
        let p = paper();
        assert_eq!(
            p.scene_polygons.total.values,
            [2_017_700.0, 4_188_885.0, 8_004_863.0]
        );
        assert_eq!(
            p.table3.sv_clustered_percent.as_ref().unwrap().values[1],
            18.7
        );
        assert_eq!(
            p.table3.polygons_sv_and_mv.values,
            [40_742.0, 39_981.0, 39_360.0]
        );
        assert_eq!(p.table4.simplified_to_original.values, [75.4, 85.0, 94.1]);
        assert_eq!(p.table5.polygons_in_frustum.values, [13_102.0, 17_457.0]);
        assert_eq!(p.table6.frame_time_ms.values, [1_247.0, 349.1, 4.54]);
        assert_eq!(
            p.table7.polygons_in_frustum.values,
            [4_548.0, 13_102.0, 23_580.0]
        );
        assert_eq!(p.table8.cell_textures_kb.values, [481.2, 1_011.0, 1_965.0]);
        assert_eq!(p.table8.load_ms_35.values, [15.8, 33.3, 64.4]);
    }

    #[test]
    fn a_row_with_a_missing_value_is_refused_with_its_table_and_row() {
        let text = PAPER_TABLES_RON.replace("values: [10.0, 21.2, 41.0]", "values: [10.0, 21.2]");
        let e = PaperTables::parse(&text).unwrap_err().to_string();
        assert!(
            e.contains("Table 8") && e.contains("55 MB/s") && e.contains("2 values for 3"),
            "{e}"
        );
        assert!(PaperTables::parse("(source: \"x\")").is_err());
    }
}
