//! The core is a stack of layers (docs/architecture.md): a module of `src/` may name only modules
//! of its own layer or of layers below it, and the files inside one module import each other
//! without a circle. This test reads the sources and checks both, naming the file, the line and
//! the path of every import that breaks them.
//!
//! What counts as an import: every path starting with `crate::`, `super::` or `self::` in the
//! code of a file (comments, strings and `#[cfg(test)]` items left out), and a bare path through
//! a child module the file declares (`mod render;` … `render::run(…)`). A path is resolved to the
//! file that defines its item, through `pub use` re-exports (`crate::render::RenderJob` is
//! `render/job.rs`'s). A `pub use` itself is an alias, not a use: it counts against the stack (a
//! lower layer may not offer a higher one's item) but not as an edge between the files of a
//! module (a `mod.rs` re-exporting its children is how a module shows its face).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The stack, bottom first: each layer may use the ones before it. One line each; the reasons are
/// in docs/architecture.md.
const STACK: &[(&str, &str)] = &[
    ("testing", "support for tests, the crate's and plugins': the χ² test of sampling, CI-aware skips, property seeds"),
    ("math", "numbers, rays, boxes, colours, deterministic sampling"),
    ("param", "the parameter language: located values, parameter tables, errors, TOML, sandboxed files, limits"),
    ("geometry", "what a ray can hit: `Intersectable`, `Geometry`, `Hit`, `Surface`, transforms"),
    ("accel", "hierarchies and lists over primitives"),
    ("scene", "the scene model: objects, materials, textures, lights, camera, `Interaction`"),
    ("render", "the render loop: integrators, samples, sums, the film"),
    ("image", "image formats, metrics, tev"),
    ("load", "scene files to render jobs: registry, load context, textures, the loader"),
    ("view", "the live view in the browser"),
    ("cli", "the command line"),
];

/// The crate root: re-exports of every layer for plugins, no code of its own.
const ROOT: &str = "lib.rs";

struct File {
    /// Path below `src/`, with `/`.
    rel: String,
    /// Module path (`["render", "job"]`).
    module: Vec<String>,
    /// The code with comments, strings and `#[cfg(test)]` items blanked (same line breaks).
    code: String,
}

/// One named path: where, the text, the file it resolves to, and whether it is a `pub use`.
#[derive(Clone, Debug)]
struct Import {
    line: usize,
    path: String,
    target: String,
    reexport: bool,
}

fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())) {
        let p = e.unwrap().path();
        if p.is_dir() {
            sources(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

fn module_of(rel: &str) -> Vec<String> {
    let mut m: Vec<String> = rel.trim_end_matches(".rs").split('/').map(String::from).collect();
    if matches!(m.last().map(String::as_str), Some("mod" | "lib")) {
        m.pop();
    }
    m
}

/// `src` with comments, string and char literals replaced by spaces (line breaks kept).
fn blank_comments_and_strings(src: &str) -> String {
    let b = src.as_bytes();
    let mut out = b.to_vec();
    let blank = |out: &mut Vec<u8>, from: usize, to: usize| {
        for c in &mut out[from..to] {
            if *c != b'\n' {
                *c = b' ';
            }
        }
    };
    let mut i = 0;
    while i < b.len() {
        let ident_before = i > 0 && (b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_');
        if b[i..].starts_with(b"//") {
            let end = b[i..].iter().position(|&c| c == b'\n').map_or(b.len(), |n| i + n);
            blank(&mut out, i, end);
            i = end;
        } else if b[i..].starts_with(b"/*") {
            let (mut depth, mut j) = (1, i + 2);
            while j < b.len() && depth > 0 {
                if b[j..].starts_with(b"/*") {
                    depth += 1;
                    j += 2;
                } else if b[j..].starts_with(b"*/") {
                    depth -= 1;
                    j += 2;
                } else {
                    j += 1;
                }
            }
            blank(&mut out, i, j);
            i = j;
        } else if !ident_before && (b[i] == b'r' || (b[i] == b'b' && b.get(i + 1) == Some(&b'r'))) && raw_string_at(b, i).is_some() {
            let end = raw_string_at(b, i).unwrap();
            blank(&mut out, i, end);
            i = end;
        } else if b[i] == b'"' {
            let mut j = i + 1;
            while j < b.len() && b[j] != b'"' {
                j += if b[j] == b'\\' { 2 } else { 1 };
            }
            blank(&mut out, i, (j + 1).min(b.len()));
            i = j + 1;
        } else if b[i] == b'\'' && !ident_before {
            // A char literal ('x', '\n', '\u{..}'), not a lifetime ('a).
            let end = if b.get(i + 1) == Some(&b'\\') {
                b[i + 2..].iter().position(|&c| c == b'\'').map(|n| i + 2 + n + 1)
            } else {
                let len = src[i + 1..].chars().next().map_or(1, char::len_utf8);
                (b.get(i + 1 + len) == Some(&b'\'')).then_some(i + 2 + len)
            };
            match end {
                Some(end) => {
                    blank(&mut out, i, end);
                    i = end;
                }
                None => i += 1,
            }
        } else {
            i += 1;
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// The end of the raw string literal starting at `i` (`r"…"`, `r#"…"#`, `br"…"`), if one does.
fn raw_string_at(b: &[u8], i: usize) -> Option<usize> {
    let mut j = i + if b[i] == b'b' { 2 } else { 1 };
    let hashes = b[j..].iter().take_while(|&&c| c == b'#').count();
    j += hashes;
    if b.get(j) != Some(&b'"') {
        return None;
    }
    let close: Vec<u8> = std::iter::once(b'"').chain(std::iter::repeat_n(b'#', hashes)).collect();
    let end = b[j + 1..].windows(close.len()).position(|w| w == close)?;
    Some(j + 1 + end + close.len())
}

/// The index just past the item starting at `from`: up to its `;` or its balanced `{…}`.
fn item_end(code: &[u8], from: usize) -> usize {
    let mut j = from;
    while j < code.len() && code[j] != b'{' && code[j] != b';' {
        j += 1;
    }
    if j >= code.len() || code[j] == b';' {
        return (j + 1).min(code.len());
    }
    let mut depth = 0;
    while j < code.len() {
        match code[j] {
            b'{' => depth += 1,
            b'}' => {
                depth -= 1;
                if depth == 0 {
                    return j + 1;
                }
            }
            _ => {}
        }
        j += 1;
    }
    j
}

/// `code` with every `#[cfg(test)]` item blanked: tests may reach up the stack.
fn blank_tests(code: &str) -> String {
    let mut out = code.as_bytes().to_vec();
    let mut at = 0;
    while let Some(n) = code[at..].find("#[cfg(test)]") {
        let start = at + n;
        let end = item_end(code.as_bytes(), start + "#[cfg(test)]".len());
        for c in &mut out[start..end] {
            if *c != b'\n' {
                *c = b' ';
            }
        }
        at = end;
    }
    String::from_utf8_lossy(&out).into_owned()
}

fn is_ident(c: u8) -> bool {
    c.is_ascii_alphanumeric() || c == b'_'
}

/// Expands a use tree (`a::{b, c::{d as e, self}}`, spaces removed) into whole paths.
fn expand(tree: &str) -> Vec<String> {
    let Some(open) = tree.find('{') else { return vec![tree.to_string()] };
    let (head, body) = (&tree[..open], &tree[open + 1..tree.rfind('}').unwrap_or(tree.len())]);
    let mut parts = Vec::new();
    let (mut depth, mut start) = (0, 0);
    for (i, c) in body.char_indices() {
        match c {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                parts.push(&body[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    parts.push(&body[start..]);
    parts
        .into_iter()
        .filter(|p| !p.is_empty())
        .flat_map(|p| {
            expand(p).into_iter().map(move |x| if x == "self" { head.trim_end_matches("::").to_string() } else { format!("{head}{x}") })
        })
        .collect()
}

/// Every path in `code` starting with one of `roots` (`crate`, `super`, `self`, or a child module
/// the file declares), with its line, as written (use trees expanded) and whether it is in a `pub use`.
fn paths(code: &str, roots: &[String]) -> Vec<(usize, String, bool)> {
    let b = code.as_bytes();
    let mut found = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if !is_ident(b[i]) || (i > 0 && (is_ident(b[i - 1]) || b[i - 1] == b':')) {
            i += 1;
            continue;
        }
        let word_end = i + b[i..].iter().take_while(|&&c| is_ident(c)).count();
        let word = &code[i..word_end];
        let dollar = i > 0 && b[i - 1] == b'$';
        if !(roots.iter().any(|r| r == word) || (dollar && word == "crate")) || !code[word_end..].starts_with("::") {
            i = word_end;
            continue;
        }
        // The whole path: identifiers, `::`, and a use tree in braces.
        let mut j = word_end;
        loop {
            if code[j..].starts_with("::") {
                j += 2;
            } else if j < b.len() && is_ident(b[j]) {
                j += b[j..].iter().take_while(|&&c| is_ident(c)).count();
            } else if j < b.len() && b[j] == b'{' && code[..j].ends_with("::") {
                let mut depth = 0;
                while j < b.len() {
                    match b[j] {
                        b'{' => depth += 1,
                        b'}' => {
                            depth -= 1;
                            if depth == 0 {
                                j += 1;
                                break;
                            }
                        }
                        _ => {}
                    }
                    j += 1;
                }
                break;
            } else if j < b.len() && b[j] == b'*' && code[..j].ends_with("::") {
                j += 1;
                break;
            } else {
                break;
            }
        }
        // A renaming after a plain path (`use a::b as c;`).
        let rest = &code[j..];
        if let Some(after) = rest.trim_start().strip_prefix("as")
            && rest.starts_with(char::is_whitespace)
            && after.starts_with(char::is_whitespace)
        {
            let name = after.trim_start();
            let len = name.bytes().take_while(|&c| is_ident(c)).count();
            j = code.len() - name.len() + len;
        }
        // Whitespace kept only where it separates words (`a as b`).
        let mut text = code[i..j].split_whitespace().collect::<Vec<_>>().join(" ");
        for sep in ["::", "{", "}", ","] {
            text = text.replace(&format!(" {sep}"), sep).replace(&format!("{sep} "), sep);
        }
        let text = text.trim_end_matches("::").to_string();
        let line = code[..i].matches('\n').count() + 1;
        let stmt_start = code[..i].rfind([';', '{', '}']).map_or(0, |k| k + 1);
        let words: Vec<&str> = code[stmt_start..i].split_whitespace().collect();
        let reexport = words.last() == Some(&"use") && words.len() >= 2 && words[words.len() - 2].starts_with("pub");
        for p in expand(&text) {
            found.push((line, p, reexport));
        }
        i = j;
    }
    found
}

struct Crate {
    files: Vec<File>,
    /// Module path → index into `files`.
    by_module: BTreeMap<Vec<String>, usize>,
    /// Per file: name → the path its `pub use` re-exports under that name.
    reexports: Vec<BTreeMap<String, Vec<String>>>,
}

impl Crate {
    fn read(src: &Path) -> Crate {
        let mut list = Vec::new();
        sources(src, &mut list);
        list.sort();
        let files: Vec<File> = list
            .iter()
            .map(|p| {
                let rel = p.strip_prefix(src).unwrap().to_string_lossy().replace('\\', "/");
                let text = std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
                File { module: module_of(&rel), rel, code: blank_tests(&blank_comments_and_strings(&text)) }
            })
            .collect();
        let by_module = files.iter().enumerate().map(|(i, f)| (f.module.clone(), i)).collect();
        let mut c = Crate { files, by_module, reexports: Vec::new() };
        c.reexports = (0..c.files.len())
            .map(|i| {
                let f = &c.files[i];
                let mut map = BTreeMap::new();
                for (_, p, reexport) in paths(&f.code, &c.roots(i)) {
                    if !reexport || p.ends_with('*') {
                        continue;
                    }
                    let (p, name) = alias(&p);
                    if let Some(abs) = c.absolute(i, &p) {
                        map.insert(name, abs);
                    }
                }
                map
            })
            .collect();
        c
    }

    /// What a path of file `i` may start with: `crate`, `super`, `self` and its declared children.
    fn roots(&self, i: usize) -> Vec<String> {
        let mut r = vec!["crate".to_string(), "super".to_string(), "self".to_string()];
        let code = &self.files[i].code;
        for (k, _) in code.match_indices("mod ") {
            let before = code[..k].chars().next_back();
            if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
                continue;
            }
            let rest = &code[k + 4..];
            let name: String = rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
            if !name.is_empty() && rest[name.len()..].trim_start().starts_with(';') {
                r.push(name);
            }
        }
        r
    }

    /// `path` (as written in file `i`) as segments from the crate root.
    fn absolute(&self, i: usize, path: &str) -> Option<Vec<String>> {
        let mut segs = path.split("::").map(String::from);
        let first = segs.next()?;
        let mut base = match first.as_str() {
            "crate" | "$crate" => Vec::new(),
            "self" => self.files[i].module.clone(),
            "super" => {
                let mut m = self.files[i].module.clone();
                m.pop();
                m
            }
            child => {
                let mut m = self.files[i].module.clone();
                m.push(child.to_string());
                m
            }
        };
        for s in segs {
            match s.as_str() {
                "super" => {
                    base.pop();
                }
                "self" => {}
                "*" => {}
                _ => base.push(s),
            }
        }
        Some(base)
    }

    /// The file defining the item at absolute path `segs`, through re-exports.
    fn resolve(&self, segs: &[String], depth: usize) -> Option<usize> {
        let k = (0..=segs.len()).rev().find(|&k| self.by_module.contains_key(&segs[..k]))?;
        let file = self.by_module[&segs[..k]];
        if depth < 8
            && let Some(next) = segs.get(k)
            && let Some(target) = self.reexports[file].get(next)
        {
            let mut t = target.clone();
            t.extend(segs[k + 1..].iter().cloned());
            return self.resolve(&t, depth + 1).or(Some(file));
        }
        Some(file)
    }

    fn imports(&self, i: usize) -> Vec<Import> {
        let mut out = Vec::new();
        for (line, p, reexport) in paths(&self.files[i].code, &self.roots(i)) {
            let (p, _) = alias(&p);
            let Some(abs) = self.absolute(i, &p) else { continue };
            let Some(t) = self.resolve(&abs, 0) else { continue };
            if t != i {
                out.push(Import { line, path: p, target: self.files[t].rel.clone(), reexport });
            }
        }
        out
    }
}

/// `a::b as c` → (`a::b`, `c`); `a::b` → (`a::b`, `b`).
fn alias(p: &str) -> (String, String) {
    match p.split_once(" as ") {
        Some((path, name)) => (path.to_string(), name.to_string()),
        None => (p.to_string(), p.rsplit("::").next().unwrap_or(p).to_string()),
    }
}

fn top(rel: &str) -> &str {
    rel.split('/').next().unwrap().trim_end_matches(".rs")
}

fn layer_of(rel: &str) -> Option<usize> {
    STACK.iter().position(|(name, _)| *name == top(rel))
}

/// Every import of `krate` that names a higher layer, and every top-level module not in the stack.
fn layer_violations(krate: &Crate) -> Vec<String> {
    let mut errors = Vec::new();
    for (i, f) in krate.files.iter().enumerate() {
        if f.rel == ROOT {
            continue;
        }
        let Some(from) = layer_of(&f.rel) else {
            errors.push(format!(
                "src/{}: module `{}` is in no layer: add it to the stack (tests/layers.rs, docs/architecture.md)",
                f.rel,
                top(&f.rel)
            ));
            continue;
        };
        for imp in krate.imports(i) {
            if imp.target == ROOT {
                errors.push(format!(
                    "src/{}:{}: `{}` names the crate root's re-export; name the item's own module",
                    f.rel, imp.line, imp.path
                ));
                continue;
            }
            let Some(to) = layer_of(&imp.target) else { continue };
            if to > from {
                errors.push(format!(
                    "src/{}:{}: `{}` ({}) is in layer `{}`, above `{}`: a layer may name only itself and the layers below it",
                    f.rel, imp.line, imp.path, imp.target, STACK[to].0, STACK[from].0
                ));
            }
        }
    }
    errors
}

/// Every circle between the files of one top-level module, each with the imports that close it.
fn file_circles(krate: &Crate) -> Vec<String> {
    // Edges between files of the same top-level module, with one example import each.
    let mut edges: BTreeMap<String, BTreeMap<String, (usize, String)>> = BTreeMap::new();
    for (i, f) in krate.files.iter().enumerate() {
        for imp in krate.imports(i) {
            if !imp.reexport && top(&imp.target) == top(&f.rel) && f.rel != ROOT {
                edges.entry(f.rel.clone()).or_default().entry(imp.target.clone()).or_insert((imp.line, imp.path.clone()));
            }
        }
    }
    // Tarjan's strongly connected components.
    struct Tarjan<'a> {
        edges: &'a BTreeMap<String, BTreeMap<String, (usize, String)>>,
        index: BTreeMap<&'a str, (usize, usize)>,
        stack: Vec<&'a str>,
        on_stack: BTreeSet<&'a str>,
        next: usize,
        sccs: Vec<Vec<&'a str>>,
    }
    impl<'a> Tarjan<'a> {
        fn visit(&mut self, v: &'a str) {
            self.index.insert(v, (self.next, self.next));
            self.next += 1;
            self.stack.push(v);
            self.on_stack.insert(v);
            for w in self.edges.get(v).into_iter().flat_map(|m| m.keys()) {
                let w = w.as_str();
                if !self.index.contains_key(w) {
                    self.visit(w);
                    let low = self.index[w].1.min(self.index[v].1);
                    self.index.get_mut(v).unwrap().1 = low;
                } else if self.on_stack.contains(w) {
                    let low = self.index[w].0.min(self.index[v].1);
                    self.index.get_mut(v).unwrap().1 = low;
                }
            }
            if self.index[v].0 == self.index[v].1 {
                let mut scc = Vec::new();
                while let Some(w) = self.stack.pop() {
                    self.on_stack.remove(w);
                    scc.push(w);
                    if w == v {
                        break;
                    }
                }
                self.sccs.push(scc);
            }
        }
    }
    let mut t = Tarjan { edges: &edges, index: BTreeMap::new(), stack: Vec::new(), on_stack: BTreeSet::new(), next: 0, sccs: Vec::new() };
    for v in edges.keys() {
        if !t.index.contains_key(v.as_str()) {
            t.visit(v);
        }
    }
    let mut errors = Vec::new();
    for mut scc in t.sccs.into_iter().filter(|s| s.len() > 1) {
        scc.sort();
        let members: BTreeSet<&str> = scc.iter().copied().collect();
        let mut lines =
            vec![format!("a circle between the files {}:", scc.iter().map(|f| format!("src/{f}")).collect::<Vec<_>>().join(", "))];
        for from in &scc {
            for (to, (line, path)) in &edges[*from] {
                if members.contains(to.as_str()) {
                    lines.push(format!("    src/{from}:{line}: `{path}` ({to})"));
                }
            }
        }
        errors.push(lines.join("\n"));
    }
    errors
}

fn src_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

#[test]
fn every_import_points_down_the_stack() {
    let errors = layer_violations(&Crate::read(&src_dir()));
    assert!(errors.is_empty(), "imports against the layer order (docs/architecture.md):\n{}", errors.join("\n"));
}

#[test]
fn no_circle_between_the_files_of_a_module() {
    let errors = file_circles(&Crate::read(&src_dir()));
    assert!(errors.is_empty(), "{}", errors.join("\n"));
}

/// The checks find what they are for: a lower layer naming a higher one directly, by `super::`,
/// in a use tree, through re-exports (the crate root's too) and in a `pub use`; a module in no
/// layer; two files of a module naming each other. Comments, strings and tests do not count.
#[test]
fn the_checks_find_planted_violations() {
    let dir = std::env::temp_dir().join(format!("raylab-layers-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let write = |rel: &str, text: &str| {
        let p = dir.join(rel);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, text).unwrap();
    };
    write("lib.rs", "pub mod extra;\npub mod math;\npub mod render;\npub mod scene;\npub use render::job::Job as Thing;\n");
    write("extra/mod.rs", "");
    write("math/mod.rs", "pub mod a;\npub mod b;\n// crate::render::Job in a comment\nconst S: &str = \"crate::render::Job\";\n");
    write("math/a.rs", "use super::b::B;\npub struct A;\nfn g(_: crate::Thing) {}\n");
    write("math/b.rs", "use crate::math::a::A;\npub struct B;\n");
    write(
        "scene/mod.rs",
        "pub mod inner;\nuse crate::{math::a::A, render::{job::Job}};\npub use crate::render::Job as J;\n#[cfg(test)]\nmod tests {\n    use crate::render::Job;\n}\n",
    );
    write("scene/inner.rs", "fn f() -> super::super::render::Job {\n    todo!()\n}\n");
    write("render/mod.rs", "pub mod job;\npub use job::Job;\nuse crate::scene::inner;\n");
    write("render/job.rs", "pub struct Job;\nfn f(_: &crate::math::a::A) {}\n");
    let krate = Crate::read(&dir);
    let layers = layer_violations(&krate);
    let circles = file_circles(&krate);
    std::fs::remove_dir_all(&dir).unwrap();
    let expected = [
        "src/extra/mod.rs: module `extra` is in no layer",
        "src/math/a.rs:3: `crate::Thing` (render/job.rs) is in layer `render`, above `math`",
        "src/scene/inner.rs:1: `super::super::render::Job` (render/job.rs) is in layer `render`, above `scene`",
        "src/scene/mod.rs:2: `crate::render::job::Job` (render/job.rs) is in layer `render`, above `scene`",
        "src/scene/mod.rs:3: `crate::render::Job` (render/job.rs) is in layer `render`, above `scene`",
    ];
    assert_eq!(layers.len(), expected.len(), "{layers:#?}");
    for (found, expected) in layers.iter().zip(expected) {
        assert!(found.starts_with(expected), "{found}\nexpected: {expected}…");
    }
    assert_eq!(circles.len(), 1, "{circles:#?}");
    assert!(circles[0].contains("src/math/a.rs:1: `super::b::B` (math/b.rs)"), "{}", circles[0]);
    assert!(circles[0].contains("src/math/b.rs:1: `crate::math::a::A` (math/a.rs)"), "{}", circles[0]);
}
