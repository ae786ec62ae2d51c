//! The located value tree every scene format produces (TOML, the report's XML, command-line
//! overrides): values with where they were written.

use crate::math::color::Color;
use crate::param::error::Loc;
use glam::DVec3;

/// A value from a scene file, with where it came from.
#[derive(Clone, Debug)]
pub struct Node {
    /// The value.
    pub value: Value,
    /// Where it was written.
    pub loc: Loc,
}

impl Node {
    /// A value given outside any scene file (a command-line flag, a control of the live view),
    /// located in a one-line source named `origin` that holds the value's text, so errors name it.
    pub fn given(origin: &str, value: Value) -> Node {
        let text = match &value {
            Value::Str(s) => s.clone(),
            Value::Int(i) => i.to_string(),
            Value::Float(f) => crate::param::error::Num(*f).to_string(),
            Value::Bool(b) => b.to_string(),
            other => other.type_name().to_string(),
        };
        let src = crate::param::error::Source::new(origin, text);
        let loc = Loc::new(&src, 0..src.text.len());
        Node { value, loc }
    }
}

/// A scene value: the data model shared by every scene format (TOML, the report's XML, overrides
/// from the command line).
#[derive(Clone, Debug)]
pub enum Value {
    /// `true` / `false`.
    Bool(bool),
    /// An integer.
    Int(i64),
    /// A floating-point number (may be non-finite: validation rejects it where it matters).
    Float(f64),
    /// A string.
    Str(String),
    /// A list.
    Array(Vec<Node>),
    /// A table of named values.
    Table(Table),
}

impl Value {
    /// What the value is, for "expected X, found Y" messages.
    pub fn type_name(&self) -> &'static str {
        match self {
            Value::Bool(_) => "a boolean",
            Value::Int(_) => "an integer",
            Value::Float(_) => "a number",
            Value::Str(_) => "a string",
            Value::Array(_) => "a list",
            Value::Table(_) => "a table",
        }
    }
}

/// A key of a [`Table`], with where it was written.
#[derive(Clone, Debug)]
pub struct Entry {
    /// The key.
    pub key: String,
    /// Where the key was written.
    pub key_loc: Loc,
    /// The value.
    pub value: Node,
}

/// An ordered table of named values (order as written).
#[derive(Clone, Debug, Default)]
pub struct Table {
    /// Entries in the order they were written. Keys are unique.
    pub entries: Vec<Entry>,
}

impl Table {
    /// The entry for `key`.
    pub fn get(&self, key: &str) -> Option<&Node> {
        self.entries.iter().find(|e| e.key == key).map(|e| &e.value)
    }

    /// The entry for `key`, with its key location.
    pub fn entry(&self, key: &str) -> Option<&Entry> {
        self.entries.iter().find(|e| e.key == key)
    }

    /// Sets `key`, replacing an existing entry in place or appending a new one.
    pub fn set(&mut self, key: &str, key_loc: Loc, value: Node) {
        match self.entries.iter_mut().find(|e| e.key == key) {
            Some(e) => e.value = value,
            None => self.entries.push(Entry { key: key.to_string(), key_loc, value }),
        }
    }

    /// Removes and returns `key`.
    pub fn remove(&mut self, key: &str) -> Option<Entry> {
        let i = self.entries.iter().position(|e| e.key == key)?;
        Some(self.entries.remove(i))
    }
}

/// Reads `[x, y, z]` (three finite numbers) from a node.
pub fn vec3_of(n: &Node) -> std::result::Result<DVec3, String> {
    let Value::Array(items) = &n.value else {
        return Err(format!("expected [x, y, z], found {}", n.value.type_name()));
    };
    if items.len() != 3 {
        return Err(format!("expected 3 numbers [x, y, z], found a list of {}", items.len()));
    }
    let mut v = [0.0; 3];
    for (slot, it) in v.iter_mut().zip(items) {
        *slot = match it.value {
            Value::Float(f) => f,
            Value::Int(i) => i as f64,
            _ => return Err(format!("expected numbers in [x, y, z], found {}", it.value.type_name())),
        };
        if !slot.is_finite() {
            return Err(format!("expected finite numbers, found {slot}"));
        }
    }
    Ok(DVec3::from(v))
}

/// Reads a colour (`[r, g, b]` or one number), each channel finite and ≥ 0.
pub fn color_of(n: &Node) -> std::result::Result<Color, String> {
    let c = match n.value {
        Value::Float(f) => DVec3::splat(f),
        Value::Int(i) => DVec3::splat(i as f64),
        Value::Array(_) => vec3_of(n).map_err(|m| m.replace("[x, y, z]", "[r, g, b]"))?,
        _ => return Err(format!("expected a colour [r, g, b] or a number, found {}", n.value.type_name())),
    };
    if !c.is_finite() {
        return Err(format!("expected finite colour channels, found {c}"));
    }
    if c.min_element() < 0.0 {
        return Err(format!("colour channels must be ≥ 0, found {c}"));
    }
    Ok(c)
}
