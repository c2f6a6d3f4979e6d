//! What the player draws a frame with and what it records of each frame (issue 28):
//! [`DrawOptions`], the switches of the player's frame model (culling tests, tile
//! size, BC textures; `player render|compare|view` flags, written into every
//! `player compare --json` report and every `frames.csv` row), and [`FrameRow`], one
//! row of `player render`'s `frames.csv`, written by the player
//! (`player/src/run.rs`) and read by the benchmark tool (`bench/`, the run files of
//! `scripts/bench.sh`). One definition for both: the player does not link the
//! worker, the benchmark tool does not link the player. player/README.md describes
//! the columns.
//!
//! CSV: a header line ([`FRAMES_CSV_HEADER`]), then one line per frame; the reader
//! ([`parse_frames_csv`]) finds columns by the header, in any order, ignores unknown
//! ones and gives a missing one its default (a file of an older player: no draw
//! options, `draw_calls` 0 for "not counted"). Times are written to the microsecond
//! (`frame_ms`, `stream_ms`) and the tenth of a millisecond (`time_s`), so a row
//! whose figures are at that precision reads back identically.

use serde::{Deserialize, Deserializer, Serialize};

/// Most triangles in one original tile or proxy cluster by default
/// ([`DrawOptions::tile_triangles`]; the judgement behind 16 is in
/// `player/src/patches.rs`, `CLUSTER_TRIANGLES`).
pub const DEFAULT_TILE_TRIANGLES: u32 = 16;

/// The switches of the player's frame model, passed explicitly to the player's
/// renderer and bake (no environment variable is read; `player` flags
/// `--no-patch-bitfields`, `--no-backface`, `--no-frustum`, `--tile-triangles N`,
/// `--no-bc`, `--no-occlusion`). The default is what the player draws without flags; the cone and
/// frustum tests, the tile size and occlusion culling change which triangles are
/// submitted, never a pixel (they are conservative), the bitfields may (paper 002
/// §4).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default)]
pub struct DrawOptions {
    /// Originals: the union of the nearest spherical samples' patch bitfields
    /// (paper 002 §3.3) selects their patches.
    pub patch_bitfields: bool,
    /// Originals and proxies: tiles whose normal cone is wholly back-facing are not
    /// drawn (003 §4.1).
    pub backface: bool,
    /// Originals and proxies: tiles whose box is outside the view frustum are not
    /// drawn (instances and proxies are still culled whole without it).
    pub frustum: bool,
    /// Most triangles in one tile (at least 1): patches and proxy normal clusters
    /// are split into spatial tiles of at most this many at load time.
    pub tile_triangles: u32,
    /// BC1/BC3 capture textures are sampled natively; off, or on an adapter without
    /// `TEXTURE_COMPRESSION_BC`, they are decoded to RGBA8 on the CPU. What reports
    /// record is what was in effect.
    pub bc_textures: bool,
    /// Proxies: tiles hidden behind the frame's originals (a CPU masked depth
    /// buffer of them, 000 §3.2 run-time step (3)) are not drawn. Reports and
    /// files of players before it read as off.
    #[serde(default)]
    pub occlusion: bool,
}

impl Default for DrawOptions {
    fn default() -> DrawOptions {
        DrawOptions {
            patch_bitfields: true,
            backface: true,
            frustum: true,
            tile_triangles: DEFAULT_TILE_TRIANGLES,
            bc_textures: true,
            occlusion: true,
        }
    }
}

impl DrawOptions {
    /// [`DrawOptions::tile_triangles`] as a count, at least 1.
    pub fn tile_size(&self) -> usize {
        self.tile_triangles.max(1) as usize
    }
}

