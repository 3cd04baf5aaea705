//! Scene errors and the locator that turns a field path or a TOML span into
//! `file:line: field`.
//!
//! The scene text is parsed twice: once by serde into the raw structs (syntax,
//! unknown keys and type errors come back with a span), and once into toml's
//! spanned document tree ([`toml::de::DeTable`]). Semantic checks name the
//! field they reject as a path (`materials.wall.reflectance`,
//! `objects.table.faces[2]`) and the locator walks the tree to find its line,
//! so every error — syntactic or semantic — names file, line and field.

use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};

use toml::Spanned;
use toml::de::{DeTable, DeValue};

/// Why a scene could not be loaded.
///
/// `Display` is `file:line: field: message` (1-based line), e.g.
/// `office.toml:42: materials.wall.reflectance: reflectance 1.2 at 550 nm exceeds 1`.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// Something in the scene text is wrong.
    #[error("{}:{line}: {field}: {message}", path.display())]
    Invalid {
        path: PathBuf,
        /// 1-based line in the scene file.
        line: usize,
        /// 1-based column (characters) in that line.
        column: usize,
        /// The offending field as a dotted path, e.g. `objects.table.faces[2]`.
        field: String,
        message: String,
    },
    /// The file itself could not be read.
    #[error("{}: cannot read the {what} file", path.display())]
    Io {
        path: PathBuf,
        /// What the file is (`scene`, `sequence`): a sequence file that
        /// cannot be read was called a scene file.
        what: &'static str,
        #[source]
        source: std::io::Error,
    },
}

impl SceneError {
    /// The 1-based line the error points at (1 for an unreadable file).
    pub fn line(&self) -> usize {
        match self {
            SceneError::Invalid { line, .. } => *line,
            SceneError::Io { .. } => 1,
        }
    }

    /// The offending field path.
    pub fn field(&self) -> &str {
        match self {
            SceneError::Invalid { field, .. } => field,
            SceneError::Io { .. } => "(file)",
        }
    }

    /// The scene file.
    pub fn path(&self) -> &Path {
        match self {
            SceneError::Invalid { path, .. } | SceneError::Io { path, .. } => path,
        }
    }
}

/// One step of a field path.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Seg {
    Key(String),
    Index(usize),
}

/// A dotted field path such as `objects.table.faces[2]`.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct FieldPath(pub(crate) Vec<Seg>);

impl FieldPath {
    pub(crate) fn root() -> Self {
        Self(Vec::new())
    }

    pub(crate) fn key(&self, k: &str) -> Self {
        let mut v = self.0.clone();
        v.push(Seg::Key(k.to_string()));
        Self(v)
    }

    pub(crate) fn index(&self, i: usize) -> Self {
        let mut v = self.0.clone();
        v.push(Seg::Index(i));
        Self(v)
    }
}

impl fmt::Display for FieldPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.0.is_empty() {
            return f.write_str("(document)");
        }
        for (i, s) in self.0.iter().enumerate() {
            match s {
                Seg::Key(k) => {
                    if i > 0 {
                        f.write_str(".")?;
                    }
                    f.write_str(k)?;
                }
                Seg::Index(n) => write!(f, "[{n}]")?,
            }
        }
        Ok(())
    }
}

/// Maps field paths and spans of one scene text to lines.
pub(crate) struct Locator<'a> {
    pub(crate) path: &'a Path,
    text: &'a str,
    root: Option<Spanned<DeTable<'a>>>,
}

impl<'a> Locator<'a> {
    pub(crate) fn new(text: &'a str, path: &'a Path) -> Self {
        Self {
            path,
            text,
            root: DeTable::parse(text).ok(),
        }
    }

    /// 1-based (line, column) of a byte offset.
    pub(crate) fn line_col(&self, offset: usize) -> (usize, usize) {
        let mut offset = offset.min(self.text.len());
        while !self.text.is_char_boundary(offset) {
            offset -= 1;
        }
        let before = self.text.get(..offset).unwrap_or(self.text);
        let line = before.matches('\n').count() + 1;
        let col = before
            .rsplit('\n')
            .next()
            .map(|l| l.chars().count())
            .unwrap_or(0)
            + 1;
        (line, col)
    }

    /// An error about `field`, located at the deepest part of the path found
    /// in the document (the key of a table entry, or an array element).
    pub(crate) fn error(&self, field: &FieldPath, message: impl Into<String>) -> SceneError {
        let offset = self.span_of(field).map(|r| r.start).unwrap_or(0);
        let (line, column) = self.line_col(offset);
        SceneError::Invalid {
            path: self.path.to_path_buf(),
            line,
            column,
            field: field.to_string(),
            message: message.into(),
        }
    }

