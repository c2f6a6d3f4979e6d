//! Wavefront OBJ through `tobj` (polygons triangulated, position indices only —
//! normals and texture coordinates are not used; `v x y z r g b` vertex colours are
//! read as sRGB). Every object/group is concatenated; materials are not loaded.

use super::{parse_error, unit_to_u8, Location, ModelFormat, Parsed};
use crate::cleanup::RawMesh;
use crate::load::LoadError;
use std::io::Cursor;
use std::path::Path;

const FORMAT: ModelFormat = ModelFormat::Obj;

pub(crate) fn parse(path: &Path, bytes: &[u8]) -> Result<Parsed, LoadError> {
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
