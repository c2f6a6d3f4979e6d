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
//!
//! It runs before ron, on text nobody has checked (issue 19): its time and memory
//! are linear in the text (paths are a tree of segments, not a string per field),
//! and it stops at the first bracket nested deeper than [`MAX_NESTING`], which the
//! manifest parser then refuses with that bracket's position — a file of 100,000
//! `[` would otherwise exhaust memory, here or in ron.

/// 1-based line and column (in characters), like `ron::error::Position`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TextPosition {
    pub line: usize,
    pub column: usize,
}

/// Deepest bracket nesting [`FieldPositions::scan`] follows; deeper text is refused
/// (see [`FieldPositions::too_deep`]).
pub const MAX_NESTING: usize = 64;

/// No parent: a path segment at the top level.
const ROOT: u32 = u32::MAX;

/// One segment of a dotted path, linked to its parent. Paths are stored as a tree of
/// these rather than as strings, so a scan is linear in the text however long and
/// deep the paths (a string per field would copy the whole prefix each time).
#[derive(Clone, Copy, Debug)]
struct PathNode {
    /// Index of the parent node, [`ROOT`] for none.
    parent: u32,
    segment: Segment,
}

#[derive(Clone, Copy, Debug)]
enum Segment {
    /// A key: byte range of its name in the text; written `.name` after a parent.
    Key { start: usize, end: usize },
    /// A list element: written `[i]`.
    Index(usize),
}

/// One `key: value` of a struct.
#[derive(Clone, Debug)]
struct Field {
    /// Its path (`scene.models[1].count`): a node in `nodes`, a key segment.
    node: u32,
    /// Byte offset of the key's first character.
    key_offset: usize,
    /// Byte offset just past the value (the `,` or closing bracket that ended it).
    value_end: usize,
}

/// Every field of a RON text, in text order.
#[derive(Clone, Debug)]
pub struct FieldPositions {
    nodes: Vec<PathNode>,
    fields: Vec<Field>,
    /// `(open, close, path)` of every `(...)`: byte offsets of both brackets and the
    /// path of the value it belongs to ([`ROOT`] at top level).
    parens: Vec<(usize, usize, u32)>,
    /// Byte offset of the first bracket nested deeper than [`MAX_NESTING`], where the
    /// scan stopped.
    too_deep: Option<usize>,
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
    /// Path of the value this bracket is part of ([`ROOT`] at top level).
    prefix: u32,
    /// Element index inside a `[...]` list.
    list_index: usize,
    /// The field currently open in this frame: index into `fields`.
    open_field: Option<usize>,
}

