//! Writing a scene description back as raylab's TOML scene format (`raylab convert`).
//!
//! The writer is exact: reading its output gives the same [`Table`] (same keys, same value types,
//! bit-identical numbers), so a scene converted from another format renders the same image as the
//! original. Layout: the root's plain values first, then `[table]` sections (nested tables as
//! `[a.b]`), then `[[array]]` tables, whose nested tables are written inline.

use crate::param::description::SceneDescription;
use crate::param::error::{Loc, Result, SceneError, Source};
use crate::param::value::Node;
use crate::param::value::{Table, Value};
use std::fmt::Write;
use std::sync::Arc;

/// The scene's root table as TOML text, preceded by `header` lines written as `#` comments.
pub fn to_toml(desc: &SceneDescription, header: &str) -> String {
    let mut out = String::new();
    for line in header.lines() {
        out.push_str(if line.is_empty() { "#" } else { "# " });
        out.push_str(line);
        out.push('\n');
    }
    if !header.is_empty() {
        out.push('\n');
    }
    out.push_str(&table_to_toml(&desc.root));
    out
}

/// A table as a TOML document.
pub fn table_to_toml(t: &Table) -> String {
    let mut out = String::new();
    write_section(&mut out, &[], t);
    for e in &t.entries {
        if let Some(items) = tables_of(&e.value.value) {
            for item in items {
                let _ = write!(out, "\n[[{}]]\n", key(&e.key));
                for ie in &item.entries {
                    let _ = writeln!(out, "{} = {}", key(&ie.key), inline(&ie.value.value));
                }
            }
        }
    }
    out
}

/// True when `a` and `b` hold the same keys with the same values, ignoring locations and the order
/// of table keys (the order of list items matters). Integers and floats are different values;
/// floats compare bit for bit (so NaN equals NaN and 0.0 differs from −0.0).
pub fn same_values(a: &Table, b: &Table) -> bool {
    a.entries.len() == b.entries.len() && a.entries.iter().all(|e| b.get(&e.key).is_some_and(|v| same_value(&e.value.value, &v.value)))
}

fn same_value(a: &Value, b: &Value) -> bool {
    match (a, b) {
        (Value::Bool(x), Value::Bool(y)) => x == y,
        (Value::Int(x), Value::Int(y)) => x == y,
        (Value::Float(x), Value::Float(y)) => x.to_bits() == y.to_bits(),
        (Value::Str(x), Value::Str(y)) => x == y,
        (Value::Array(x), Value::Array(y)) => x.len() == y.len() && x.iter().zip(y).all(|(p, q)| same_value(&p.value, &q.value)),
        (Value::Table(x), Value::Table(y)) => same_values(x, y),
        _ => false,
    }
}

/// The tables of a non-empty list made only of tables (written as `[[key]]`).
fn tables_of(v: &Value) -> Option<Vec<&Table>> {
    let Value::Array(items) = v else { return None };
    if items.is_empty() {
        return None;
    }
    items.iter().map(|n| if let Value::Table(t) = &n.value { Some(t) } else { None }).collect()
}

/// Writes the plain values of `t` under the header `[path]` (none for the root), then its
/// sub-tables as sections. Lists of tables are left to the caller at the root; deeper ones are
/// written inline.
fn write_section(out: &mut String, path: &[&str], t: &Table) {
    let at_root = path.is_empty();
    let is_section = |v: &Value| matches!(v, Value::Table(_)) || (at_root && tables_of(v).is_some());
    let plain: Vec<_> = t.entries.iter().filter(|e| !is_section(&e.value.value)).collect();
    let has_sub = t.entries.iter().any(|e| matches!(e.value.value, Value::Table(_)));
    if !at_root && (!plain.is_empty() || !has_sub) {
        let header: Vec<String> = path.iter().map(|k| key(k)).collect();
        let _ = writeln!(out, "{}[{}]", if out.is_empty() { "" } else { "\n" }, header.join("."));
    }
    for e in plain {
        let _ = writeln!(out, "{} = {}", key(&e.key), inline(&e.value.value));
    }
    for e in &t.entries {
        if let Value::Table(sub) = &e.value.value {
            let mut p = path.to_vec();
            p.push(&e.key);
            write_section(out, &p, sub);
        }
    }
}

