//! Where each field of a RON document sits: the span side of the two-stage manifest
//! parse (STYLE.md habit 8).
//!
//! serde hands the validator plain values without positions, so validation errors
//! (out-of-range value, missing file, empty park, ...) find their `line:column` here:
//! a small structural scan of the same text records every `name:` key of a struct
//! with its dotted path (`scene.models[1].count`), its position and the extent of its
//! value. The scan only tracks nesting, strings and comments; it never fails and
//! never panics, whatever the text (ron has already accepted the text when the
//! validator asks, and on a ron error it is only used to name the field).

/// 1-based line and column (in characters), like `ron::error::Position`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TextPosition {
    pub line: usize,
    pub column: usize,
}

/// One `key: value` of a struct.
#[derive(Clone, Debug)]
struct Field {
    /// Dotted path, list indices in brackets: `scene.models[1].count`.
    path: String,
    /// Byte offset of the key's first character.
    key_offset: usize,
    /// Byte offset just past the value (the `,` or closing bracket that ended it).
    value_end: usize,
}

/// Every field of a RON text, in text order.
#[derive(Clone, Debug)]
pub struct FieldPositions {
    fields: Vec<Field>,
    /// `(open, close, path)` of every `(...)`: byte offsets of both brackets and the
    /// path of the value it belongs to.
    parens: Vec<(usize, usize, String)>,
    /// Byte offset of the start of each line.
    line_starts: Vec<usize>,
    text: String,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Bracket {
    Paren,
    Square,
    Brace,
}

/// One open bracket while scanning.
#[derive(Clone, Debug)]
struct Frame {
    bracket: Bracket,
    /// Path of the field whose value this bracket is part of ("" at top level).
    prefix: String,
    /// Element index inside a `[...]` list.
    list_index: usize,
    /// The field currently open in this frame: index into `fields`.
    open_field: Option<usize>,
}

impl FieldPositions {
    /// Scans `text`.
    pub fn scan(text: &str) -> FieldPositions {
        let bytes = text.as_bytes();
        let mut fields: Vec<Field> = Vec::new();
        let mut parens: Vec<(usize, usize, String)> = Vec::new();
        let mut stack: Vec<(usize, Frame)> = Vec::new();
        // Whether the next identifier in the innermost paren frame may be a key:
        // right after `(` or `,`.
        let mut expect_key = false;
        let mut i = 0usize;
        let close_field = |fields: &mut Vec<Field>, frame: &mut Frame, at: usize| {
            if let Some(f) = frame.open_field.take() {
                if let Some(field) = fields.get_mut(f) {
                    field.value_end = at;
                }
            }
        };
        while i < bytes.len() {
            let c = bytes[i];
            match c {
                b'/' if bytes.get(i + 1) == Some(&b'/') => {
                    while i < bytes.len() && bytes[i] != b'\n' {
                        i += 1;
                    }
                    continue;
                }
                b'/' if bytes.get(i + 1) == Some(&b'*') => {
                    // RON block comments nest.
                    let mut depth = 0usize;
                    while i < bytes.len() {
                        if bytes[i] == b'/' && bytes.get(i + 1) == Some(&b'*') {
                            depth += 1;
                            i += 2;
                        } else if bytes[i] == b'*' && bytes.get(i + 1) == Some(&b'/') {
                            depth = depth.saturating_sub(1);
                            i += 2;
                            if depth == 0 {
                                break;
                            }
                        } else {
                            i += 1;
                        }
                    }
                    continue;
                }
                b'"' => {
                    expect_key = false;
                    i += 1;
                    while i < bytes.len() && bytes[i] != b'"' {
                        i += if bytes[i] == b'\\' { 2 } else { 1 };
                    }
                    i += 1;
                    continue;
                }
                b'(' | b'[' | b'{' => {
                    let prefix = current_path(&fields, stack.last().map(|(_, f)| f));
                    stack.push((
                        i,
                        Frame {
                            bracket: match c {
                                b'(' => Bracket::Paren,
                                b'[' => Bracket::Square,
                                _ => Bracket::Brace,
                            },
                            prefix,
                            list_index: 0,
                            open_field: None,
                        },
                    ));
                    expect_key = c == b'(';
                }
                b')' | b']' | b'}' => {
                    if let Some((open, mut frame)) = stack.pop() {
                        close_field(&mut fields, &mut frame, i);
                        if frame.bracket == Bracket::Paren {
                            parens.push((open, i, frame.prefix));
                        }
                    }
                    expect_key = false;
                }
                b',' => {
                    if let Some((_, frame)) = stack.last_mut() {
                        close_field(&mut fields, frame, i);
                        if frame.bracket == Bracket::Square {
                            frame.list_index += 1;
                        }
                        expect_key = frame.bracket == Bracket::Paren;
                    }
                }
                c if c.is_ascii_alphabetic() || c == b'_' => {
                    let start = i;
                    while i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'_')
                    {
                        i += 1;
                    }
                    if expect_key {
                        let mut j = i;
                        while j < bytes.len() && bytes[j].is_ascii_whitespace() {
                            j += 1;
                        }
                        let is_key = bytes.get(j) == Some(&b':') && bytes.get(j + 1) != Some(&b':');
                        if let (true, Some((_, frame))) = (is_key, stack.last_mut()) {
                            let name = &text[start..i];
                            let path = if frame.prefix.is_empty() {
                                name.to_string()
                            } else {
                                format!("{}.{name}", frame.prefix)
                            };
                            frame.open_field = Some(fields.len());
                            fields.push(Field {
                                path,
                                key_offset: start,
                                value_end: text.len(),
                            });
                            i = j + 1;
                        }
                    }
                    expect_key = false;
                    continue;
                }
                c if c.is_ascii_whitespace() => {}
                _ => expect_key = false,
            }
            i += 1;
        }
        let mut line_starts = vec![0];
        line_starts.extend(text.match_indices('\n').map(|(k, _)| k + 1));
        FieldPositions {
            fields,
            parens,
            line_starts,
            text: text.to_string(),
        }
    }

