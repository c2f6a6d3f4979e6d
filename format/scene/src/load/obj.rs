//! Wavefront OBJ through `tobj` (polygons triangulated, position indices only —
//! normals and texture coordinates are not used; `v x y z r g b` vertex colours are
//! read as sRGB). Every object/group is concatenated; materials are not loaded.
//! `v` lines are checked first, so a bad or non-finite coordinate names its line.

use super::{parse_error, unit_to_u8, Location, ModelFormat, Parsed};
use crate::cleanup::RawMesh;
use crate::load::LoadError;
use std::io::Cursor;
use std::path::Path;

const FORMAT: ModelFormat = ModelFormat::Obj;

/// Checks every `v` line before tobj reads the file, so a bad or non-finite
/// coordinate is reported with its line (tobj's errors carry no position).
fn check_vertex_lines(path: &Path, bytes: &[u8]) -> Result<(), LoadError> {
    let mut vertex = 0usize;
    for (i, line) in bytes.split(|&b| b == b'\n').enumerate() {
        let Some(rest) = line
            .strip_prefix(b"v")
            .filter(|r| r.first().is_some_and(u8::is_ascii_whitespace))
        else {
            continue;
        };
        let at = Location::Line(i + 1);
        let text = String::from_utf8_lossy(rest);
        let mut coords = text.split_whitespace().map(str::parse::<f32>);
        for _ in 0..3 {
            match coords.next() {
                Some(Ok(x)) if x.is_finite() => {}
                Some(Ok(x)) => {
                    return Err(parse_error(
                        path,
                        FORMAT,
                        format!("vertex {vertex} has a non-finite coordinate {x}"),
                        at,
                    ))
                }
                _ => {
                    return Err(parse_error(
                        path,
                        FORMAT,
                        format!("vertex {vertex} needs three numeric coordinates"),
                        at,
                    ))
                }
            }
        }
        vertex += 1;
    }
    Ok(())
}

pub(crate) fn parse(path: &Path, bytes: &[u8]) -> Result<Parsed, LoadError> {
    check_vertex_lines(path, bytes)?;
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ..Default::default()
    };
    let mut reader = Cursor::new(bytes);
    let (models, _materials) = tobj::load_obj_buf(&mut reader, &options, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|e| parse_error(path, FORMAT, e.to_string(), Location::Unknown))?;
    let any_colors = models.iter().any(|m| !m.mesh.vertex_color.is_empty());
    let mut positions: Vec<[f32; 3]> = Vec::new();
    let mut colors: Vec<[u8; 4]> = Vec::new();
    let mut triangles = Vec::new();
    for (part, model) in models.iter().enumerate() {
        let mesh = &model.mesh;
        let base = u32::try_from(positions.len())
            .map_err(|_| parse_error(path, FORMAT, "too many vertices", Location::Unknown))?;
        let count = mesh.positions.len() / 3;
        positions.extend(mesh.positions.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
        if any_colors {
            if mesh.vertex_color.len() == mesh.positions.len() {
                colors.extend(
                    mesh.vertex_color
                        .chunks_exact(3)
                        .map(|c| [unit_to_u8(c[0]), unit_to_u8(c[1]), unit_to_u8(c[2]), 255]),
                );
            } else {
                colors.extend(std::iter::repeat_n([255u8; 4], count));
            }
        }
        for (face, t) in mesh.indices.chunks(3).enumerate() {
            let [a, b, c] = [0, 1, 2].map(|k| t.get(k).copied().unwrap_or(u32::MAX));
            if [a, b, c].iter().any(|&i| i as usize >= count) {
                return Err(parse_error(
                    path,
                    FORMAT,
                    format!(
                        "triangle {face} of object `{}` uses a vertex out of range ({a}, {b}, {c}; {count} vertices)",
                        model.name
                    ),
                    Location::Element(format!("object {part} face {face}")),
                ));
            }
            triangles.push([base + a, base + b, base + c]);
        }
    }
    Ok(Parsed {
        raw: RawMesh {
            positions,
            colors: any_colors.then_some(colors),
            triangles,
        },
        nodes: 0,
        parts: models.len(),
    })
}