    /// An error at a span reported by the TOML parser or deserializer; the
    /// field is the deepest document node holding the span.
    pub(crate) fn error_at(&self, span: Option<Range<usize>>, message: &str) -> SceneError {
        let offset = span.map(|r| r.start).unwrap_or(0);
        let (line, column) = self.line_col(offset);
        let field = match &self.root {
            Some(root) => {
                let mut p = FieldPath::root();
                path_in_table(root.get_ref(), offset, &mut p);
                p.to_string()
            }
            None => "(toml syntax)".to_string(),
        };
        SceneError::Invalid {
            path: self.path.to_path_buf(),
            line,
            column,
            field,
            message: message.trim().to_string(),
        }
    }

    /// The keys of the table at `field`, in the order they appear in the file.
    pub(crate) fn keys_in_file_order(&self, field: &FieldPath) -> Vec<String> {
        let Some(root) = &self.root else {
            return Vec::new();
        };
        let mut table = root.get_ref();
        for s in &field.0 {
            let Seg::Key(k) = s else { return Vec::new() };
            match table.iter().find(|(key, _)| key.get_ref() == k) {
                Some((_, v)) => match v.get_ref() {
                    DeValue::Table(t) => table = t,
                    _ => return Vec::new(),
                },
                None => return Vec::new(),
            }
        }
        let mut keys: Vec<(usize, String)> = table
            .iter()
            .map(|(k, _)| (k.span().start, k.get_ref().to_string()))
            .collect();
        keys.sort();
        keys.into_iter().map(|(_, k)| k).collect()
    }

    fn span_of(&self, field: &FieldPath) -> Option<Range<usize>> {
        let root = self.root.as_ref()?;
        let mut best = None;
        let mut table: Option<&DeTable> = Some(root.get_ref());
        let mut array: Option<&[Spanned<DeValue>]> = None;
        for s in &field.0 {
            let value = match s {
                Seg::Key(k) => {
                    let Some((key, v)) =
                        table.and_then(|t| t.iter().find(|(key, _)| key.get_ref() == k))
                    else {
                        break;
                    };
                    best = Some(key.span());
                    v
                }
                Seg::Index(i) => {
                    let Some(v) = array.and_then(|a| a.get(*i)) else {
                        break;
                    };
                    best = Some(v.span());
                    v
                }
            };
            table = None;
            array = None;
            match value.get_ref() {
                DeValue::Table(t) => table = Some(t),
                DeValue::Array(a) => array = Some(a),
                _ => {}
            }
        }
        best
    }
}

fn contains(span: &Range<usize>, offset: usize) -> bool {
    span.start <= offset && offset < span.end.max(span.start + 1)
}

/// Extends `path` with the deepest entry of `table` whose key or value holds
/// `offset`. Tables opened by a `[header]` may have a value span that covers
/// only the header, so a key belonging to the table body is matched by the
/// last entry whose key starts before the offset when nothing else matches.
fn path_in_table(table: &DeTable, offset: usize, path: &mut FieldPath) {
    let mut hit = None;
    for (k, v) in table.iter() {
        if contains(&k.span(), offset) || contains(&v.span(), offset) {
            hit = Some((k, v));
            break;
        }
    }
    if hit.is_none() {
        // Header tables (`[a]`, `[[a]]`): the entry whose subtree holds
        // the offset.
        hit = table.iter().find(|(_, v)| value_holds(v.get_ref(), offset));
    }
    let Some((k, v)) = hit else { return };
    path.0.push(Seg::Key(k.get_ref().to_string()));
    path_in_value(v, offset, path);
}

/// Whether a table, or an array of tables (`[[move]]`), holds `offset` in
/// one of its keys or values, at any depth.
fn value_holds(v: &DeValue, offset: usize) -> bool {
    match v {
        DeValue::Table(t) => t.iter().any(|(k, v)| {
            contains(&k.span(), offset)
                || contains(&v.span(), offset)
                || value_holds(v.get_ref(), offset)
        }),
        DeValue::Array(a) => a
            .iter()
            .any(|e| contains(&e.span(), offset) || value_holds(e.get_ref(), offset)),
        _ => false,
    }
}

fn path_in_value(v: &Spanned<DeValue>, offset: usize, path: &mut FieldPath) {
    match v.get_ref() {
        DeValue::Table(t) => path_in_table(t, offset, path),
        DeValue::Array(a) => {
            // An element of an array of tables may span only its header.
            if let Some((i, e)) = (a.iter().enumerate())
                .find(|(_, e)| contains(&e.span(), offset))
                .or_else(|| (a.iter().enumerate()).find(|(_, e)| value_holds(e.get_ref(), offset)))
            {
                path.0.push(Seg::Index(i));
                path_in_value(e, offset, path);
            }
        }
        _ => {}
    }
}
