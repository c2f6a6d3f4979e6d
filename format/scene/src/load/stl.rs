//! STL (binary and ASCII) through `stl_io`. Binary files are recognised by their
//! size (`84 + 50 × triangle count` bytes), even when their 80-byte header starts
//! with `solid ` (which would otherwise send them to the ASCII reader); a binary file
//! shorter than its count says is an error naming the byte offset where it ends.

use super::{parse_error, Location, ModelFormat, Parsed};
use crate::cleanup::RawMesh;
use crate::load::LoadError;
use std::borrow::Cow;
use std::io::Cursor;
use std::path::Path;

const FORMAT: ModelFormat = ModelFormat::Stl;

pub(crate) fn parse(path: &Path, bytes: &[u8]) -> Result<Parsed, LoadError> {
    let declared = bytes
        .get(80..84)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as u64);
    let binary_size = declared.map(|n| 84 + 50 * n);
    let looks_ascii = bytes.starts_with(b"solid ");
    let is_binary = match binary_size {
        Some(size) => !looks_ascii || size == bytes.len() as u64,
        None => !looks_ascii,
    };
    let mut input: Cow<[u8]> = Cow::Borrowed(bytes);
    if is_binary {
        let (Some(n), Some(size)) = (declared, binary_size) else {
            return Err(parse_error(
                path,
                FORMAT,
                format!(
                    "binary STL needs an 84-byte header, the file has {} bytes",
                    bytes.len()
                ),
                Location::Byte(bytes.len() as u64),
            ));
        };
        if size > bytes.len() as u64 {
            return Err(parse_error(
                path,
                FORMAT,
                format!(
                    "binary STL declares {n} triangles ({size} bytes) but the file has {} bytes",
                    bytes.len()
                ),
                Location::Byte(bytes.len() as u64),
            ));
        }
        if looks_ascii {
            // Keep stl_io's ASCII probe away from a binary header that says "solid ".
            let mut owned = bytes.to_vec();
            owned[0] = b'S';
            input = Cow::Owned(owned);
        }
    }
    let mut cursor = Cursor::new(&input[..]);
    let reader = stl_io::create_stl_reader(&mut cursor)
        .map_err(|e| parse_error(path, FORMAT, format!("cannot read: {e}"), Location::Unknown))?;
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for (t, triangle) in reader.enumerate() {
        let triangle = triangle.map_err(|e| {
            parse_error(
                path,
                FORMAT,
                format!("cannot read triangle {t}: {e}"),
                Location::Element(format!("triangle {t}")),
            )
        })?;
        let base = positions.len() as u32;
        for v in triangle.vertices {
            positions.push(v.0);
        }
        triangles.push([base, base + 1, base + 2]);
        if positions.len() > u32::MAX as usize - 3 {
            return Err(parse_error(
                path,
                FORMAT,
                "too many triangles",
                Location::Unknown,
            ));
        }
    }
    Ok(Parsed {
        raw: RawMesh {
            positions,
            colors: None,
            triangles,
        },
        nodes: 0,
        parts: 1,
    })
}