/// A value in inline form.
fn inline(v: &Value) -> String {
    match v {
        Value::Bool(b) => b.to_string(),
        Value::Int(i) => i.to_string(),
        Value::Float(f) => float(*f),
        Value::Str(s) => string(s),
        Value::Array(items) => {
            let parts: Vec<String> = items.iter().map(|n| inline(&n.value)).collect();
            format!("[{}]", parts.join(", "))
        }
        Value::Table(t) if t.entries.is_empty() => "{}".into(),
        Value::Table(t) => {
            let parts: Vec<String> = t.entries.iter().map(|e| format!("{} = {}", key(&e.key), inline(&e.value.value))).collect();
            format!("{{ {} }}", parts.join(", "))
        }
    }
}

/// A float that reads back bit-identical: Rust's shortest round-trip form, always with a `.` or an
/// exponent so TOML reads a float, and TOML's names for the non-finite values.
fn float(f: f64) -> String {
    if f.is_nan() {
        return if f.is_sign_negative() { "-nan".into() } else { "nan".into() };
    }
    if f.is_infinite() {
        return if f > 0.0 { "inf".into() } else { "-inf".into() };
    }
    let s = format!("{f:?}");
    if s.contains(['.', 'e', 'E']) { s } else { format!("{s}.0") }
}

/// A key: bare when TOML allows it, quoted otherwise.
fn key(k: &str) -> String {
    if !k.is_empty() && k.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-') { k.to_string() } else { string(k) }
}

