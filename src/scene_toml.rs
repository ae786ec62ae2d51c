//! Writing a scene description back as raylab's TOML scene format (`raylab convert`).
//!
//! The writer is exact: reading its output gives the same [`Table`] (same keys, same value types,
//! bit-identical numbers), so a scene converted from another format renders the same image as the
//! original. Layout: the root's plain values first, then `[table]` sections (nested tables as
//! `[a.b]`), then `[[array]]` tables, whose nested tables are written inline.

use crate::load::SceneDescription;
use crate::params::{Table, Value};
use std::fmt::Write;

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Source;
    use crate::load::parse_toml;

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
        round_trip(include_str!("../scenes/showcase.toml"));
        round_trip(include_str!("../scenes/dozen.toml"));
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