    /// Position of the key of the field at `path` (its first occurrence).
    pub fn key_position(&self, path: &str) -> Option<TextPosition> {
        let field = self.fields.iter().find(|f| f.path == path)?;
        Some(self.position_of(field.key_offset))
    }

    /// Position of the field at `path`, else of its nearest named ancestor
    /// (`scene.models[2].count` → `scene.models[2]`'s first key → `scene.models` ...),
    /// else 1:1.
    pub fn nearest_position(&self, path: &str) -> TextPosition {
        let mut p = path.to_string();
        loop {
            if let Some(pos) = self.key_position(&p) {
                return pos;
            }
            // A list element has no key of its own: use its first field.
            let element_prefix = format!("{p}.");
            if p.ends_with(']') {
                if let Some(f) = self
                    .fields
                    .iter()
                    .find(|f| f.path.starts_with(&element_prefix))
                {
                    return self.position_of(f.key_offset);
                }
            }
            match p.rfind(['.', '[']) {
                Some(cut) => p.truncate(cut),
                None => return TextPosition { line: 1, column: 1 },
            }
        }
    }

    /// The innermost field whose key or value contains `position` (a ron error
    /// position), as a dotted path.
    pub fn path_at(&self, position: TextPosition) -> Option<String> {
        let offset = self.offset_of(position)?;
        self.fields
            .iter()
            .filter(|f| f.key_offset <= offset && offset <= f.value_end)
            .min_by_key(|f| f.value_end - f.key_offset)
            .map(|f| f.path.clone())
    }

    /// Path of the innermost `(...)` that contains `position` or ends just before it
    /// (where ron reports a missing field).
    pub fn struct_at(&self, position: TextPosition) -> Option<String> {
        let offset = self.offset_of(position)?;
        self.parens
            .iter()
            .filter(|(open, close, _)| *open < offset && offset <= close + 1)
            .min_by_key(|(open, close, _)| close - open)
            .map(|(_, _, path)| path.clone())
    }

    /// The key of the last field at or before `position` whose name is `name`.
    pub fn key_before(&self, position: TextPosition, name: &str) -> Option<TextPosition> {
        let offset = self.offset_of(position)?;
        self.fields
            .iter()
            .rfind(|f| f.key_offset <= offset && f.path.rsplit('.').next() == Some(name))
            .map(|f| self.position_of(f.key_offset))
    }

    fn position_of(&self, offset: usize) -> TextPosition {
        let line_index = self.line_starts.partition_point(|&s| s <= offset).max(1) - 1;
        let line_start = self.line_starts[line_index];
        let column = self
            .text
            .get(line_start..offset)
            .map_or(1, |s| s.chars().count() + 1);
        TextPosition {
            line: line_index + 1,
            column,
        }
    }

    fn offset_of(&self, position: TextPosition) -> Option<usize> {
        let line_start = *self.line_starts.get(position.line.checked_sub(1)?)?;
        let line = &self.text[line_start..];
        let within = line
            .char_indices()
            .nth(position.column.saturating_sub(1))
            .map_or(line.len(), |(k, _)| k);
        Some(line_start + within)
    }
}

/// The dotted path a value opened now would belong to.
fn current_path(fields: &[Field], frame: Option<&Frame>) -> String {
    let Some(frame) = frame else {
        return String::new();
    };
    let mut path = match frame.open_field.and_then(|f| fields.get(f)) {
        Some(field) => field.path.clone(),
        None => frame.prefix.clone(),
    };
    if frame.bracket == Bracket::Square {
        path.push_str(&format!("[{}]", frame.list_index));
    }
    path
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_and_positions() {
        let text = "(\n  name: \"a,(b\", // c: 1\n  scene: Park((seed: 7, models: [\n    (model: File(\"x\"), count: 2),\n    (count: 3, model: Procedural(\"box\")),\n  ])),\n  cells: (cell_size: 5.0),\n)";
        let f = FieldPositions::scan(text);
        assert_eq!(
            f.key_position("scene.models[1].count"),
            Some(TextPosition { line: 5, column: 6 })
        );
        assert_eq!(
            f.key_position("scene.models[0].count"),
            Some(TextPosition {
                line: 4,
                column: 24
            })
        );
        assert_eq!(
            f.key_position("cells.cell_size"),
            Some(TextPosition {
                line: 7,
                column: 11
            })
        );
        assert_eq!(f.key_position("c"), None);
        assert_eq!(
            f.nearest_position("scene.models[1].target_height"),
            TextPosition { line: 5, column: 6 }
        );
        assert_eq!(
            f.path_at(TextPosition {
                line: 7,
                column: 22
            })
            .as_deref(),
            Some("cells.cell_size")
        );
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(256))]
        /// Any text scans without panicking, and every query answers.
        #[test]
        fn scan_never_panics(text in "[ -~\n\té\"()\\[\\]{}:,/*#]{0,200}") {
            let f = FieldPositions::scan(&text);
            for line in 0..4 {
                for column in 0..30 {
                    let at = TextPosition { line, column };
                    let _ = f.path_at(at);
                    let _ = f.struct_at(at);
                    let _ = f.key_before(at, "a");
                }
            }
            let _ = f.nearest_position("a.b[0].c");
        }
    }
}
