//! PLY (ASCII and binary, either endianness) through `ply-rs`: the `vertex` element's
//! `x y z` (any numeric type) and optional `red green blue` (uchar 0–255 or float
//! 0–1, read as sRGB), and the `face` element's `vertex_indices` / `vertex_index` list
//! (fan-triangulated). A header line starting with no PLY keyword is read as a
//! comment (see `tolerant_header`).

use super::{fan, parse_error, unit_to_u8, Location, ModelFormat, Parsed};
use crate::cleanup::RawMesh;
use crate::load::LoadError;
use ply_rs::ply::{DefaultElement, Property};
use std::io::{BufReader, Cursor};
use std::path::Path;

const FORMAT: ModelFormat = ModelFormat::Ply;

fn scalar(p: &Property) -> Option<f64> {
    Some(match *p {
        Property::Char(v) => f64::from(v),
        Property::UChar(v) => f64::from(v),
        Property::Short(v) => f64::from(v),
        Property::UShort(v) => f64::from(v),
        Property::Int(v) => f64::from(v),
        Property::UInt(v) => f64::from(v),
        Property::Float(v) => f64::from(v),
        Property::Double(v) => v,
        _ => return None,
    })
}

fn color_channel(p: &Property) -> Option<u8> {
    match *p {
        Property::Float(v) => Some(unit_to_u8(v)),
        Property::Double(v) => Some(unit_to_u8(v as f32)),
        _ => scalar(p).map(|v| v.clamp(0.0, 255.0) as u8),
    }
}

/// A face's index list; `None` when an index is negative or not an integer list.
fn index_list(p: &Property) -> Option<Vec<u32>> {
    fn conv<T: Copy>(v: &[T], f: impl Fn(T) -> Option<u32>) -> Option<Vec<u32>> {
        v.iter().map(|&x| f(x)).collect()
    }
    match p {
        Property::ListChar(v) => conv(v, |x| u32::try_from(x).ok()),
        Property::ListUChar(v) => conv(v, |x| Some(u32::from(x))),
        Property::ListShort(v) => conv(v, |x| u32::try_from(x).ok()),
        Property::ListUShort(v) => conv(v, |x| Some(u32::from(x))),
        Property::ListInt(v) => conv(v, |x| u32::try_from(x).ok()),
        Property::ListUInt(v) => Some(v.clone()),
        _ => None,
    }
}

/// Header keywords of the PLY format.
const KEYWORDS: &[&str] = &[
    "ply",
    "format",
    "comment",
    "obj_info",
    "element",
    "property",
    "end_header",
];

/// The file with any header line that starts with no PLY keyword turned into a
/// comment: Blender 2.47's exporter writes a bare `Created by Blender3D ...` line
/// (e.g. Debian's `wuson.ply`), which ply-rs rejects.
fn tolerant_header(bytes: &[u8]) -> std::borrow::Cow<'_, [u8]> {
    let Some(end) = bytes
        .windows(10)
        .position(|w| w == b"end_header")
        .filter(|&e| e <= 64 * 1024)
    else {
        return std::borrow::Cow::Borrowed(bytes);
    };
    let header = &bytes[..end];
    let bad_line = |line: &[u8]| {
        let word = line
            .split(|b| b.is_ascii_whitespace())
            .find(|w| !w.is_empty())
            .unwrap_or(b"");
        !word.is_empty() && !KEYWORDS.iter().any(|k| k.as_bytes() == word)
    };
    if !header.split(|&b| b == b'\n').any(bad_line) {
        return std::borrow::Cow::Borrowed(bytes);
    }
    let mut fixed = Vec::with_capacity(bytes.len() + 64);
    for line in header.split_inclusive(|&b| b == b'\n') {
        if bad_line(line) {
            fixed.extend_from_slice(b"comment ");
        }
        fixed.extend_from_slice(line);
    }
    fixed.extend_from_slice(&bytes[end..]);
    std::borrow::Cow::Owned(fixed)
}

pub(crate) fn parse(path: &Path, bytes: &[u8]) -> Result<Parsed, LoadError> {
    let parser = ply_rs::parser::Parser::<DefaultElement>::new();
    let bytes = tolerant_header(bytes);
    let mut reader = BufReader::new(Cursor::new(&bytes[..]));
    let ply = parser
        .read_ply(&mut reader)
        .map_err(|e| parse_error(path, FORMAT, e.to_string(), Location::Unknown))?;
    let vertices = ply
        .payload
        .get("vertex")
        .ok_or_else(|| parse_error(path, FORMAT, "no `vertex` element", Location::Unknown))?;
    let faces = ply
        .payload
        .get("face")
        .ok_or_else(|| parse_error(path, FORMAT, "no `face` element", Location::Unknown))?;

    let has_colors = vertices
        .first()
        .is_some_and(|v| ["red", "green", "blue"].iter().all(|k| v.contains_key(*k)));
    let mut positions = Vec::with_capacity(vertices.len());
    let mut colors = Vec::new();
    for (i, v) in vertices.iter().enumerate() {
        let missing = |k: &str| {
            parse_error(
                path,
                FORMAT,
                format!("vertex {i} has no numeric `{k}`"),
                Location::Element(format!("vertex {i}")),
            )
        };
        let coord = |k: &str| v.get(k).and_then(scalar).ok_or_else(|| missing(k));
        positions.push([coord("x")? as f32, coord("y")? as f32, coord("z")? as f32]);
        if has_colors {
            let channel = |k: &str| v.get(k).and_then(color_channel).ok_or_else(|| missing(k));
            colors.push([channel("red")?, channel("green")?, channel("blue")?, 255]);
        }
    }
    let mut triangles = Vec::with_capacity(faces.len());
    for (f, face) in faces.iter().enumerate() {
        let at = || Location::Element(format!("face {f}"));
        let list = face
            .get("vertex_indices")
            .or_else(|| face.get("vertex_index"))
            .ok_or_else(|| {
                parse_error(
                    path,
                    FORMAT,
                    format!("face {f} has no `vertex_indices`"),
                    at(),
                )
            })?;
        let indices = index_list(list).ok_or_else(|| {
            parse_error(
                path,
                FORMAT,
                format!("face {f}: `vertex_indices` is not a list of non-negative integers"),
                at(),
            )
        })?;
        if indices.len() < 3 {
            return Err(parse_error(
                path,
                FORMAT,
                format!(
                    "face {f} has {} vertices (at least 3 needed)",
                    indices.len()
                ),
                at(),
            ));
        }
        fan(&indices, &mut triangles);
    }
    Ok(Parsed {
        raw: RawMesh {
            positions,
            colors: has_colors.then_some(colors),
            triangles,
        },
        nodes: 0,
        parts: 1,
    })
}
