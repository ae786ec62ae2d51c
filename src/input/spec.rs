//! Parameter tables: the typed rows (name, type, default, meaning) each plugin declares once.

use std::fmt;

/// The type of a plugin parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamKind {
    /// A finite number.
    Float,
    /// An integer.
    Int,
    /// `true` or `false`.
    Bool,
    /// A string.
    Str,
    /// Three finite numbers `[x, y, z]`.
    Vec3,
    /// Linear RGB `[r, g, b]` (each ≥ 0) or one number for grey.
    Color,
    /// The name of a material in `[materials]`, or an inline material table.
    Material,
    /// A path to a file, relative to the scene file.
    Path,
    /// A list of `[x, y, z]` points.
    Vec3List,
    /// Anything else: a table or list the plugin reads itself.
    Any,
}

impl ParamKind {
    /// The name shown in parameter tables.
    pub fn name(self) -> &'static str {
        match self {
            ParamKind::Float => "float",
            ParamKind::Int => "int",
            ParamKind::Bool => "bool",
            ParamKind::Str => "string",
            ParamKind::Vec3 => "vec3",
            ParamKind::Color => "color",
            ParamKind::Material => "material",
            ParamKind::Path => "path",
            ParamKind::Vec3List => "[vec3]",
            ParamKind::Any => "table",
        }
    }
}

/// The default of a plugin parameter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Default {
    /// The parameter must be given.
    Required,
    /// The parameter may be absent; the plugin handles absence (`*_opt` getters).
    Optional,
    /// A number.
    Float(f64),
    /// An integer.
    Int(i64),
    /// A boolean.
    Bool(bool),
    /// A string.
    Str(&'static str),
    /// A vector or colour.
    Vec3([f64; 3]),
}

impl fmt::Display for Default {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Default::Required => write!(f, "required"),
            Default::Optional => write!(f, "—"),
            Default::Float(v) => write!(f, "{v}"),
            Default::Int(v) => write!(f, "{v}"),
            Default::Bool(v) => write!(f, "{v}"),
            Default::Str(v) => write!(f, "\"{v}\""),
            Default::Vec3([x, y, z]) => write!(f, "[{x}, {y}, {z}]"),
        }
    }
}

/// One row of a plugin's parameter table: name, type, default and meaning (with units).
#[derive(Clone, Copy, Debug)]
pub struct ParamSpec {
    /// The key in the scene file.
    pub name: &'static str,
    /// Its type.
    pub kind: ParamKind,
    /// Its default.
    pub default: Default,
    /// What it means, its units and its valid range.
    pub doc: &'static str,
}

impl ParamSpec {
    /// A row of a parameter table.
    pub const fn new(name: &'static str, kind: ParamKind, default: Default, doc: &'static str) -> Self {
        ParamSpec { name, kind, default, doc }
    }
}

/// The `material` parameter every geometry takes.
pub const MATERIAL_PARAM: ParamSpec = ParamSpec::new(
    "material",
    ParamKind::Material,
    Default::Str("default"),
    "name of a material in [materials], or an inline table such as { kd = [0.8, 0.2, 0.2] }",
);
