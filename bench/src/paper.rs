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

/// A paper table whose rows are all numbers: its number, title and column names, then
/// one [`PaperRow`] field a row, and `rows()`, every row in that order (what
/// [`PaperTables::parse`] checks against the columns).
macro_rules! paper_table {
    (
        $(#[$attr:meta])*
        $name:ident { $($(#[$row_attr:meta])* $row:ident,)* }
    ) => {
        $(#[$attr])*
        #[derive(Clone, Debug, PartialEq, Deserialize)]
        #[serde(deny_unknown_fields)]
        pub struct $name {
            pub table: String,
            pub title: String,
            pub columns: Vec<String>,
            $($(#[$row_attr])* pub $row: PaperRow,)*
        }

        impl $name {
            /// Every row, in the order of the fields.
            pub fn rows(&self) -> Vec<&PaperRow> {
                vec![$(&self.$row),*]
            }
        }
    };
}

paper_table! {
    /// The scene totals (§4.1, the scenes of Table 2).
    ScenePolygons { total, }
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

    /// Every numeric row the table has (not `viewcells`).
    pub fn rows(&self) -> Vec<&PaperRow> {
        let optional = [
            &self.sv_clustered_percent,
            &self.sv_single_percent,
            &self.mv_percent,
        ];
        let mut rows = vec![&self.parameter];
        rows.extend(optional.into_iter().flatten());
        rows.extend([
            &self.polygons_inside_a_viewcell,
            &self.polygons_sv_and_mv,
            &self.polygons_for_a_viewcell,
            &self.simplified_to_original,
            &self.fps,
            &self.psnr_db,
            &self.polygons_in_frustum,
        ]);
        rows
    }
}

paper_table! {
    /// Table 6: configurations A, B, C on the 8M scene.
    Table6 {
        polygons,
        frame_time_ms,
        fps,
        speedup,
    }
}

paper_table! {
    /// Table 7: configuration C on the 2M, 4M and 8M scenes.
    Table7 {
        polygons_inside_a_viewcell,
        polygons_sv_and_mv,
        polygons_for_a_viewcell,
        simplified_to_original,
        fps,
        psnr_db,
        texture_kb_in_frustum,
        polygons_in_frustum,
    }
}

paper_table! {
    /// Table 8: storage and cell load time on the 2M, 4M and 8M scenes.
    Table8 {
        sv_mv_mb,
        textures_mb,
        total_mb,
        original_meshes_mb,
        cell_polygons_kb,
        cell_textures_kb,
        cell_total_kb,
        load_ms_55,
        load_ms_35,
    }
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

    /// Every row has one value per column: per column of its own table for Tables
    /// 3–6, per scene for the scene totals and Tables 7 and 8.
    fn check(&self) -> Result<(), PaperError> {
        fn rows<'a, T: 'a>(
            table: &str,
            columns: usize,
            rows: impl IntoIterator<Item = &'a PaperRow<T>>,
        ) -> Result<(), PaperError> {
            for r in rows {
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
        rows(
            &self.scene_polygons.table,
            scenes,
            self.scene_polygons.rows(),
        )?;
        for t in [&self.table3, &self.table4, &self.table5] {
            rows(&t.table, t.columns.len(), t.rows())?;
            rows(&t.table, t.columns.len(), &t.viewcells)?;
        }
        let t = &self.table6;
        rows(&t.table, t.columns.len(), t.rows())?;
        rows(&self.table7.table, scenes, self.table7.rows())?;
        rows(&self.table8.table, scenes, self.table8.rows())?;
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