impl FieldPositions {
    /// Scans `text`, in time and memory linear in its length. Stops at the first
    /// bracket nested deeper than [`MAX_NESTING`] (see [`FieldPositions::too_deep`]).
    pub fn scan(text: &str) -> FieldPositions {
        let bytes = text.as_bytes();
        let mut nodes: Vec<PathNode> = Vec::new();
        let mut fields: Vec<Field> = Vec::new();
        let mut parens: Vec<(usize, usize, u32)> = Vec::new();
        let mut stack: Vec<(usize, Frame)> = Vec::new();
        let mut too_deep = None;
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
                    if stack.len() >= MAX_NESTING {
                        too_deep = Some(i);
                        break;
                    }
                    let prefix = current_path(&mut nodes, &fields, stack.last().map(|(_, f)| f));
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
                            let node =
                                push_node(&mut nodes, frame.prefix, Segment::Key { start, end: i });
                            frame.open_field = Some(fields.len());
                            fields.push(Field {
                                node,
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
            nodes,
            fields,
            parens,
            too_deep,
            line_starts,
            text: text.to_string(),
        }
    }

    /// Position of the first bracket nested deeper than [`MAX_NESTING`], if any; the
    /// scan stopped there, so the text must be refused.
    pub fn too_deep(&self) -> Option<TextPosition> {
        self.too_deep.map(|offset| self.position_of(offset))
    }

    /// Position of the key of the field at `path` (its first occurrence).
    pub fn key_position(&self, path: &str) -> Option<TextPosition> {
        let field = self.fields.iter().find(|f| self.path_is(f.node, path))?;
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
            if p.ends_with(']') {
                if let Some(f) = self.fields.iter().find(|f| self.is_key_under(f.node, &p)) {
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
            .map(|f| self.path_string(f.node))
    }

    /// Path of the innermost `(...)` that contains `position` or ends just before it
    /// (where ron reports a missing field).
    pub fn struct_at(&self, position: TextPosition) -> Option<String> {
        let offset = self.offset_of(position)?;
        self.parens
            .iter()
            .filter(|(open, close, _)| *open < offset && offset <= close + 1)
            .min_by_key(|(open, close, _)| close - open)
            .map(|&(_, _, node)| self.path_string(node))
    }

    /// The key of the last field at or before `position` whose name is `name`.
    pub fn key_before(&self, position: TextPosition, name: &str) -> Option<TextPosition> {
        let offset = self.offset_of(position)?;
        self.fields
            .iter()
            .rfind(|f| f.key_offset <= offset && self.last_key(f.node) == Some(name))
            .map(|f| self.position_of(f.key_offset))
    }

    /// The dotted path of `node` ("" for [`ROOT`]).
    fn path_string(&self, node: u32) -> String {
        let mut segments = Vec::new();
        let mut n = node;
        while let Some(p) = self.nodes.get(n as usize) {
            segments.push(*p);
            n = p.parent;
        }
        let mut path = String::new();
        for (k, p) in segments.iter().rev().enumerate() {
            match p.segment {
                Segment::Key { start, end } => {
                    if k > 0 {
                        path.push('.');
                    }
                    path.push_str(&self.text[start..end]);
                }
                Segment::Index(i) => path.push_str(&format!("[{i}]")),
            }
        }
        path
    }

    /// Whether the path of `node` is `target`, compared from the end: the cost is
    /// bounded by `target`'s length, not the path's.
    fn path_is(&self, node: u32, target: &str) -> bool {
        let mut rest = target;
        let mut n = node;
        while let Some(p) = self.nodes.get(n as usize) {
            let stripped = match p.segment {
                Segment::Key { start, end } => {
                    rest.strip_suffix(&self.text[start..end])
                        .and_then(|r| match p.parent {
                            ROOT => Some(r),
                            _ => r.strip_suffix('.'),
                        })
                }
                Segment::Index(i) => rest.strip_suffix(&format!("[{i}]")[..]),
            };
            match stripped {
                Some(r) => rest = r,
                None => return false,
            }
            n = p.parent;
        }
        rest.is_empty()
    }

    /// Whether `node` is a key somewhere under the value at path `ancestor` (its path
    /// starts with `ancestor.`).
    fn is_key_under(&self, node: u32, ancestor: &str) -> bool {
        let mut n = node;
        while let Some(p) = self.nodes.get(n as usize) {
            if matches!(p.segment, Segment::Key { .. })
                && p.parent != ROOT
                && self.path_is(p.parent, ancestor)
            {
                return true;
            }
            n = p.parent;
        }
        false
    }

    /// The name of `node` when it is a key.
    fn last_key(&self, node: u32) -> Option<&str> {
        match self.nodes.get(node as usize)?.segment {
            Segment::Key { start, end } => self.text.get(start..end),
            Segment::Index(_) => None,
        }
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

/// Appends a node and returns its index.
fn push_node(nodes: &mut Vec<PathNode>, parent: u32, segment: Segment) -> u32 {
    nodes.push(PathNode { parent, segment });
    // A text of under 4 GiB has fewer nodes than u32::MAX (each needs a byte).
    (nodes.len() - 1) as u32
}

/// The path a value opened now would belong to (a new node for a list element).
fn current_path(nodes: &mut Vec<PathNode>, fields: &[Field], frame: Option<&Frame>) -> u32 {
    let Some(frame) = frame else {
        return ROOT;
    };
    let base = match frame.open_field.and_then(|f| fields.get(f)) {
        Some(field) => field.node,
        None => frame.prefix,
    };
    if frame.bracket == Bracket::Square {
        push_node(nodes, base, Segment::Index(frame.list_index))
    } else {
        base
    }
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

    #[test]
    fn deep_nesting_stops_the_scan_at_the_first_bracket_too_deep() {
        let text = "[".repeat(100_000);
        let f = FieldPositions::scan(&text);
        assert_eq!(
            f.too_deep(),
            Some(TextPosition {
                line: 1,
                column: MAX_NESTING + 1
            })
        );
        let ok = format!("{}{}", "[".repeat(MAX_NESTING), "]".repeat(MAX_NESTING));
        assert_eq!(FieldPositions::scan(&ok).too_deep(), None);
    }

    /// Many fields under a long, deep path: the scan stays linear (a string per
    /// field copied the whole prefix, quadratic in the text) and paths still read.
    #[test]
    fn long_paths_scan_in_linear_memory() {
        let key = "k".repeat(10_000);
        let depth = 60;
        let mut text = format!("{}(", format!("({key}: ").repeat(depth));
        for _ in 0..20_000 {
            text.push_str("a: 1, ");
        }
        text.push_str(&")".repeat(depth + 1));
        let f = FieldPositions::scan(&text);
        assert_eq!(f.too_deep(), None);
        assert_eq!(f.fields.len(), depth + 20_000);
        assert!(f.nodes.len() <= depth + 20_000);
        let deepest = format!("{}.a", vec![key.as_str(); depth].join("."));
        assert_eq!(
            f.key_position(&deepest),
            Some(TextPosition {
                line: 1,
                column: depth * (key.len() + 3) + 2
            })
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