/// One row of `frames.csv`: one frame of `player render`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct FrameRow {
    pub frame: usize,
    /// The path frame's time, seconds.
    pub time_s: f32,
    /// The current cell (`-1` in the CSV, and in the run files of older benchmark
    /// tools, for none).
    #[serde(deserialize_with = "cell_or_negative")]
    pub cell: Option<u32>,
    /// The current cell differs from the previous frame's.
    pub crossing: bool,
    /// GPU submit → done, milliseconds.
    pub frame_ms: f64,
    pub triangles: u64,
    /// Texture bytes of the proxies the frame draws.
    pub texture_bytes: u64,
    pub cache_hits: u64,
    pub cache_misses: u64,
    /// Render-thread streaming work this frame (demand loads, uploads), milliseconds.
    pub stream_ms: f64,
    /// Texture bytes uploaded from the texture queue before this frame (≤ the
    /// per-frame budget unless one texture alone is larger).
    pub uploaded_bytes: u64,
    /// Proxies of the current cell drawn as original geometry (textures queued).
    pub pending_proxies: u64,
    /// Draw calls the frame submits (0: a file of a player that did not count them).
    pub draw_calls: u64,
    /// What the frame was drawn with; `None` in files of older players.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub draw_options: Option<DrawOptions>,
}

/// The header line of `frames.csv` (the columns [`FrameRow::csv`] writes).
pub const FRAMES_CSV_HEADER: &str = "frame,time_s,cell,crossing,frame_ms,triangles,texture_bytes,cache_hits,cache_misses,stream_ms,uploaded_bytes,pending_proxies,draw_calls,patch_bitfields,backface,frustum,tile_triangles,bc_textures,occlusion";

impl FrameRow {
    /// The row as a `frames.csv` line (no newline), columns as
    /// [`FRAMES_CSV_HEADER`]; booleans as 0/1, no cell as -1, no draw options as
    /// empty fields.
    pub fn csv(&self) -> String {
        let b = |v: bool| u8::from(v).to_string();
        let options = self.draw_options.map_or_else(
            || ",,,,,".to_string(),
            |o| {
                format!(
                    "{},{},{},{},{},{}",
                    b(o.patch_bitfields),
                    b(o.backface),
                    b(o.frustum),
                    o.tile_triangles,
                    b(o.bc_textures),
                    b(o.occlusion)
                )
            },
        );
        format!(
            "{},{:.4},{},{},{:.3},{},{},{},{},{:.3},{},{},{},{options}",
            self.frame,
            self.time_s,
            self.cell.map_or(-1, i64::from),
            b(self.crossing),
            self.frame_ms,
            self.triangles,
            self.texture_bytes,
            self.cache_hits,
            self.cache_misses,
            self.stream_ms,
            self.uploaded_bytes,
            self.pending_proxies,
            self.draw_calls,
        )
    }
}

/// The whole `frames.csv` of `rows`: the header, then one line per row.
pub fn write_frames_csv(rows: &[FrameRow]) -> String {
    let mut s = String::from(FRAMES_CSV_HEADER);
    s.push('\n');
    for r in rows {
        s.push_str(&r.csv());
        s.push('\n');
    }
    s
}

/// Why a `frames.csv` does not read.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum FramesCsvError {
    #[error("frames.csv: empty")]
    Empty,
    #[error("frames.csv line {line}: bad value {value:?} in column {column}")]
    BadValue {
        line: usize,
        column: String,
        value: String,
    },
}

/// Parses `frames.csv` by its header (columns in any order; unknown ones ignored,
/// missing ones at their default; the draw options only when the first five of their
/// columns are there and filled, `occlusion` off when missing).
pub fn parse_frames_csv(text: &str) -> Result<Vec<FrameRow>, FramesCsvError> {
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let (_, header) = lines.next().ok_or(FramesCsvError::Empty)?;
    let header: Vec<&str> = header.split(',').map(str::trim).collect();
    let mut rows = Vec::new();
    for (n, line) in lines {
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let row = Fields {
            header: &header,
            fields: &fields,
            line: n + 1,
        };
        let options = match [
            "patch_bitfields",
            "backface",
            "frustum",
            "tile_triangles",
            "bc_textures",
        ]
        .map(|c| row.get(c))
        {
            [Some(bits), Some(back), Some(frustum), Some(tile), Some(bc)] => Some(DrawOptions {
                patch_bitfields: row.flag("patch_bitfields", bits)?,
                backface: row.flag("backface", back)?,
                frustum: row.flag("frustum", frustum)?,
                tile_triangles: row.parse("tile_triangles", tile)?,
                bc_textures: row.flag("bc_textures", bc)?,
                // A column of later players: off in older files.
                occlusion: match row.get("occlusion") {
                    Some(v) => row.flag("occlusion", v)?,
                    None => false,
                },
            }),
            _ => None,
        };
        let cell: i64 = row.num("cell")?.unwrap_or(-1);
        rows.push(FrameRow {
            frame: row.num("frame")?.unwrap_or_default(),
            time_s: row.num("time_s")?.unwrap_or_default(),
            cell: u32::try_from(cell).ok(),
            crossing: match row.get("crossing") {
                Some(v) => row.flag("crossing", v)?,
                None => false,
            },
            frame_ms: row.num("frame_ms")?.unwrap_or_default(),
            triangles: row.num("triangles")?.unwrap_or_default(),
            texture_bytes: row.num("texture_bytes")?.unwrap_or_default(),
            cache_hits: row.num("cache_hits")?.unwrap_or_default(),
            cache_misses: row.num("cache_misses")?.unwrap_or_default(),
            stream_ms: row.num("stream_ms")?.unwrap_or_default(),
            uploaded_bytes: row.num("uploaded_bytes")?.unwrap_or_default(),
            pending_proxies: row.num("pending_proxies")?.unwrap_or_default(),
            draw_calls: row.num("draw_calls")?.unwrap_or_default(),
            draw_options: options,
        });
    }
    Ok(rows)
}

