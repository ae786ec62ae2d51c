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
    let doc = toml::de::DeTable::parse(&source.text).map_err(|e| {
        let span = e.span().unwrap_or(0..0);
        SceneError::at(&Loc::new(source, span), format!("TOML syntax error: {}", e.message().trim()))
    })?;
    let loc = Loc::new(source, 0..source.text.len());
    // Consumed as it is converted: each part of the parser's tree is freed once copied, so the
    // two trees never coexist whole (10⁶ inline objects would need both at once).
    let root = convert_table(doc.into_inner(), source)?;
    Ok(SceneDescription { name, root, loc })
}

/// Parses one TOML value written on the command line (`--set key=VALUE`).
pub fn parse_toml_value(source: &Arc<Source>, range: std::ops::Range<usize>) -> Result<Node> {
    let text = &source.text[range.clone()];
    let v = toml::de::DeValue::parse(text)
        .map_err(|e| SceneError::at(&Loc::new(source, range.clone()), format!("expected a TOML value: {}", e.message().trim())))?;
    let mut n = convert_value(v, source)?;
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

fn convert_table(t: toml::de::DeTable<'_>, src: &Arc<Source>) -> Result<Table> {
    let mut entries = Vec::with_capacity(t.len());
    for (k, v) in t {
        let key_loc = Loc::new(src, k.span());
        entries.push(crate::param::value::Entry { key: k.into_inner().into_owned(), key_loc, value: convert_value(v, src)? });
    }
    Ok(Table { entries })
}

fn convert_value(v: toml::Spanned<toml::de::DeValue<'_>>, src: &Arc<Source>) -> Result<Node> {
    use toml::de::DeValue;
    let loc = Loc::new(src, v.span());
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
        DeValue::Array(items) => Value::Array(items.into_iter().map(|i| convert_value(i, src)).collect::<Result<_>>()?),
        DeValue::Table(t) => Value::Table(convert_table(t, src)?),
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
