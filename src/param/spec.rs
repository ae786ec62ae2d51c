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
    /// A colour, or a texture: the name of one in `[textures]`, or an inline texture table.
    Texture,
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
            ParamKind::Texture => "color/texture",
            ParamKind::Material => "material",
            ParamKind::Path => "path",
            ParamKind::Vec3List => "[vec3]",
            ParamKind::Any => "table",
        }
    }
}

/// The default of a plugin parameter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ParamDefault {
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

impl fmt::Display for ParamDefault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParamDefault::Required => write!(f, "required"),
            ParamDefault::Optional => write!(f, "—"),
            ParamDefault::Float(v) => write!(f, "{v}"),
            ParamDefault::Int(v) => write!(f, "{v}"),
            ParamDefault::Bool(v) => write!(f, "{v}"),
            ParamDefault::Str(v) => write!(f, "\"{v}\""),
            ParamDefault::Vec3([x, y, z]) => write!(f, "[{x}, {y}, {z}]"),
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
    pub default: ParamDefault,
    /// What it means, its units and its valid range.
    pub doc: &'static str,
    /// What the rest of raylab may do with it (`--depth`, the limits, `sweep`, the live view).
    pub role: Role,
}

impl ParamSpec {
    /// A row of a parameter table (an ordinary setting).
    pub const fn new(name: &'static str, kind: ParamKind, default: ParamDefault, doc: &'static str) -> Self {
        ParamSpec { name, kind, default, doc, role: Role::Setting }
    }

    /// This row as the plugin's recursion depth (an integer), whose value in a reference render
    /// is `reference`.
    pub const fn depth(mut self, reference: Reference) -> Self {
        self.role = Role::Depth(reference);
        self
    }

    /// This row as a quality knob (speed traded for accuracy), whose value in a reference render
    /// is `reference`.
    pub const fn quality(mut self, reference: Reference) -> Self {
        self.role = Role::Quality(reference);
        self
    }
}

/// What a parameter is to the rest of raylab, so that every command works for any plugin by
/// role, not by parameter name.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Role {
    /// A setting of the scene or the model.
    Setting,
    /// The recursion depth: `--depth` sets it, `--max-depth-limit` bounds it, `sweep --vary depth=…`
    /// varies it. At most one per plugin.
    Depth(Reference),
    /// A quality knob: speed traded for accuracy (`sweep` varies it, the live view shows it).
    Quality(Reference),
}

impl Role {
    /// The value a reference render uses, for a depth or a quality knob.
    pub fn reference(&self) -> Option<Reference> {
        match *self {
            Role::Setting => None,
            Role::Depth(r) | Role::Quality(r) => Some(r),
        }
    }
}

/// A knob's value in a reference render (`sweep`'s `auto` reference: as accurate as is
/// affordable).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reference {
    /// The scene's value, or what was asked for.
    Keep,
    /// At least this, and at least every value swept (larger is more accurate).
    AtLeast(f64),
    /// At most this, and at most every value swept (smaller is more accurate).
    AtMost(f64),
    /// Exactly this value (e.g. an approximation switched off).
    Exactly(ParamDefault),
}
