//! Errors in user input (scene files, meshes, command-line arguments), with their location.
//!
//! Every error a user can cause is a [`SceneError`] value that names where it is (file, line and
//! column when known) and what was expected. Nothing in loading panics on bad input.

use std::fmt;
use std::path::Path;
use std::sync::Arc;

/// A text the user wrote (a scene file, or the command line), kept for error messages.
#[derive(Debug)]
pub struct Source {
    /// What to call it in messages: a path, or `<command line>`.
    pub name: String,
    /// The full text.
    pub text: String,
    line_starts: Vec<usize>,
}

impl Source {
    /// Wraps a named text.
    pub fn new(name: impl Into<String>, text: impl Into<String>) -> Arc<Self> {
        let text = text.into();
        let line_starts = std::iter::once(0).chain(text.match_indices('\n').map(|(i, _)| i + 1)).collect();
        Arc::new(Source { name: name.into(), text, line_starts })
    }

    /// 1-based line and column (in characters) of byte `offset`.
    pub fn line_col(&self, offset: usize) -> (usize, usize) {
        let offset = offset.min(self.text.len());
        let line = self.line_starts.partition_point(|&s| s <= offset).max(1) - 1;
        let start = self.line_starts[line];
        let col = self.text.get(start..offset).map_or(offset - start, |s| s.chars().count());
        (line + 1, col + 1)
    }

    /// The text of 1-based line `line`, without its newline.
    pub fn line_text(&self, line: usize) -> &str {
        let start = self.line_starts.get(line.wrapping_sub(1)).copied().unwrap_or(self.text.len());
        let end = self.line_starts.get(line).map_or(self.text.len(), |&e| e - 1);
        self.text.get(start..end.max(start)).unwrap_or("").trim_end_matches('\r')
    }
}

/// A byte range in a [`Source`].
#[derive(Clone, Debug)]
pub struct Loc {
    /// The text the range is in.
    pub source: Arc<Source>,
    /// Byte offset of the first byte.
    pub start: usize,
    /// Byte offset one past the last byte.
    pub end: usize,
}

impl Loc {
    /// A range in `source`.
    pub fn new(source: &Arc<Source>, range: std::ops::Range<usize>) -> Self {
        Loc { source: source.clone(), start: range.start, end: range.end }
    }

    /// `name:line:col`; `name` alone in a source with no text (a scene raylab made itself from a
    /// model file, located at the file: there is no line 1 to point at).
    pub fn describe(&self) -> String {
        if self.source.text.is_empty() {
            return self.source.name.clone();
        }
        let (l, c) = self.source.line_col(self.start);
        format!("{}:{l}:{c}", self.source.name)
    }
}

/// Where an error is.
#[derive(Clone, Debug)]
pub enum Location {
    /// Not tied to any input text.
    None,
    /// A file, with an optional 1-based line and column (for files raylab did not parse itself).
    File {
        /// Path as given or resolved.
        path: String,
        /// Line and column, when the parser reported them.
        line_col: Option<(usize, usize)>,
    },
    /// A range in a text raylab parsed.
    Span(Loc),
}

/// An error in user input: what is wrong, where, and optionally how to fix it.
#[derive(Clone, Debug)]
pub struct SceneError {
    /// What is wrong and what was expected, in one sentence.
    pub message: String,
    /// Where.
    pub location: Location,
    /// A hint, such as the list of valid names.
    pub help: Option<String>,
}

impl SceneError {
    /// An error at a located value.
    pub fn at(loc: &Loc, message: impl Into<String>) -> Self {
        SceneError { message: message.into(), location: Location::Span(loc.clone()), help: None }
    }

    /// An error in a file, optionally at a line and column.
    pub fn in_file(path: impl AsRef<Path>, line_col: Option<(usize, usize)>, message: impl Into<String>) -> Self {
        SceneError { message: message.into(), location: Location::File { path: path.as_ref().display().to_string(), line_col }, help: None }
    }

    /// An error with no location (command-line conflicts and the like).
    pub fn msg(message: impl Into<String>) -> Self {
        SceneError { message: message.into(), location: Location::None, help: None }
    }

    /// Adds a hint.
    pub fn with_help(mut self, help: impl Into<String>) -> Self {
        self.help = Some(help.into());
        self
    }

    /// Prefixes the message with context, such as `object #3 "ball" (sphere): `.
    pub fn context(mut self, what: impl fmt::Display) -> Self {
        self.message = format!("{what}: {}", self.message);
        self
    }

    /// `file:line:col` or `file`, when known.
    pub fn where_(&self) -> Option<String> {
        match &self.location {
            Location::None => None,
            Location::File { path, line_col: Some((l, c)) } => Some(format!("{path}:{l}:{c}")),
            Location::File { path, line_col: None } => Some(path.clone()),
            Location::Span(loc) => Some(loc.describe()),
        }
    }