/// `s` as a TOML basic string, quoted, with the required escapes.
pub fn string(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\t' => out.push_str("\\t"),
            '\r' => out.push_str("\\r"),
            c if c.is_control() => {
                let _ = write!(out, "\\u{:04X}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// Parses raylab's TOML scene format into a description.
pub fn parse_toml(source: &Arc<Source>, name: String) -> Result<SceneDescription> {
    let loc = Loc::new(source, 0..source.text.len());
    let root = match parse_in_parts(source) {
        Some(root) => root,
        None => parse_whole(source)?,
    };
    Ok(SceneDescription { name, root, loc })
}

/// The whole text parsed at once.
fn parse_whole(source: &Arc<Source>) -> Result<Table> {
    let doc = toml::de::DeTable::parse(&source.text).map_err(|e| {
        let span = e.span().unwrap_or(0..0);
        SceneError::at(&Loc::new(source, span), format!("TOML syntax error: {}", e.message().trim()))
    })?;
    // Consumed as it is converted: each part of the parser's tree is freed once copied, so the
    // two trees never coexist whole.
    convert_table(doc.into_inner(), source, 0)
}

/// Scene text longer than this is parsed a part at a time ([`parse_in_parts`]).
pub const PART_BYTES: usize = 1 << 20;

/// A long scene parsed a part at a time, so that the parser's tree (its tokens and tables, about
/// 40 times the text) exists for one part of about [`PART_BYTES`] at once, not for the whole
/// file: the text is cut before top-level `[[KEY]]` headers (one bare key: `[[object]]`,
/// `[[light]]`), found by the TOML lexer outside strings, arrays and inline tables; each part is
/// parsed and converted, and its tables appended to the arrays the parts before opened. `None`
/// when the text is short, has no place to cut, or when anything is not plain: a part that does
/// not parse or convert, or a part defining a top-level key an earlier part defined otherwise
/// than as a `[[KEY]]` array. The caller then parses the whole text, which gives exactly the
/// result and the errors it always gave; a scene cut in parts gives the same tree, locations
/// included.
fn parse_in_parts(source: &Arc<Source>) -> Option<Table> {
    let text = source.text.as_str();
    if text.len() <= PART_BYTES {
        return None;
    }
    let parts = cut(text);
    if parts.len() < 2 {
        return None;
    }
    let mut root = Table::default();
    // Keys an earlier part opened as `[[KEY]]` arrays: a later part may append to them.
    let mut arrays: Vec<&str> = Vec::new();
    for (i, (start, keys)) in parts.iter().enumerate() {
        let end = parts.get(i + 1).map_or(text.len(), |p| p.0);
        let doc = toml::de::DeTable::parse(&text[*start..end]).ok()?;
        let part = convert_table(doc.into_inner(), source, *start).ok()?;
        for e in part.entries {
            match root.entries.iter_mut().find(|r| r.key == e.key) {
                None => root.entries.push(e),
                Some(r) => match (&mut r.value.value, e.value.value) {
                    (Value::Array(items), Value::Array(more)) if arrays.contains(&e.key.as_str()) => items.extend(more),
                    _ => return None,
                },
            }
        }
        arrays.extend(keys.iter().copied());
    }
    Some(root)
}

/// Where to cut `text` for [`parse_in_parts`]: the start of each part (the first is 0, each
/// other a top-level `[[KEY]]` header at least [`PART_BYTES`] after the part before), with the
/// keys of the `[[KEY]]` headers in the part.
fn cut(text: &str) -> Vec<(usize, Vec<&str>)> {
    use toml_parser::lexer::TokenKind as K;
    let mut parts: Vec<(usize, Vec<&str>)> = vec![(0, Vec::new())];
    let mut lexer = toml_parser::Source::new(text).lex().filter(|t| !matches!(t.kind(), K::Whitespace | K::Comment)).peekable();
    let (mut depth, mut line_start) = (0usize, true);
    while let Some(t) = lexer.next() {
        let kind = t.kind();
        if line_start && depth == 0 && kind == K::LeftSquareBracket {
            // A header: `[a.b]` or `[[a.b]]`. Only `[[KEY]]`, with `[[` adjacent, is a place to cut.
            let start = t.span().start();
            let double = lexer.peek().is_some_and(|n| n.kind() == K::LeftSquareBracket && n.span().start() == start + 1);
            let mut key_tokens = Vec::new();
            for n in lexer.by_ref() {
                if matches!(n.kind(), K::Newline | K::Eof) {
                    break;
                }
                key_tokens.push(n);
            }
            line_start = true;
            let key = match key_tokens.as_slice() {
                [open, atom, c1, c2] if double && open.kind() == K::LeftSquareBracket && atom.kind() == K::Atom => {
                    let adjacent =
                        c1.kind() == K::RightSquareBracket && c2.kind() == K::RightSquareBracket && c2.span().start() == c1.span().end();
                    let key = &text[atom.span().start()..atom.span().end()];
                    (adjacent && key.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-')).then_some(key)
                }
                _ => None,
            };
            let Some(key) = key else { continue };
            let last = parts.last_mut().expect("a first part");
            if start >= last.0 + PART_BYTES {
                parts.push((start, vec![key]));
            } else if !last.1.contains(&key) {
                last.1.push(key);
            }
            continue;
        }
        match kind {
            K::Newline => line_start = depth == 0,
            K::LeftSquareBracket | K::LeftCurlyBracket => {
                depth += 1;
                line_start = false;
            }
            K::RightSquareBracket | K::RightCurlyBracket => {
                depth = depth.saturating_sub(1);
                line_start = false;
            }
            _ => line_start = false,
        }
    }
    parts
}

/// Parses one TOML value written on the command line (`--set key=VALUE`).
pub fn parse_toml_value(source: &Arc<Source>, range: std::ops::Range<usize>) -> Result<Node> {
    let text = &source.text[range.clone()];
    let v = toml::de::DeValue::parse(text)
        .map_err(|e| SceneError::at(&Loc::new(source, range.clone()), format!("expected a TOML value: {}", e.message().trim())))?;
    let mut n = convert_value(v, source, 0)?;
    shift_locs(&mut n, range.start);
    Ok(n)
}

fn shift_locs(n: &mut Node, by: usize) {
    n.loc.start += by;
    n.loc.end += by;
    match &mut n.value {
        Value::Array(items) => items.iter_mut().for_each(|i| shift_locs(i, by)),
        Value::Table(t) => t.entries.iter_mut().for_each(|e| {
            e.key_loc.start += by;
            e.key_loc.end += by;
            shift_locs(&mut e.value, by);
        }),
        _ => {}
    }
}

/// Converts the parser's table of text starting at byte `at` of `src`.
fn convert_table(t: toml::de::DeTable<'_>, src: &Arc<Source>, at: usize) -> Result<Table> {
    let mut entries = Vec::with_capacity(t.len());
    for (k, v) in t {
        let span = k.span();
        let key_loc = Loc::new(src, span.start + at..span.end + at);
        entries.push(crate::param::value::Entry { key: k.into_inner().into_owned(), key_loc, value: convert_value(v, src, at)? });
    }
    Ok(Table { entries })
}

fn convert_value(v: toml::Spanned<toml::de::DeValue<'_>>, src: &Arc<Source>, at: usize) -> Result<Node> {
    use toml::de::DeValue;
    let span = v.span();
    let loc = Loc::new(src, span.start + at..span.end + at);
    let value = match v.into_inner() {
        DeValue::String(s) => Value::Str(s.into_owned()),
        DeValue::Boolean(b) => Value::Bool(b),
        DeValue::Integer(i) => {
            let digits = i.as_str().replace('_', "");
            let (neg, body) = match digits.strip_prefix('-') {
                Some(b) => (true, b),
                None => (false, digits.strip_prefix('+').unwrap_or(&digits)),
            };
            // The parser hands over the digits with or without a 0x/0o/0b prefix, and "0x" alone.
            let body = match body.get(..2) {
                Some("0x" | "0o" | "0b") if i.radix() != 10 => &body[2..],
                _ => body,
            };
            if body.is_empty() {
                return Err(SceneError::at(&loc, "expected digits after the 0x, 0o or 0b prefix"));
            }
            let mag = i128::from_str_radix(body, i.radix()).map_err(|_| SceneError::at(&loc, "integer out of range"))?;
            let val = if neg { -mag } else { mag };
            Value::Int(i64::try_from(val).map_err(|_| SceneError::at(&loc, "integer out of range for 64 bits"))?)
        }
        DeValue::Float(f) => {
            let s = f.as_str().replace('_', "");
            Value::Float(s.parse::<f64>().map_err(|_| SceneError::at(&loc, format!("malformed number {s}")))?)
        }
        DeValue::Datetime(_) => return Err(SceneError::at(&loc, "dates and times are not valid in a scene")),
        DeValue::Array(items) => Value::Array(items.into_iter().map(|i| convert_value(i, src, at)).collect::<Result<_>>()?),
        DeValue::Table(t) => Value::Table(convert_table(t, src, at)?),
    };
    Ok(Node { value, loc })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::param::error::Source;
    use crate::param::toml::parse_toml;

    fn parse(text: &str) -> Table {
        parse_toml(&Source::new("t.toml", text), "t".into()).unwrap_or_else(|e| panic!("{}\n---\n{text}", e.report())).root
    }

    fn round_trip(text: &str) {
        let first = parse(text);
        let written = table_to_toml(&first);
        let second = parse(&written);
        assert!(same_values(&first, &second), "round trip changed the table:\n{text}\n--- became ---\n{written}");
        assert_eq!(table_to_toml(&second), written, "writing is stable");
    }

    #[test]
    fn the_bundled_scenes_round_trip() {
        round_trip(include_str!("../../scenes/showcase.toml"));
        round_trip(include_str!("../../scenes/dozen.toml"));
    }

    #[test]
    fn integers_in_every_radix() {
        let t = parse("a = 0x40\nb = 0o60\nc = 0b101\nd = -1_000\ne = +7\nf = 0xDEAD_beef\n");
        let ints: Vec<i64> = ["a", "b", "c", "d", "e", "f"]
            .iter()
            .map(|k| match t.get(k).map(|n| &n.value) {
                Some(Value::Int(i)) => *i,
                other => panic!("{k}: {other:?}"),
            })
            .collect();
        assert_eq!(ints, [64, 48, 5, -1000, 7, 0xDEAD_BEEF]);
    }

    #[test]
    fn awkward_values_round_trip_exactly() {
        round_trip(
            r#"
            "key with spaces" = "quote \" backslash \\ tab \t newline \n bell \u0007 é"
            tiny = 5e-324
            huge = 1.7976931348623157e308
            third = 0.3333333333333333
            negzero = -0.0
            whole = 3.0
            int = -9223372036854775808
            nan = nan
            inf = -inf
            empty = []
            mixed = [1, 2.5, "x", [true, false], { a = 1 }]
            [empty_table]
            [a.b.c]
            d = { e = { f = [1.0] } }
            [[object]]
            type = "x"
            material = { kd = [0.5, 0.25, 1e-300] }
            [[object]]
            nested = [[1, 2], [3]]
            "#,
        );
    }

    /// Every location in `a` equals `b`'s (the values are compared by `same_values`).
    fn same_locations(a: &Table, b: &Table) -> bool {
        fn node(a: &Node, b: &Node) -> bool {
            (a.loc.start, a.loc.end) == (b.loc.start, b.loc.end)
                && match (&a.value, &b.value) {
                    (Value::Array(x), Value::Array(y)) => x.len() == y.len() && x.iter().zip(y).all(|(p, q)| node(p, q)),
                    (Value::Table(x), Value::Table(y)) => same_locations(x, y),
                    _ => true,
                }
        }
        a.entries.len() == b.entries.len()
            && a.entries.iter().zip(&b.entries).all(|(x, y)| {
                x.key == y.key && (x.key_loc.start, x.key_loc.end) == (y.key_loc.start, y.key_loc.end) && node(&x.value, &y.value)
            })
    }

    /// A scene of `n` objects and lights with every construct that could confuse the cut:
    /// sub-tables and arrays of an `[[object]]`, `[[...]]` in strings, comments and multi-line
    /// arrays, quoted and dotted keys, and `tail` at the end.
    fn long_scene(n: usize, tail: &str) -> String {
        let mut t = String::from("background = [0.1, 0.1, 0.1]\n[render]\nwidth = 8\n[camera]\nposition = [0, 0, -10]\n");
        for i in 0..n {
            t.push_str(&format!("[[object]] # [[light]]\ntype = \"sphere\"\ncenter = [{i}, 0,\n[[0]]]\nradius = 0.3\n"));
            match i % 7 {
                0 => t.push_str("[object.material]\nkd = 0.5\n[[object.extra]]\nx = 1\n"),
                1 => t.push_str("note = \"\"\"\n[[object]]\n\"\"\"\n"),
                2 => t.push_str("[[light]]\ntype = \"point\"\nposition = [0, 1, 2]\n"),
                3 => t.push_str("material = { kd = [0.1,\n 0.2, 0.3] }\n"),
                4 => t.push_str("[[ object ]]\ntype = \"plane\"\n[[\"object\"]]\ntype = \"plane\"\n"),
                5 => t.push_str("[[object.a.b]]\ny = 'x'\n"),
                _ => {}
            }
        }
        t.push_str(tail);
        t
    }

    /// A long scene parsed in parts gives the tree the whole parse gives, locations included.
    #[test]
    fn a_long_scene_in_parts_is_the_whole_parse() {
        let text = long_scene(40_000, "");
        assert!(text.len() > 3 * PART_BYTES);
        let src = Source::new("long.toml", text);
        assert!(cut(&src.text).len() >= 3, "the scene is cut");
        let parts = parse_in_parts(&src).expect("parsed in parts");
        let whole = parse_whole(&src).unwrap();
        assert!(same_values(&parts, &whole), "the parts differ from the whole");
        assert!(same_locations(&parts, &whole), "the locations differ");
        let Some(Value::Array(objects)) = parts.get("object").map(|n| &n.value) else { panic!("no objects") };
        assert_eq!(objects.len(), 40_000 + 2 * (0..40_000).filter(|i| i % 7 == 4).count());
    }

    /// Where the parts do not simply add up, the whole text is parsed: what TOML allows across
    /// parts (a table's sub-table long after it) is read, and what it refuses (a table or key
    /// defined twice, an inline array appended to, a syntax error far down) is the whole parse's
    /// error, at its place.
    #[test]
    fn a_long_scene_that_does_not_cut_cleanly_is_parsed_whole() {
        for (tail, ok) in [
            ("[render.more]\nx = 1\n", true),
            ("[render]\nheight = 8\n", false),
            ("[[object]]\ntype = \"sphere\"\n[camera]\nfov = 30\n", false),
            ("[[background]]\nx = 1\n", false),
            ("[[object]]\ntype = = 1\n", false),
            ("[[object]]\nradius = 99999999999999999999\n", false),
        ] {
            let src = Source::new("long.toml", long_scene(15_000, tail));
            assert!(src.text.len() > PART_BYTES);
            let got = parse_toml(&src, "long".into());
            let whole = parse_whole(&src);
            match (got, whole) {
                (Ok(a), Ok(b)) => {
                    assert!(ok, "{tail:?} parsed");
                    assert!(same_values(&a.root, &b) && same_locations(&a.root, &b), "{tail:?}");
                }
                (Err(a), Err(b)) => {
                    assert!(!ok, "{tail:?}: {}", a.report());
                    assert_eq!(a.report(), b.report(), "{tail:?}");
                    let line: usize = a.where_().and_then(|w| w.split(':').nth(1).and_then(|l| l.parse().ok())).unwrap_or(0);
                    assert!(line > src.text[..PART_BYTES].matches('\n').count(), "{tail:?}: not far down: {}", a.report());
                }
                (a, b) => panic!("{tail:?}: in parts {:?}, whole {:?}", a.map(|_| ()), b.map(|_| ())),
            }
        }
    }

    #[test]
    fn differences_are_noticed() {
        let a = parse("x = 1\ny = [1.0, 2.0]");
        assert!(same_values(&a, &parse("y = [1.0, 2.0]\nx = 1")), "key order does not matter");
        assert!(!same_values(&a, &parse("x = 1.0\ny = [1.0, 2.0]")), "int vs float");
        assert!(!same_values(&a, &parse("x = 1\ny = [2.0, 1.0]")), "list order matters");
        assert!(!same_values(&a, &parse("x = 1")), "missing key");
        assert!(!same_values(&parse("x = 0.0"), &parse("x = -0.0")), "sign of zero");
    }
}
