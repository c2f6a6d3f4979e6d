//! OFF (Object File Format, Geomview), hand-written: `[C][N]OFF`, counts
//! `vertices faces edges`, one vertex per line (`x y z`, then `nx ny nz` for NOFF,
//! then `r g b [a]` for COFF: integers 0–255 or floats 0–1), one face per line
//! (`n i1 … in`, fan-triangulated; trailing face colours ignored). `#` starts a
//! comment. Every error names its line; non-finite and absurd coordinates are rejected here.

use super::{fan, parse_error, unit_to_u8, Location, ModelFormat, Parsed};
use crate::cleanup::{RawMesh, MAX_MODEL_COORDINATE};
use crate::load::LoadError;
use std::path::Path;

const FORMAT: ModelFormat = ModelFormat::Off;

pub(crate) fn parse(path: &Path, bytes: &[u8]) -> Result<Parsed, LoadError> {
    let err = |what: String, line: usize| parse_error(path, FORMAT, what, Location::Line(line));
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let line = bytes[..e.valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
            + 1;
        err("not UTF-8 text".into(), line)
    })?;
    // Non-empty lines with comments stripped, with their 1-based numbers.
    let mut lines = text.lines().enumerate().filter_map(|(i, l)| {
        let l = l.split('#').next().unwrap_or("").trim();
        (!l.is_empty()).then_some((i + 1, l))
    });

    // Header keyword, maybe followed by the counts on the same line.
    let (header_line, header) = lines.next().ok_or_else(|| err("empty file".into(), 1))?;
    let mut tokens = header.split_whitespace();
    let keyword = tokens.next().unwrap_or("");
    let (has_colors, has_normals) = match keyword {
        "OFF" => (false, false),
        "COFF" => (true, false),
        "NOFF" => (false, true),
        "CNOFF" | "NCOFF" => (true, true),
        _ => {
            return Err(err(
                format!("expected an `OFF` header, found `{keyword}`"),
                header_line,
            ))
        }
    };
    let rest: Vec<&str> = tokens.collect();
    let (counts_line, counts): (usize, Vec<&str>) = if rest.is_empty() {
        let (n, l) = lines
            .next()
            .ok_or_else(|| err("file ends before the counts line".into(), header_line))?;
        (n, l.split_whitespace().collect())
    } else {
        (header_line, rest)
    };
    let count = |k: usize, name: &str| -> Result<usize, LoadError> {
        counts
            .get(k)
            .and_then(|t| t.parse::<usize>().ok())
            .ok_or_else(|| err(format!("expected the {name} count"), counts_line))
    };
    let vertex_count = count(0, "vertex")?;
    let face_count = count(1, "face")?;
    // A vertex needs at least 6 bytes ("0 0 0\n"), a face 8: cap what we reserve.
    let positions_cap = vertex_count.min(bytes.len() / 6);
    let faces_cap = face_count.min(bytes.len() / 8);

    // The file ends after `done` of `total` vertices or faces.
    let ends_early = |done: usize, total: usize, what: &str| {
        err(
            format!("file ends after {done} of {total} {what}"),
            text.lines().count(),
        )
    };

    // Vertices.
    let mut positions = Vec::with_capacity(positions_cap);
    let mut colors = has_colors.then(|| Vec::with_capacity(positions_cap));
    for v in 0..vertex_count {
        let (line, l) = lines
            .next()
            .ok_or_else(|| ends_early(v, vertex_count, "vertices"))?;
        let values: Vec<&str> = l.split_whitespace().collect();
        let number = |k: usize| -> Result<f32, LoadError> {
            let t = values.get(k).ok_or_else(|| {
                err(
                    format!("vertex {v}: expected at least {} numbers", k + 1),
                    line,
                )
            })?;
            t.parse::<f32>()
                .map_err(|_| err(format!("vertex {v}: `{t}` is not a number"), line))
        };
        let p = [number(0)?, number(1)?, number(2)?];
        if !p.iter().all(|x| x.is_finite()) {
            return Err(err(
                format!("vertex {v} has a non-finite coordinate {p:?}"),
                line,
            ));
        }
        if p.iter().any(|x| x.abs() > MAX_MODEL_COORDINATE) {
            return Err(err(
                format!("vertex {v} has a coordinate beyond ±{MAX_MODEL_COORDINATE}: {p:?}"),
                line,
            ));
        }
        positions.push(p);
        if let Some(colors) = &mut colors {
            let first = if has_normals { 6 } else { 3 };
            let channel = |k: usize| -> Result<u8, LoadError> {
                let t = values.get(first + k).ok_or_else(|| {
                    err(format!("vertex {v}: COFF vertex without a colour"), line)
                })?;
                if let Ok(i) = t.parse::<u32>() {
                    Ok(i.min(255) as u8)
                } else {
                    let f = t.parse::<f32>().map_err(|_| {
                        err(format!("vertex {v}: colour `{t}` is not a number"), line)
                    })?;
                    Ok(unit_to_u8(f))
                }
            };
            colors.push([channel(0)?, channel(1)?, channel(2)?, 255]);
        }
    }

    // Faces.
    let mut triangles = Vec::with_capacity(faces_cap);
    let mut polygon: Vec<u32> = Vec::new();
    for f in 0..face_count {
        let (line, l) = lines
            .next()
            .ok_or_else(|| ends_early(f, face_count, "faces"))?;
        let mut values = l.split_whitespace();
        let n: usize = values
            .next()
            .and_then(|t| t.parse().ok())
            .ok_or_else(|| err(format!("face {f}: expected a vertex count"), line))?;
        if n < 3 {
            return Err(err(
                format!("face {f} has {n} vertices (at least 3 needed)"),
                line,
            ));
        }
        polygon.clear();
        for k in 0..n {
            let t = values
                .next()
                .ok_or_else(|| err(format!("face {f}: expected {n} indices, found {k}"), line))?;
            let i: u32 = t
                .parse()
                .map_err(|_| err(format!("face {f}: `{t}` is not a vertex index"), line))?;
            if i as usize >= vertex_count {
                return Err(err(
                    format!("face {f} uses vertex {i}, but there are only {vertex_count} vertices"),
                    line,
                ));
            }
            polygon.push(i);
        }
        fan(&polygon, &mut triangles);
    }
    Ok(Parsed {
        raw: RawMesh {
            positions,
            colors,
            triangles,
        },
        nodes: 0,
        parts: 1,
    })
}