    /// The full report: location, message, the offending source line with a caret, and the hint.
    pub fn report(&self) -> String {
        let mut out = self.to_string();
        if let Location::Span(loc) = &self.location
            && !loc.source.text.is_empty()
        {
            let (line, col) = loc.source.line_col(loc.start);
            let text = loc.source.line_text(line);
            let width = loc.source.text.get(loc.start..loc.end).map_or(1, |s| s.lines().next().unwrap_or("").chars().count()).max(1);
            let gutter = line.to_string().len();
            out.push_str(&format!(
                "\n{:gutter$} |\n{line} | {text}\n{:gutter$} | {}{}",
                "",
                "",
                " ".repeat(col - 1),
                "^".repeat(width.min(text.chars().count().saturating_sub(col - 1).max(1)))
            ));
        }
        if let Some(h) = &self.help {
            out.push_str(&format!("\n  help: {h}"));
        }
        out
    }
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.where_() {
            Some(w) => write!(f, "{w}: {}", self.message),
            None => write!(f, "{}", self.message),
        }
    }
}

impl std::error::Error for SceneError {}

/// Result of loading or validating user input.
pub type Result<T, E = SceneError> = std::result::Result<T, E>;

/// The closest of `candidates` to `word` by edit distance, if it is close enough to be a likely typo.
pub fn did_you_mean<'a>(word: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    candidates
        .into_iter()
        .map(|c| (edit_distance(word, c), c))
        .filter(|&(d, c)| d <= (c.len().max(word.len()) / 3).max(1))
        .min_by_key(|&(d, _)| d)
        .map(|(_, c)| c)
}

fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, &cb) in b.iter().enumerate() {
            cur[j + 1] = (prev[j] + usize::from(ca != cb)).min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}

/// A number as messages and summaries show it: as written (`0.05`, `1024`) between
/// [`Num::PLAIN`]'s bounds, in scientific notation outside them (`1e300`, `1e-9`), where Rust's
/// `{}` spells out every digit (301 of them for `1e300`). Shortest text that reads back exactly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Num(pub f64);

impl Num {
    /// Magnitudes shown as written: `1e-4 ≤ |v| < 1e9` (and 0).
    pub const PLAIN: (f64, f64) = (1e-4, 1e9);
}

impl std::fmt::Display for Num {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let v = self.0;
        if v == 0.0 || !v.is_finite() || (Self::PLAIN.0..Self::PLAIN.1).contains(&v.abs()) { write!(f, "{v}") } else { write!(f, "{v:e}") }
    }
}

/// The sentence that says raylab lacks the cargo feature `feature`, and how to build it in:
/// every error about something a feature would add (a mesh file, EXR output, a BVH) ends with it.
pub fn built_without(feature: &str) -> String {
    format!(
        "raylab was built without the `{feature}` feature: rebuild with `--features {feature}` \
         (`cargo install --path plugins --features mesh,bvh,exr` installs every feature)"
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A location in a source with no text (a model file's own scene) names the file alone,
    /// without a line 1 that is not the file's and an empty snippet.
    #[test]
    fn a_location_in_no_text_names_the_file_alone() {
        let s = Source::new("/models/box.obj", String::new());
        let e = SceneError::at(&Loc::new(&s, 0..0), "object #0 (mesh): cannot read it").with_help("fix it");
        assert_eq!(e.report(), "/models/box.obj: object #0 (mesh): cannot read it\n  help: fix it");
        let s = Source::new("a.toml", "x = 1\n".to_string());
        assert_eq!(SceneError::at(&Loc::new(&s, 4..5), "bad").report(), "a.toml:1:5: bad\n  |\n1 | x = 1\n  |     ^");
    }

    #[test]
    fn numbers_are_compact_and_exact() {
        let shown: Vec<String> =
            [0.05, 1024.0, 0.0, 1e300, 1e-9, -2.5e12, f64::INFINITY, 1e-4, 123456789.0].iter().map(|&v| Num(v).to_string()).collect();
        assert_eq!(shown, ["0.05", "1024", "0", "1e300", "1e-9", "-2.5e12", "inf", "0.0001", "123456789"]);
        for v in [0.1, 1e300, 3.0e-7, -1.0 / 3.0, f64::MIN_POSITIVE] {
            assert_eq!(Num(v).to_string().parse::<f64>(), Ok(v), "{v:e} reads back");
        }
    }

    #[test]
    fn line_and_column_are_one_based_and_count_characters() {
        let s = Source::new("x.toml", "a = 1\nbé = \"x\"\n");
        assert_eq!(s.line_col(0), (1, 1));
        assert_eq!(s.line_col(6), (2, 1));
        let off = s.text.find('=').unwrap();
        assert_eq!(s.line_col(s.text[off + 1..].find('=').unwrap() + off + 1), (2, 4));
        assert_eq!(s.line_text(2), "bé = \"x\"");
    }

    #[test]
    fn report_shows_the_line_and_a_caret() {
        let s = Source::new("x.toml", "radius = \"big\"\n");
        let e = SceneError::at(&Loc::new(&s, 9..14), "expected a number").with_help("radius is in scene units");
        let r = e.report();
        assert!(r.starts_with("x.toml:1:10: expected a number"), "{r}");
        assert!(r.contains("^^^^^") && r.contains("help:"), "{r}");
    }

    #[test]
    fn suggestions_find_typos_only() {
        assert_eq!(did_you_mean("radus", ["center", "radius"]), Some("radius"));
        assert_eq!(did_you_mean("colour", ["color", "intensity"]), Some("color"));
        assert_eq!(did_you_mean("zzz", ["center", "radius"]), None);
    }
}