/// One CSV line's fields by column name.
struct Fields<'a> {
    header: &'a [&'a str],
    fields: &'a [&'a str],
    line: usize,
}

impl Fields<'_> {
    /// The non-empty value of `column`, if the header has it.
    fn get(&self, column: &str) -> Option<&str> {
        let i = self.header.iter().position(|h| *h == column)?;
        self.fields.get(i).copied().filter(|v| !v.is_empty())
    }

    fn bad(&self, column: &str, value: &str) -> FramesCsvError {
        FramesCsvError::BadValue {
            line: self.line,
            column: column.to_string(),
            value: value.to_string(),
        }
    }

    fn parse<T: std::str::FromStr>(&self, column: &str, value: &str) -> Result<T, FramesCsvError> {
        value.parse().map_err(|_| self.bad(column, value))
    }

    /// `column`'s value, `None` when the column is missing; a column in the header
    /// without a value on this line is an error.
    fn num<T: std::str::FromStr>(&self, column: &str) -> Result<Option<T>, FramesCsvError> {
        match self.header.iter().position(|h| *h == column) {
            None => Ok(None),
            Some(i) => {
                let v = self.fields.get(i).copied().unwrap_or("");
                self.parse(column, v).map(Some)
            }
        }
    }

    /// A 0/1 flag.
    fn flag(&self, column: &str, value: &str) -> Result<bool, FramesCsvError> {
        match value {
            "0" => Ok(false),
            "1" => Ok(true),
            _ => Err(self.bad(column, value)),
        }
    }
}

