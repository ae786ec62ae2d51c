//! Plugin parameters: the located value tree every scene format produces, the typed parameter
//! table each plugin declares once ([`ParamSpec`]), and the checked accessor plugins read through
//! ([`Params`]).
//!
//! A plugin's parameter table is the single source of truth: the getters take their defaults from
//! it, `raylab plugins` prints it, and a key in the scene that the plugin never read is an error
//! naming its location (a typo never passes silently).

use crate::math::color::Color;
use crate::param::error::{Loc, Num, Result, SceneError, did_you_mean};
use crate::param::spec::{ParamDefault, ParamKind, ParamSpec};
use crate::param::value::{Node, Table, Value, color_of, vec3_of};
use glam::DVec3;
use std::fmt;

/// Read access to one plugin instance's parameters, checked against its parameter table.
///
/// Every getter marks its key as used and takes the default from the table; [`Params::finish`]
/// reports any key that was never read.
pub struct Params<'a> {
    what: String,
    specs: &'a [ParamSpec],
    table: &'a Table,
    loc: Loc,
    used: Vec<bool>,
    /// Keys the caller reads itself (an object's `type`, `name`, `transform`): never reported.
    reserved: &'static [&'static str],
}

/// What `build` makes of no parameters at all: every one at its default in `specs`. A plugin's
/// `Default` is this, so its defaults are written once, in its parameter table. Panics when a
/// parameter is required or a default fails `build`'s checks: a bug in the plugin's table, which
/// the first use of `Default` shows.
pub fn from_defaults<T>(what: &str, specs: &[ParamSpec], build: impl FnOnce(&mut Params) -> Result<T>) -> T {
    let empty = Table::default();
    let source = crate::param::error::Source::new(format!("the defaults of {what}"), "");
    let mut p = Params::new(what, specs, &empty, Loc::new(&source, 0..0));
    build(&mut p).unwrap_or_else(|e| panic!("{what}: its parameter table's defaults do not build: {e}"))
}

impl<'a> Params<'a> {
    /// Parameters of `what` (e.g. `sphere "ball"`) read from `table` (written at `loc`) against `specs`.
    pub fn new(what: impl Into<String>, specs: &'a [ParamSpec], table: &'a Table, loc: Loc) -> Self {
        Params { what: what.into(), specs, table, loc, used: vec![false; table.entries.len()], reserved: &[] }
    }