/// A cell as written by the player (a number or null) or by older benchmark tools
/// (-1 for none).
fn cell_or_negative<'de, D: Deserializer<'de>>(d: D) -> Result<Option<u32>, D::Error> {
    Ok(Option::<i64>::deserialize(d)?.and_then(|c| u32::try_from(c).ok()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(frame: usize, cell: Option<u32>, options: Option<DrawOptions>) -> FrameRow {
        FrameRow {
            frame,
            time_s: 0.1 * frame as f32,
            cell,
            crossing: frame % 2 == 1,
            frame_ms: 1.25 + frame as f64,
            triangles: 1200 + frame as u64,
            texture_bytes: 64,
            cache_hits: 3,
            cache_misses: 1,
            stream_ms: 0.031,
            uploaded_bytes: 4 << 20,
            pending_proxies: 2,
            draw_calls: 33,
            draw_options: options,
        }
    }

    #[test]
    fn a_written_row_reads_back_identically() {
        let odd = DrawOptions {
            patch_bitfields: false,
            backface: true,
            frustum: false,
            tile_triangles: 1_000_000,
            bc_textures: false,
            occlusion: false,
        };
        let rows = vec![
            row(0, Some(5), Some(DrawOptions::default())),
            row(1, None, Some(odd)),
            row(2, Some(0), None),
        ];
        let text = write_frames_csv(&rows);
        assert_eq!(text.lines().next(), Some(FRAMES_CSV_HEADER));
        assert_eq!(parse_frames_csv(&text).unwrap(), rows);
        // The benchmark tool keeps rows in its run files as JSON: the same row back.
        let json = serde_json::to_string(&rows).unwrap();
        assert_eq!(serde_json::from_str::<Vec<FrameRow>>(&json).unwrap(), rows);
        // Every column of the header is written, and only those.
        let columns = FRAMES_CSV_HEADER.split(',').count();
        for line in text.lines() {
            assert_eq!(line.split(',').count(), columns, "{line}");
        }
    }

    #[test]
    fn any_row_reads_back_within_the_written_precision() {
        let mut r = row(7, Some(3), Some(DrawOptions::default()));
        r.time_s = 0.123_456_7;
        r.frame_ms = 141.141_234_567;
        r.stream_ms = 2.000_499;
        let back = &parse_frames_csv(&write_frames_csv(std::slice::from_ref(&r))).unwrap()[0];
        assert!((back.time_s - r.time_s).abs() <= 0.5e-4);
        assert!((back.frame_ms - r.frame_ms).abs() <= 0.5e-3);
        assert!((back.stream_ms - r.stream_ms).abs() <= 0.5e-3);
        let exact = |f: &FrameRow| FrameRow {
            time_s: 0.0,
            frame_ms: 0.0,
            stream_ms: 0.0,
            ..f.clone()
        };
        assert_eq!(exact(back), exact(&r));
    }

    #[test]
    fn files_of_older_players_read_with_defaults() {
        // The columns of 2026-11 (no uploads, pending proxies, draw calls or
        // options), in another order, with a column this reader does not know.
        let csv = "frame,cell,time_s,crossing,frame_ms,triangles,texture_bytes,cache_hits,cache_misses,stream_ms,something_new\n\
                   0,5,0.0000,0,1.500,1200,0,0,1,3.000,x\n\
                   \n\
                   1,-1,0.1000,1,2.000,900,64,1,1,0.500,y\n";
        let rows = parse_frames_csv(csv).unwrap();
        assert_eq!(rows.len(), 2);
        assert_eq!((rows[0].cell, rows[1].cell), (Some(5), None));
        assert!(!rows[0].crossing && rows[1].crossing);
        assert_eq!((rows[1].triangles, rows[1].texture_bytes), (900, 64));
        assert_eq!((rows[1].draw_calls, rows[1].draw_options), (0, None));
        assert_eq!(parse_frames_csv(""), Err(FramesCsvError::Empty));
        assert!(matches!(
            parse_frames_csv("frame,cell\n1,x\n"),
            Err(FramesCsvError::BadValue { line: 2, .. })
        ));
        assert!(parse_frames_csv("frame,crossing\n1,2\n").is_err());
    }

    #[test]
    fn rows_of_older_run_files_read() {
        // A row of `docs/bench/run-20261121T140328Z.json` (cell -1 for none there).
        let json = r#"[{"frame":0,"time_s":0.0,"cell":68,"crossing":false,"frame_ms":141.141,
            "triangles":957570,"texture_bytes":0,"cache_hits":0,"cache_misses":0,"stream_ms":0.0},
            {"frame":1,"time_s":0.1,"cell":-1,"crossing":true,"frame_ms":1.0,
            "triangles":1,"texture_bytes":0,"cache_hits":0,"cache_misses":0,"stream_ms":0.0}]"#;
        let rows: Vec<FrameRow> = serde_json::from_str(json).unwrap();
        assert_eq!((rows[0].cell, rows[1].cell), (Some(68), None));
        assert_eq!((rows[0].triangles, rows[0].draw_options), (957570, None));
    }

    #[test]
    fn default_options_are_the_players_defaults() {
        let d = DrawOptions::default();
        assert!(d.patch_bitfields && d.backface && d.frustum && d.bc_textures && d.occlusion);
        assert_eq!(d.tile_size(), 16);
        let none = DrawOptions {
            tile_triangles: 0,
            ..d
        };
        assert_eq!(none.tile_size(), 1);
        // A report key written before a switch existed reads as its default,
        // but occlusion culling as off: players before it had none.
        let o: DrawOptions = serde_json::from_str(r#"{"backface":false}"#).unwrap();
        assert_eq!(
            o,
            DrawOptions {
                backface: false,
                occlusion: false,
                ..d
            }
        );
    }
}