    /// These parameters, with `keys` left to the caller: neither read nor reported as unknown
    /// (so a plugin's table need not be copied without them).
    pub fn reserving(mut self, keys: &'static [&'static str]) -> Self {
        for (e, used) in self.table.entries.iter().zip(&mut self.used) {
            if keys.contains(&e.key.as_str()) {
                *used = true;
            }
        }
        self.reserved = keys;
        self
    }

    /// What these parameters belong to, for messages.
    pub fn what(&self) -> &str {
        &self.what
    }

    /// Where the plugin's table was written.
    pub fn loc(&self) -> &Loc {
        &self.loc
    }

    /// An error about the whole table.
    pub fn error(&self, message: impl Into<String>) -> SceneError {
        SceneError::at(&self.loc, message.into()).context(&self.what)
    }

    /// An error about parameter `name` (at its value when given, else at the table).
    pub fn error_at(&self, name: &str, message: impl fmt::Display) -> SceneError {
        let loc = self.table.get(name).map_or(&self.loc, |n| &n.loc);
        SceneError::at(loc, format!("parameter `{name}`: {message}")).context(&self.what)
    }

    /// True when the plugin's parameter table declares `name`.
    pub fn declares(&self, name: &str) -> bool {
        self.specs.iter().any(|s| s.name == name)
    }

    /// True when the scene gives `name` (does not mark it used).
    pub fn has(&self, name: &str) -> bool {
        self.table.get(name).is_some()
    }

    fn spec(&self, name: &str) -> Result<&'a ParamSpec> {
        self.specs
            .iter()
            .find(|s| s.name == name)
            .ok_or_else(|| self.error(format!("plugin bug: parameter `{name}` is read but not declared in its parameter table")))
    }

    /// The raw located value of `name`, marking it used. `None` when absent.
    pub fn node(&mut self, name: &str) -> Result<Option<&'a Node>> {
        self.spec(name)?;
        Ok(self.take(name))
    }

    fn take(&mut self, name: &str) -> Option<&'a Node> {
        let i = self.table.entries.iter().position(|e| e.key == name)?;
        self.used[i] = true;
        Some(&self.table.entries[i].value)
    }

    fn missing(&self, name: &str, kind: ParamKind) -> SceneError {
        let spec = self.specs.iter().find(|s| s.name == name);
        self.error(format!("missing required parameter `{name}` ({})", kind.name()))
            .with_help(spec.map_or(String::new(), |s| format!("`{name}`: {}", s.doc)))
    }

    fn wrong_type(&self, name: &str, node: &Node, expected: &str) -> SceneError {
        self.error_at(name, format_args!("expected {expected}, found {}", node.value.type_name()))
    }

    /// A finite number.
    pub fn float(&mut self, name: &str) -> Result<f64> {
        let spec = self.spec(name)?;
        match self.take(name) {
            Some(n) => self.as_float(name, n),
            None => match spec.default {
                ParamDefault::Float(v) => Ok(v),
                ParamDefault::Int(v) => Ok(v as f64),
                _ => Err(self.missing(name, ParamKind::Float)),
            },
        }
    }

    /// A finite number, or `None` when absent.
    pub fn float_opt(&mut self, name: &str) -> Result<Option<f64>> {
        self.spec(name)?;
        self.take(name).map(|n| self.as_float(name, n)).transpose()
    }

    /// A finite number in `range` (inclusive), with a message naming the range.
    pub fn float_in(&mut self, name: &str, range: std::ops::RangeInclusive<f64>) -> Result<f64> {
        let v = self.float(name)?;
        if range.contains(&v) {
            Ok(v)
        } else {
            Err(self.error_at(name, format_args!("{} is out of range; expected {} to {}", Num(v), Num(*range.start()), Num(*range.end()))))
        }
    }

    /// A finite number > 0.
    pub fn positive(&mut self, name: &str) -> Result<f64> {
        let v = self.float(name)?;
        if v > 0.0 { Ok(v) } else { Err(self.error_at(name, format_args!("expected a number > 0, found {}", Num(v)))) }
    }

    /// A finite number ≥ 0.
    pub fn non_negative(&mut self, name: &str) -> Result<f64> {
        let v = self.float(name)?;
        if v >= 0.0 { Ok(v) } else { Err(self.error_at(name, format_args!("expected a number ≥ 0, found {}", Num(v)))) }
    }

    fn as_float(&self, name: &str, n: &Node) -> Result<f64> {
        let v = match n.value {
            Value::Float(v) => v,
            Value::Int(v) => v as f64,
            _ => return Err(self.wrong_type(name, n, "a number")),
        };
        if v.is_finite() { Ok(v) } else { Err(self.error_at(name, format_args!("expected a finite number, found {v}"))) }
    }

    /// An integer in `range` (inclusive).
    pub fn int_in(&mut self, name: &str, range: std::ops::RangeInclusive<i64>) -> Result<i64> {
        let spec = self.spec(name)?;
        let v = match self.take(name) {
            Some(n) => match n.value {
                Value::Int(v) => v,
                _ => return Err(self.wrong_type(name, n, "an integer")),
            },
            None => match spec.default {
                ParamDefault::Int(v) => v,
                _ => return Err(self.missing(name, ParamKind::Int)),
            },
        };
        if range.contains(&v) {
            Ok(v)
        } else {
            let expected = if *range.end() == i64::MAX {
                format!("an integer ≥ {}", range.start())
            } else {
                format!("{} to {}", range.start(), range.end())
            };
            Err(self.error_at(name, format_args!("{v} is out of range; expected {expected}")))
        }
    }

    /// `true` or `false`.
    pub fn bool(&mut self, name: &str) -> Result<bool> {
        let spec = self.spec(name)?;
        match self.take(name) {
            Some(n) => match n.value {
                Value::Bool(b) => Ok(b),
                _ => Err(self.wrong_type(name, n, "true or false")),
            },
            None => match spec.default {
                ParamDefault::Bool(b) => Ok(b),
                _ => Err(self.missing(name, ParamKind::Bool)),
            },
        }
    }

    /// A string.
    pub fn string(&mut self, name: &str) -> Result<String> {
        let spec = self.spec(name)?;
        match self.take(name) {
            Some(n) => match &n.value {
                Value::Str(s) => Ok(s.clone()),
                _ => Err(self.wrong_type(name, n, "a string")),
            },
            None => match spec.default {
                ParamDefault::Str(s) => Ok(s.to_string()),
                _ => Err(self.missing(name, ParamKind::Str)),
            },
        }
    }

    /// One of `choices` (a string).
    pub fn choice(&mut self, name: &str, choices: &[&str]) -> Result<String> {
        let s = self.string(name)?;
        if choices.contains(&s.as_str()) {
            Ok(s)
        } else {
            let mut e = self.error_at(name, format_args!("unknown value \"{s}\"; expected one of: {}", choices.join(", ")));
            if let Some(m) = did_you_mean(&s, choices.iter().copied()) {
                e = e.with_help(format!("did you mean \"{m}\"?"));
            }
            Err(e)
        }
    }

    /// Three finite numbers.
    pub fn vec3(&mut self, name: &str) -> Result<DVec3> {
        let spec = self.spec(name)?;
        match self.take(name) {
            Some(n) => self.as_vec3(name, n),
            None => match spec.default {
                ParamDefault::Vec3(v) => Ok(DVec3::from(v)),
                _ => Err(self.missing(name, ParamKind::Vec3)),
            },
        }
    }

    /// Three finite numbers, or `None` when absent.
    pub fn vec3_opt(&mut self, name: &str) -> Result<Option<DVec3>> {
        self.spec(name)?;
        self.take(name).map(|n| self.as_vec3(name, n)).transpose()
    }

    /// A non-zero vector, normalised to unit length.
    pub fn direction(&mut self, name: &str) -> Result<DVec3> {
        let v = self.vec3(name)?;
        self.normalize(name, v)
    }

    /// A non-zero vector normalised to unit length, or `None` when absent.
    pub fn direction_opt(&mut self, name: &str) -> Result<Option<DVec3>> {
        self.vec3_opt(name)?.map(|v| self.normalize(name, v)).transpose()
    }

    fn normalize(&self, name: &str, v: DVec3) -> Result<DVec3> {
        let n = v.try_normalize().filter(|n| n.is_finite());
        n.ok_or_else(|| self.error_at(name, format_args!("expected a non-zero direction, found {v}")))
    }

    fn as_vec3(&self, name: &str, n: &Node) -> Result<DVec3> {
        vec3_of(n).map_err(|m| self.error_at(name, m))
    }

    /// A colour: `[r, g, b]` or one number for grey, each channel finite and ≥ 0.
    pub fn color(&mut self, name: &str) -> Result<Color> {
        let spec = self.spec(name)?;
        match self.take(name) {
            Some(n) => color_of(n).map_err(|m| self.error_at(name, m)),
            None => match spec.default {
                ParamDefault::Vec3(v) => Ok(DVec3::from(v)),
                ParamDefault::Float(v) => Ok(DVec3::splat(v)),
                _ => Err(self.missing(name, ParamKind::Color)),
            },
        }
    }

    /// A list of points `[[x, y, z], ...]`.
    pub fn vec3_list(&mut self, name: &str) -> Result<Vec<DVec3>> {
        self.spec(name)?;
        let Some(n) = self.take(name) else { return Err(self.missing(name, ParamKind::Vec3List)) };
        let Value::Array(items) = &n.value else { return Err(self.wrong_type(name, n, "a list of [x, y, z] points")) };
        items
            .iter()
            .map(|it| vec3_of(it).map_err(|m| SceneError::at(&it.loc, format!("parameter `{name}`: {m}")).context(&self.what)))
            .collect()
    }

    /// Reports keys the plugin never read (unknown or not applicable), with a suggestion.
    pub fn finish(self) -> Result<()> {
        self.check_unknown()?;
        for (e, used) in self.table.entries.iter().zip(&self.used) {
            if !*used {
                return Err(SceneError::at(&e.key_loc, format!("parameter `{}` does not apply here", e.key))
                    .with_help("it is valid for this type, but not in combination with the other parameters given")
                    .context(&self.what));
            }
        }
        Ok(())
    }

    /// Reports the first key that is not in the parameter table (a typo), with a suggestion. Call it
    /// before an error that a typo may explain ("missing `look_at`" when `lookat` was written).
    pub fn check_unknown(&self) -> Result<()> {
        let names: Vec<&str> = self.specs.iter().map(|s| s.name).collect();
        let Some(e) = self.table.entries.iter().find(|e| !names.contains(&e.key.as_str()) && !self.reserved.contains(&e.key.as_str()))
        else {
            return Ok(());
        };
        let err = SceneError::at(&e.key_loc, format!("unknown parameter `{}`", e.key)).with_help(
            match did_you_mean(&e.key, names.iter().copied()) {
                Some(m) => format!("did you mean `{m}`?  (parameters: {})", names.join(", ")),
                None if names.is_empty() => "this type takes no parameters".into(),
                None => format!("parameters: {}", names.join(", ")),
            },
        );
        Err(err.context(&self.what))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::param::error::Source;

    fn table(src: &std::sync::Arc<Source>, kv: &[(&str, Value)]) -> Table {
        let mut t = Table::default();
        for (k, v) in kv {
            t.set(k, Loc::new(src, 0..1), Node { value: v.clone(), loc: Loc::new(src, 0..1) });
        }
        t
    }

    const SPECS: &[ParamSpec] = &[
        ParamSpec::new("radius", ParamKind::Float, ParamDefault::Float(1.0), "radius"),
        ParamSpec::new("center", ParamKind::Vec3, ParamDefault::Required, "centre"),
    ];

    #[test]
    fn defaults_come_from_the_table_and_unknown_keys_fail() {
        let src = Source::new("t", "x");
        let t = table(&src, &[("center", Value::Array(vec![])), ("radus", Value::Float(2.0))]);
        let mut p = Params::new("sphere", SPECS, &t, Loc::new(&src, 0..1));
        assert_eq!(p.float("radius").unwrap(), 1.0);
        let e = p.vec3("center").unwrap_err();
        assert!(e.message.contains("expected 3 numbers"), "{e}");
        let e = p.finish().unwrap_err();
        assert!(e.message.contains("unknown parameter `radus`"), "{e}");
        assert!(e.help.unwrap().contains("did you mean `radius`"));
    }

    #[test]
    fn missing_required_and_non_finite_are_errors() {
        let src = Source::new("t", "x");
        let t = table(&src, &[("radius", Value::Float(f64::NAN))]);
        let mut p = Params::new("sphere", SPECS, &t, Loc::new(&src, 0..1));
        assert!(p.float("radius").unwrap_err().message.contains("finite"));
        assert!(p.vec3("center").unwrap_err().message.contains("missing required parameter `center`"));
        assert!(p.float("nope").unwrap_err().message.contains("plugin bug"));
    }

    /// Reserved keys are left to the caller; every other key is still checked.
    #[test]
    fn reserved_keys_are_neither_unknown_nor_unused() {
        let src = Source::new("t", "x");
        let t = table(&src, &[("type", Value::Str("sphere".into())), ("radius", Value::Float(2.0))]);
        let mut p = Params::new("sphere", SPECS, &t, Loc::new(&src, 0..1)).reserving(&["type"]);
        assert_eq!(p.float("radius").unwrap(), 2.0);
        p.finish().unwrap();
        let t = table(&src, &[("type", Value::Str("sphere".into())), ("radus", Value::Float(2.0))]);
        let p = Params::new("sphere", SPECS, &t, Loc::new(&src, 0..1)).reserving(&["type"]);
        assert!(p.finish().unwrap_err().message.contains("unknown parameter `radus`"));
    }
}
