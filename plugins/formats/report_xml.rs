//! `.xml`: the report's XML scene style, read into raylab's scene description.
//!
//! The report builds its Scene, Camera, AmbientLight and geometries from XML attribute maps
//! (`Map<String, String> attributes`), and many scenes exist in that style. It has varied over the
//! years; all of these are read:
//!
//! - the older one: `<scene background-color="r g b" screen-width=".." screen-height=".."
//!   screen-dist="..">` with `<camera P0=".." vTo=".." vUp=".."/>`;
//! - a later one: `<scene background-color=".." screen-distance="..">` with a separate
//!   `<image screen-width=".." screen-height=".." Nx=".." Ny=".."/>` and `Vto`/`Vup`;
//! - files with only `background-color`, `<ambient-light>` and `<geometries>`: no camera, no image.
//!
//! Every element and attribute is in the tables below ([`ELEMENTS`], [`MATERIAL_ATTRS`]), which
//! drive the reader, its error messages and the reference in `docs/report-xml.md`. Choices where
//! the style is ambiguous (all documented there):
//!
//! - Element and attribute names are matched without regard to case (`vTo`, `Vto` and `vto` are
//!   one attribute; giving two spellings of one attribute is an error).
//! - Colours are `"r g b"` in 0–255 and become linear values `/255`; the scene is written with
//!   `encoding = "linear"` (the report wrote clamped values straight; its scenes look right only
//!   so). Coefficients (`kd`, `ks`, …) are plain numbers, one (grey) or three.
//! - Without `Nx`/`Ny` the image is [`DEFAULT_SIDE`] pixels on its longer side with the screen's
//!   aspect ratio; without a screen size the screen takes the image's aspect ratio, `DEFAULT_SIDE`
//!   scene units on its longer side. Without either, both are `DEFAULT_SIDE` square.
//! - Without `<camera>`, the camera's attribute defaults apply: the eye at the origin looking
//!   down −z with +y up, where the later course's tests put it. `--camera KEY=VALUE` overrides any
//!   camera parameter from the command line.
//! - Objects use the report's default material ([`raylab::Material::report_default`]: kd = ks = 1,
//!   shininess 1, no reflection or transmission); its attributes may be set on each geometry.
//! - An `<ambient-light>` without `Ka` has the report's fixed 0.1 in the report's own style, and
//!   1 in the later one (the course from 2020 on: files with `<image>`, with `Vto`/`Vup`, or with
//!   neither a camera nor a screen size), whose test scenes show their shapes in the ambient
//!   colour ([`is_later_dialect`]).
//!
//! Every value keeps its position in the XML text, so an error anywhere (syntax, an unknown
//! element or attribute, a bad number, or a value a plugin rejects) names the line and column.

use raylab::LoadContext;
use raylab::load::registry::SceneFormat;
use raylab::param::description::SceneDescription;
use raylab::param::error::{Loc, Result, SceneError, Source, did_you_mean};
use raylab::param::value::{Entry, Node, Table, Value};
use roxmltree::{Attribute, Node as XmlNode};
use std::ops::Range;
use std::path::Path;
use std::sync::Arc;

/// Pixels (and screen units) on the longer side of the image when the file gives no size.
pub const DEFAULT_SIDE: u32 = 500;

/// How an attribute's text is read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AttrKind {
    /// `"r g b"`, each 0–255; becomes linear RGB `/255`.
    Color,
    /// `"x y z"`: three numbers.
    Vector,
    /// One number.
    Number,
    /// A whole number ≥ 1.
    Count,
    /// One number (grey) or three (`"r g b"`), as is (not 0–255).
    Coefficient,
    /// `"x y z x y z …"`: points, three numbers each.
    Points,
    /// Text.
    Text,
}

impl AttrKind {
    /// The form shown in the reference.
    pub fn form(self) -> &'static str {
        match self {
            AttrKind::Color => "r g b (0–255)",
            AttrKind::Vector => "x y z",
            AttrKind::Number => "number",
            AttrKind::Count => "whole number ≥ 1",
            AttrKind::Coefficient => "number, or r g b",
            AttrKind::Points => "x y z x y z …",
            AttrKind::Text => "text",
        }
    }
}

/// What happens when an attribute is absent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AttrDefault {
    /// It must be given.
    Required,
    /// This value (in the attribute's own syntax) is used.
    Value(&'static str),
    /// It is left out of the scene, so the raylab plugin's default applies (`raylab plugins`).
    Plugin,
    /// Computed from other attributes, as its description says.
    Computed,
}

/// One attribute of an element.
#[derive(Clone, Copy, Debug)]
pub struct AttrSpec {
    /// Accepted spellings (matched without regard to case); the first is the canonical one.
    pub names: &'static [&'static str],
    /// The raylab parameter it becomes (empty when the reader handles it specially).
    pub key: &'static str,
    /// Its syntax.
    pub kind: AttrKind,
    /// Its default.
    pub default: AttrDefault,
    /// What it means, with units.
    pub doc: &'static str,
}

const fn attr(names: &'static [&'static str], key: &'static str, kind: AttrKind, default: AttrDefault, doc: &'static str) -> AttrSpec {
    AttrSpec { names, key, kind, default, doc }
}

/// What an element becomes in raylab's scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Becomes {
    /// An `[[object]]` of this type.
    Object(&'static str),
    /// A `[[light]]` of this type.
    Light(&'static str),
    /// Something the reader assembles itself (scene, image, camera, containers).
    Structure,
}

/// One element of the style.
#[derive(Clone, Copy, Debug)]
pub struct ElementSpec {
    /// Its name (matched without regard to case).
    pub name: &'static str,
    /// Where it may appear.
    pub parents: &'static [&'static str],
    /// What it becomes.
    pub becomes: Becomes,
    /// Its attributes.
    pub attrs: &'static [AttrSpec],
    /// True for geometries: they also take [`MATERIAL_ATTRS`].
    pub material: bool,
    /// What it is.
    pub doc: &'static str,
}

use AttrDefault::{Computed, Plugin, Required, Value as Dv};
use AttrKind::{Coefficient, Color, Count, Number, Points, Text, Vector};

const NAME: AttrSpec = attr(&["name"], "name", Text, Plugin, "name shown in errors and `raylab trace`");
const COLOR: AttrSpec = attr(&["color"], "color", Color, Required, "intensity I₀");
const KC: AttrSpec = attr(&["kc"], "kc", Number, Plugin, "constant attenuation (default 1)");
const KL: AttrSpec = attr(&["kl"], "kl", Number, Plugin, "linear attenuation, per scene unit (default 0)");
const KQ: AttrSpec = attr(&["kq"], "kq", Number, Plugin, "quadratic attenuation, per scene unit² (default 0)");
const SCREEN_W: &[&str] = &["screen-width"];
const SCREEN_H: &[&str] = &["screen-height"];

/// The material attributes every geometry takes: the report's Material (kd, ks, kr, kt, n), its
/// Geometry's shininess and emission, stage D's blurring, and raylab's ka. Defaults are the
/// report's ([`raylab::Material::report_default`]).
pub const MATERIAL_ATTRS: &[AttrSpec] = &[
    attr(&["emission"], "emission", Color, Dv("0 0 0"), "light the surface emits (the report's object colour)"),
    attr(&["kd"], "kd", Coefficient, Dv("1"), "diffuse coefficient"),
    attr(&["ks"], "ks", Coefficient, Dv("1"), "specular coefficient"),
    attr(&["kr"], "kr", Coefficient, Dv("0"), "mirror reflection coefficient"),
    attr(&["kt"], "kt", Coefficient, Dv("0"), "transmission coefficient"),
    attr(&["shininess", "nShininess"], "shininess", Number, Dv("1"), "Phong exponent"),
    attr(&["n"], "ior", Number, Dv("1"), "index of refraction of a closed solid's inside"),
    attr(&["blur", "blurring"], "blur", Number, Dv("0"), "glossiness (stage D): jitter-disc radius at unit distance, 0..1"),
    attr(&["ka"], "ka", Coefficient, Dv("1"), "response to ambient light (raylab; the report adds ambient unfiltered)"),
];

/// Every element of the style.
pub const ELEMENTS: &[ElementSpec] = &[
    ElementSpec {
        name: "scene",
        parents: &[],
        becomes: Becomes::Structure,
        attrs: &[
            attr(&["background-color"], "background", Color, Dv("0 0 0"), "colour of rays that hit nothing"),
            attr(SCREEN_W, "", Number, Computed, "screen width, scene units (older style; or on `<image>`)"),
            attr(SCREEN_H, "", Number, Computed, "screen height, scene units (older style; or on `<image>`)"),
            attr(&["screen-dist", "screen-distance"], "screen_distance", Number, Dv("100"), "eye-to-screen distance, scene units"),
            attr(&["name"], "name", Text, Plugin, "scene name (default: the file name)"),
        ],
        material: false,
        doc: "The root. Holds the camera, image, lights and geometries in any order.",
    },
    ElementSpec {
        name: "image",
        parents: &["scene"],
        becomes: Becomes::Structure,
        attrs: &[
            attr(SCREEN_W, "", Number, Computed, "screen width, scene units"),
            attr(SCREEN_H, "", Number, Computed, "screen height, scene units"),
            attr(&["Nx"], "width", Count, Computed, "image width, pixels"),
            attr(&["Ny"], "height", Count, Computed, "image height, pixels"),
        ],
        material: false,
        doc: "Screen and image size (later style). A missing pair: see \"Image size\" above.",
    },
    ElementSpec {
        name: "camera",
        parents: &["scene"],
        becomes: Becomes::Structure,
        attrs: &[
            attr(&["P0"], "position", Vector, Dv("0 0 0"), "eye point"),
            attr(&["vTo"], "to", Vector, Dv("0 0 -1"), "viewing direction"),
            attr(&["vUp"], "up", Vector, Dv("0 1 0"), "up direction (vRight = vTo × vUp)"),
        ],
        material: false,
        doc: "The report's camera. At most one; without it the defaults apply (`--camera KEY=VALUE` overrides any of them).",
    },
    ElementSpec {
        name: "geometries",
        parents: &["scene"],
        becomes: Becomes::Structure,
        attrs: &[],
        material: false,
        doc: "Holds the geometries, in order.",
    },
    ElementSpec {
        name: "lights",
        parents: &["scene"],
        becomes: Becomes::Structure,
        attrs: &[],
        material: false,
        doc: "Optionally holds the lights (they may also stand directly in `<scene>`).",
    },
    ElementSpec {
        name: "ambient-light",
        parents: &["scene", "lights"],
        becomes: Becomes::Light("ambient"),
        attrs: &[
            attr(&["color"], "color", Color, Required, "colour"),
            attr(
                &["Ka"],
                "ka",
                Number,
                Computed,
                "ambient factor: the report's fixed 0.1 in its own (older) style; 1 in the later style (see \"Two dialects\" above)",
            ),
            NAME,
        ],
        material: false,
        doc: "The report's AmbientLight: colour × Ka everywhere.",
    },
    ElementSpec {
        name: "directional-light",
        parents: &["scene", "lights"],
        becomes: Becomes::Light("directional"),
        attrs: &[COLOR, attr(&["direction"], "direction", Vector, Required, "direction the light travels"), NAME],
        material: false,
        doc: "The report's DirectionalLight (a sun).",
    },
    ElementSpec {
        name: "point-light",
        parents: &["scene", "lights"],
        becomes: Becomes::Light("point"),
        attrs: &[COLOR, attr(&["position"], "position", Vector, Required, "where the light is"), KC, KL, KQ, NAME],
        material: false,
        doc: "The report's PointLight: I₀ / (kc + kl·d + kq·d²).",
    },
    ElementSpec {
        name: "spot-light",
        parents: &["scene", "lights"],
        becomes: Becomes::Light("spot"),
        attrs: &[
            COLOR,
            attr(&["position"], "position", Vector, Required, "where the light is"),
            attr(&["direction"], "direction", Vector, Required, "axis of the spot (D)"),
            KC,
            KL,
            KQ,
            attr(&["exponent"], "exponent", Number, Plugin, "narrowing exponent (raylab; default 1, the report's spot)"),
            attr(&["cone-angle"], "cone_angle", Number, Plugin, "cone half-angle, degrees (raylab; default 90)"),
            NAME,
        ],
        material: false,
        doc: "The report's SpotLight: a point light × max(0, D·L).",
    },
    ElementSpec {
        name: "sphere",
        parents: &["geometries"],
        becomes: Becomes::Object("sphere"),
        attrs: &[
            attr(&["center"], "center", Vector, Required, "centre"),
            attr(&["radius"], "radius", Number, Required, "radius, > 0"),
            NAME,
        ],
        material: true,
        doc: "The report's Sphere.",
    },
    ElementSpec {
        name: "triangle",
        parents: &["geometries"],
        becomes: Becomes::Object("triangle"),
        attrs: &[
            attr(&["p0"], "p0", Vector, Required, "first vertex"),
            attr(&["p1"], "p1", Vector, Required, "second vertex"),
            attr(&["p2"], "p2", Vector, Required, "third vertex"),
            NAME,
        ],
        material: true,
        doc: "The report's Triangle (a ray exactly through an edge misses, as in the report).",
    },
    ElementSpec {
        name: "plane",
        parents: &["geometries"],
        becomes: Becomes::Object("plane"),
        attrs: &[
            attr(&["point"], "point", Vector, Dv("0 0 0"), "a point on the plane (the report's Q)"),
            attr(&["normal"], "normal", Vector, Dv("0 0 1"), "normal"),
            NAME,
        ],
        material: true,
        doc: "The report's Plane (defaults as its no-argument constructor).",
    },
    ElementSpec {
        name: "quadrangle",
        parents: &["geometries"],
        becomes: Becomes::Object("quadrangle"),
        attrs: &[
            attr(&["p0"], "p0", Vector, Required, "first corner"),
            attr(&["p1"], "p1", Vector, Required, "second corner"),
            attr(&["p2"], "p2", Vector, Required, "third corner (opposite p0)"),
            attr(&["p3"], "p3", Vector, Required, "fourth corner"),
            NAME,
        ],
        material: true,
        doc: "The report's Quadrangle: flat and convex, corners in order around the outline.",
    },
    ElementSpec {
        name: "polygon",
        parents: &["geometries"],
        becomes: Becomes::Object("polygon"),
        attrs: &[attr(&["vertices"], "vertices", Points, Required, "the corners in order, at least 3, coplanar, convex"), NAME],
        material: true,
        doc: "A flat convex polygon (raylab).",
    },
    ElementSpec {
        name: "hemisphere",
        parents: &["geometries"],
        becomes: Becomes::Object("hemisphere"),
        attrs: &[
            attr(&["center"], "center", Vector, Required, "centre of the full sphere"),
            attr(&["radius"], "radius", Number, Required, "radius, > 0"),
            attr(&["open"], "open", Vector, Plugin, "direction toward the open side (the report's constructor vector; default 0 1 0)"),
            NAME,
        ],
        material: true,
        doc: "The report's Hemisphere (bowl), stage D.",
    },
    ElementSpec {
        name: "cylinder",
        parents: &["geometries"],
        becomes: Becomes::Object("cylinder"),
        attrs: &[
            attr(&["axis-point"], "base", Vector, Required, "centre of the bottom cap"),
            attr(&["axis-direction"], "axis", Vector, Required, "direction from the bottom cap to the top cap"),
            attr(&["radius"], "radius", Number, Required, "radius, > 0"),
            attr(&["height"], "height", Number, Required, "distance between the caps, > 0"),
            NAME,
        ],
        material: true,
        doc: "A finite cylinder with caps (the report's Cylinder fields, plus a height).",
    },
    ElementSpec {
        name: "tube",
        parents: &["geometries"],
        becomes: Becomes::Object("tube"),
        attrs: &[
            attr(&["axis-point"], "point", Vector, Required, "a point on the axis"),
            attr(&["axis-direction"], "axis", Vector, Required, "axis direction"),
            attr(&["radius"], "radius", Number, Required, "radius, > 0"),
            NAME,
        ],
        material: true,
        doc: "An infinite open cylinder: the report's Cylinder (axis point, axis direction, radius).",
    },
];

/// The format, ready for [`raylab::Registry::add_format`].
pub fn format() -> SceneFormat {
    SceneFormat {
        extensions: &["xml"],
        summary: "the report's XML scene style (`<scene>`, `<camera>`, `<ambient-light>`, `<geometries>`, …); see docs/report-xml.md",
        read: Arc::new(read),
    }
}

/// Reads the bytes of an XML scene file at `path`.
pub fn read(path: &Path, bytes: &[u8], _: &LoadContext) -> Result<SceneDescription> {
    let text = std::str::from_utf8(bytes)
        .map_err(|e| SceneError::in_file(path, None, format!("scene file is not UTF-8 text (byte {})", e.valid_up_to())))?;
    let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("scene").to_string();
    parse(&Source::new(path.display().to_string(), text), name)
}

/// Parses an XML scene; `name` is the scene name unless the file sets one.
pub fn parse(source: &Arc<Source>, name: String) -> Result<SceneDescription> {
    let doc = roxmltree::Document::parse(&source.text).map_err(|e| {
        let pos = e.pos();
        let at = byte_offset(&source.text, pos.row as usize, pos.col as usize);
        SceneError::at(&Loc::new(source, at..at), format!("XML syntax error: {e}"))
    })?;
    let r = Reader { src: source };
    let root = doc.root_element();
    if !root.tag_name().name().eq_ignore_ascii_case("scene") {
        return Err(SceneError::at(&r.tag_loc(root), format!("expected <scene> as the root element, found <{}>", root.tag_name().name())));
    }
    let scene = r.read_scene(root)?;
    Ok(SceneDescription { name, root: scene, loc: Loc::new(source, 0..source.text.len()) })
}

/// The reference of the style as Markdown: every element and attribute, from the tables above.
pub fn reference() -> String {
    let mut out = String::new();
    let default = |d: AttrDefault| match d {
        Required => "required".to_string(),
        Dv(v) => format!("`{v}`"),
        Plugin => "raylab's".to_string(),
        Computed => "computed".to_string(),
    };
    let table = |out: &mut String, attrs: &[AttrSpec]| {
        out.push_str("| attribute | value | default | raylab | meaning |\n|---|---|---|---|---|\n");
        for a in attrs {
            let names: Vec<String> = a.names.iter().map(|n| format!("`{n}`")).collect();
            let key = if a.key.is_empty() { "—".to_string() } else { format!("`{}`", a.key) };
            out.push_str(&format!("| {} | {} | {} | {key} | {} |\n", names.join(", "), a.kind.form(), default(a.default), a.doc));
        }
    };
    for e in ELEMENTS {
        out.push_str(&format!("### `<{}>`\n\n{}", e.name, e.doc));
        if !e.parents.is_empty() {
            let p: Vec<String> = e.parents.iter().map(|p| format!("`<{p}>`")).collect();
            out.push_str(&format!(" In {}.", p.join(" or ")));
        }
        match e.becomes {
            Becomes::Object(t) => out.push_str(&format!(" Becomes `[[object]] type = \"{t}\"`.")),
            Becomes::Light(t) => out.push_str(&format!(" Becomes `[[light]] type = \"{t}\"`.")),
            Becomes::Structure => {}
        }
        out.push_str("\n\n");
        if e.attrs.is_empty() {
            out.push_str("No attributes.\n\n");
            continue;
        }
        table(&mut out, e.attrs);
        if e.material {
            out.push_str("\nPlus the [material attributes](#material-attributes).\n");
        }
        out.push('\n');
    }
    out.push_str("### Material attributes\n\nOn any geometry; the defaults are the report's material.\n\n");
    table(&mut out, MATERIAL_ATTRS);
    out
}

/// Byte offset of 1-based `row` and `col` (in characters) in `text`.
fn byte_offset(text: &str, row: usize, col: usize) -> usize {
    let line_start: usize = text.split_inclusive('\n').take(row.saturating_sub(1)).map(str::len).sum();
    let line = &text[line_start.min(text.len())..];
    line_start + line.char_indices().nth(col.saturating_sub(1)).map_or(line.len(), |(i, _)| i)
}

fn element_spec(name: &str) -> &'static ElementSpec {
    ELEMENTS.iter().find(|e| e.name == name).expect("element in ELEMENTS")
}

struct Reader<'s> {
    src: &'s Arc<Source>,
}

/// The attributes of one element, matched against its spec.
struct Attrs<'a, 'i> {
    spec: &'static ElementSpec,
    /// Where defaults are said to come from: the element's tag, or the scene's when it is absent.
    loc: Loc,
    found: Vec<(&'static AttrSpec, Attribute<'a, 'i>)>,
}

impl Reader<'_> {
    fn loc(&self, r: Range<usize>) -> Loc {
        Loc::new(self.src, r)
    }

    /// The `<name` part of an element's start tag.
    fn tag_loc(&self, n: XmlNode) -> Loc {
        let start = n.range().start;
        self.loc(start..start + 1 + n.tag_name().name().len())
    }

    /// The element children of `n`, refusing text other than whitespace.
    fn children<'a, 'i>(&self, n: XmlNode<'a, 'i>) -> Result<Vec<XmlNode<'a, 'i>>> {
        let mut out = Vec::new();
        for c in n.children() {
            if c.is_element() {
                out.push(c);
            } else if c.is_text() && !c.text().unwrap_or("").trim().is_empty() {
                let text = c.text().unwrap_or("").trim();
                let start = c.range().start + self.src.text[c.range()].find(|ch: char| !ch.is_whitespace()).unwrap_or(0);
                return Err(SceneError::at(&self.loc(start..start + text.len()), format!("unexpected text in <{}>", n.tag_name().name()))
                    .with_help("the report's style puts every value in an attribute, e.g. <sphere center=\"0 0 -50\" radius=\"50\"/>"));
            }
        }
        Ok(out)
    }

    /// The spec of child element `c` of `parent`, which must be one of `allowed`.
    fn child_spec(&self, c: XmlNode, parent: &str) -> Result<&'static ElementSpec> {
        let name = c.tag_name().name();
        let allowed: Vec<&'static ElementSpec> = ELEMENTS.iter().filter(|e| e.parents.contains(&parent)).collect();
        if let Some(e) = allowed.iter().find(|e| e.name.eq_ignore_ascii_case(name)) {
            return Ok(e);
        }
        let names: Vec<&str> = allowed.iter().map(|e| e.name).collect();
        let mut err = SceneError::at(&self.tag_loc(c), format!("unknown element <{name}> in <{parent}>"));
        let list = names.iter().map(|n| format!("<{n}>")).collect::<Vec<_>>().join(", ");
        err = err.with_help(match did_you_mean(&name.to_ascii_lowercase(), names.iter().copied()) {
            Some(m) => format!("did you mean <{m}>? (expected one of {list})"),
            None => match ELEMENTS.iter().find(|e| e.name.eq_ignore_ascii_case(name)) {
                Some(e) => {
                    format!("<{}> belongs in {}", e.name, e.parents.iter().map(|p| format!("<{p}>")).collect::<Vec<_>>().join(" or "))
                }
                None => format!("expected one of {list}"),
            },
        });
        Err(err)
    }

    /// Matches the attributes of `n` against `spec`: unknown and repeated ones are errors.
    fn attrs<'a, 'i>(&self, n: XmlNode<'a, 'i>, spec: &'static ElementSpec) -> Result<Attrs<'a, 'i>> {
        let all: Vec<&'static AttrSpec> = spec.attrs.iter().chain(if spec.material { MATERIAL_ATTRS } else { &[] }).collect();
        let mut found: Vec<(&'static AttrSpec, Attribute)> = Vec::new();
        for a in n.attributes() {
            let name = a.name();
            let Some(s) = all.iter().find(|s| s.names.iter().any(|k| k.eq_ignore_ascii_case(name))) else {
                let names: Vec<&str> = all.iter().map(|s| s.names[0]).collect();
                let lower: Vec<String> = names.iter().map(|s| s.to_ascii_lowercase()).collect();
                let guess = did_you_mean(&name.to_ascii_lowercase(), lower.iter().map(String::as_str))
                    .and_then(|g| names.iter().find(|n| n.eq_ignore_ascii_case(g)));
                let list = if names.is_empty() { "none".to_string() } else { names.join(", ") };
                return Err(SceneError::at(&self.loc(a.range_qname()), format!("unknown attribute `{name}` on <{}>", spec.name))
                    .with_help(match guess {
                        Some(g) => format!("did you mean `{g}`? (attributes: {list})"),
                        None => format!("attributes of <{}>: {list}", spec.name),
                    }));
            };
            if let Some((_, prev)) = found.iter().find(|(p, _)| std::ptr::eq(*p, *s)) {
                let (l, c) = self.src.line_col(prev.range_qname().start);
                return Err(SceneError::at(&self.loc(a.range_qname()), format!("attribute `{}` is given twice", s.names[0]))
                    .with_help(format!("also given as `{}` at {l}:{c}", prev.name())));
            }
            found.push((s, a));
        }
        Ok(Attrs { spec, loc: self.tag_loc(n), found })
    }

    /// The numbers in `text` with their byte ranges in the source (when the source holds the text
    /// verbatim; otherwise every number is located at `range`, the whole value).
    fn numbers(&self, text: &str, range: Range<usize>, what: &str) -> Result<Vec<(f64, Range<usize>)>> {
        let verbatim = self.src.text.get(range.clone()) == Some(text);
        let mut out = Vec::new();
        let mut rest = text;
        let mut offset = 0;
        while let Some(start) = rest.find(|c: char| !c.is_whitespace()) {
            let len = rest[start..].find(char::is_whitespace).unwrap_or(rest.len() - start);
            let word = &rest[start..start + len];
            let r = if verbatim { range.start + offset + start..range.start + offset + start + len } else { range.clone() };
            let v: f64 = word.parse().map_err(|_| {
                let mut e = SceneError::at(&self.loc(r.clone()), format!("{what}: expected a number, found \"{word}\""));
                if word.contains(',') {
                    e = e.with_help("numbers are separated by spaces, not commas: \"1 2 3\"");
                }
                e
            })?;
            if !v.is_finite() {
                return Err(SceneError::at(&self.loc(r), format!("{what}: expected a finite number, found \"{word}\"")));
            }
            out.push((v, r));
            offset += start + len;
            rest = &rest[start + len..];
        }
        Ok(out)
    }

    /// Reads `text` (at `range`) as `kind`.
    fn convert(&self, kind: AttrKind, text: &str, range: Range<usize>, what: &str) -> Result<Node> {
        let loc = self.loc(range.clone());
        let float = |(v, r): (f64, Range<usize>)| Node { value: Value::Float(v), loc: self.loc(r) };
        let value = match kind {
            AttrKind::Text => Value::Str(text.to_string()),
            AttrKind::Count => {
                let t = text.trim();
                match t.parse::<i64>() {
                    Ok(v) if v >= 1 => Value::Int(v),
                    _ => return Err(SceneError::at(&loc, format!("{what}: expected a whole number ≥ 1, found \"{t}\""))),
                }
            }
            AttrKind::Number => match self.numbers(text, range.clone(), what)?.as_slice() {
                [(v, _)] => Value::Float(*v),
                other => return Err(SceneError::at(&loc, format!("{what}: expected one number, found {}", other.len()))),
            },
            AttrKind::Vector => {
                let n = self.numbers(text, range.clone(), what)?;
                if n.len() != 3 {
                    return Err(SceneError::at(&loc, format!("{what}: expected three numbers \"x y z\", found {}", n.len())));
                }
                Value::Array(n.into_iter().map(float).collect())
            }
            AttrKind::Color => {
                let n = self.numbers(text, range.clone(), what)?;
                if n.len() != 3 {
                    return Err(SceneError::at(
                        &loc,
                        format!("{what}: expected a colour \"r g b\" (0–255 each), found {} numbers", n.len()),
                    ));
                }
                let mut items = Vec::with_capacity(3);
                for (v, r) in n {
                    if !(0.0..=255.0).contains(&v) {
                        return Err(SceneError::at(&self.loc(r), format!("{what}: colour channels are 0–255, found {v}")));
                    }
                    items.push(float((v / 255.0, r)));
                }
                Value::Array(items)
            }
            AttrKind::Coefficient => {
                let mut n = self.numbers(text, range.clone(), what)?;
                match n.len() {
                    1 => Value::Float(n.remove(0).0),
                    3 => Value::Array(n.into_iter().map(float).collect()),
                    k => return Err(SceneError::at(&loc, format!("{what}: expected one number or three \"r g b\", found {k}"))),
                }
            }
            AttrKind::Points => {
                let n = self.numbers(text, range.clone(), what)?;
                if n.len() % 3 != 0 {
                    return Err(SceneError::at(&loc, format!("{what}: expected points \"x y z x y z …\", found {} numbers", n.len())));
                }
                let points = n
                    .chunks(3)
                    .map(|c| {
                        let r = c[0].1.start..c[2].1.end;
                        Node { value: Value::Array(c.iter().cloned().map(float).collect()), loc: self.loc(r) }
                    })
                    .collect();
                Value::Array(points)
            }
        };
        Ok(Node { value, loc })
    }

    /// Attribute `name` of `a` as (key location, value), the default when absent, or `None` when
    /// absent and left to the plugin. A required attribute that is absent is an error.
    fn value(&self, a: &Attrs, name: &str) -> Result<Option<Located>> {
        let spec = a.spec.attrs.iter().chain(MATERIAL_ATTRS).find(|s| s.names[0] == name).expect("attribute in its element's spec");
        let what = format!("<{} {}>", a.spec.name, spec.names[0]);
        if let Some((_, at)) = a.found.iter().find(|(s, _)| std::ptr::eq(*s, spec)) {
            let node = self.convert(spec.kind, at.value(), at.range_value(), &what)?;
            return Ok(Some((self.loc(at.range_qname()), node)));
        }
        match spec.default {
            Dv(text) => {
                let mut node = self.convert(spec.kind, text, 0..0, &what).expect("defaults in the spec are valid");
                relocate(&mut node, &a.loc);
                Ok(Some((a.loc.clone(), node)))
            }
            Required => {
                Err(SceneError::at(&a.loc, format!("<{}> needs attribute `{}` ({})", a.spec.name, spec.names[0], spec.kind.form()))
                    .with_help(format!("`{}`: {}", spec.names[0], spec.doc)))
            }
            Plugin | Computed => Ok(None),
        }
    }

    fn given(&self, a: &Attrs, name: &str) -> bool {
        a.found.iter().any(|(s, _)| s.names[0] == name)
    }

    fn read_scene(&self, root: XmlNode) -> Result<Table> {
        let scene_spec = element_spec("scene");
        let sa = self.attrs(root, scene_spec)?;
        let mut out = Table::default();
        let mut camera: Option<XmlNode> = None;
        let mut image: Option<XmlNode> = None;
        let mut objects = Vec::new();
        let mut lights = Vec::new();
        for c in self.children(root)? {
            let spec = self.child_spec(c, "scene")?;
            match spec.name {
                "camera" | "image" => {
                    let slot = if spec.name == "camera" { &mut camera } else { &mut image };
                    if let Some(prev) = slot {
                        let (l, col) = self.src.line_col(prev.range().start);
                        return Err(SceneError::at(&self.tag_loc(c), format!("a second <{}>; the scene has one", spec.name))
                            .with_help(format!("the first is at {l}:{col}")));
                    }
                    *slot = Some(c);
                }
                "geometries" => {
                    self.attrs(c, spec)?;
                    for g in self.children(c)? {
                        let gs = self.child_spec(g, "geometries")?;
                        objects.push(self.plugin_table(g, gs)?);
                    }
                }
                "lights" => {
                    self.attrs(c, spec)?;
                    for l in self.children(c)? {
                        let ls = self.child_spec(l, "lights")?;
                        lights.push(self.plugin_table(l, ls)?);
                    }
                }
                _ => lights.push(self.plugin_table(c, spec)?),
            }
        }

        if is_later_dialect(root, camera, image) {
            for light in &mut lights {
                give_ambient_factor(light, 1.0);
            }
        }

        let mut put = |key: &str, v: Option<Located>| {
            if let Some((kl, node)) = v {
                out.entries.push(Entry { key: key.to_string(), key_loc: kl, value: node });
            }
        };
        put("name", self.value(&sa, "name")?);
        put("background", self.value(&sa, "background-color")?);

        // Screen and image size.
        let ia = match image {
            Some(n) => Some(self.attrs(n, element_spec("image"))?),
            None => None,
        };
        let mut screen = self.pair(&sa, SCREEN_W[0], SCREEN_H[0])?;
        if let Some(ia) = &ia {
            let on_image = self.pair(ia, SCREEN_W[0], SCREEN_H[0])?;
            if let (Some(s), Some(_)) = (&screen, &on_image) {
                return Err(SceneError::at(&s.width.0, "the screen size is given on both <scene> and <image>").with_help("give it once"));
            }
            screen = screen.or(on_image);
        }
        let pixels = match &ia {
            Some(ia) => self.pair(ia, "Nx", "Ny")?,
            None => None,
        };
        let (screen, pixels) = sizes(screen, pixels, &sa.loc);
        let render_loc = ia.as_ref().map_or(&sa.loc, |a| &a.loc).clone();
        let mut render = Table::default();
        render.entries.push(entry("width", pixels.width));
        render.entries.push(entry("height", pixels.height));
        render.entries.push(entry("encoding", (sa.loc.clone(), Node { value: Value::Str("linear".into()), loc: sa.loc.clone() })));
        out.entries.push(Entry {
            key: "render".into(),
            key_loc: render_loc.clone(),
            value: Node { value: Value::Table(render), loc: render_loc },
        });

        // Camera.
        let ca = match camera {
            Some(n) => self.attrs(n, element_spec("camera"))?,
            None => Attrs { spec: element_spec("camera"), loc: sa.loc.clone(), found: Vec::new() },
        };
        let mut cam = Table::default();
        for a in element_spec("camera").attrs {
            if let Some(v) = self.value(&ca, a.names[0])? {
                cam.entries.push(entry(a.key, v));
            }
        }
        if let Some(v) = self.value(&sa, "screen-dist")? {
            cam.entries.push(entry("screen_distance", v));
        }
        cam.entries.push(entry("screen_width", screen.width));
        cam.entries.push(entry("screen_height", screen.height));
        out.entries.push(Entry { key: "camera".into(), key_loc: ca.loc.clone(), value: Node { value: Value::Table(cam), loc: ca.loc } });

        // The report's default material, for geometries that set no material attribute.
        let none = Attrs { spec: element_spec("sphere"), loc: sa.loc.clone(), found: Vec::new() };
        let mut default = Table::default();
        for m in MATERIAL_ATTRS {
            if let Some(v) = self.value(&none, m.names[0])? {
                default.entries.push(entry(m.key, v));
            }
        }
        let mut materials = Table::default();
        materials.entries.push(entry("default", (sa.loc.clone(), Node { value: Value::Table(default), loc: sa.loc.clone() })));
        out.entries.push(entry("materials", (sa.loc.clone(), Node { value: Value::Table(materials), loc: sa.loc.clone() })));

        for (key, items) in [("object", objects), ("light", lights)] {
            if !items.is_empty() {
                out.entries.push(entry(key, (sa.loc.clone(), Node { value: Value::Array(items), loc: sa.loc.clone() })));
            }
        }
        Ok(out)
    }

    /// Both or neither of two attributes (a width and a height), as numbers.
    fn pair(&self, a: &Attrs, w: &str, h: &str) -> Result<Option<Size>> {
        match (self.given(a, w), self.given(a, h)) {
            (false, false) => Ok(None),
            (true, true) => Ok(Some(Size { width: self.value(a, w)?.expect("given"), height: self.value(a, h)?.expect("given") })),
            (gw, _) => {
                let (has, missing) = if gw { (w, h) } else { (h, w) };
                Err(SceneError::at(&a.loc, format!("<{}> gives `{has}` without `{missing}`", a.spec.name))
                    .with_help("give both or neither"))
            }
        }
    }

    /// An `[[object]]` or `[[light]]` table from a geometry or light element.
    fn plugin_table(&self, n: XmlNode, spec: &'static ElementSpec) -> Result<Node> {
        let (Becomes::Object(ty) | Becomes::Light(ty)) = spec.becomes else {
            return Err(SceneError::at(&self.tag_loc(n), format!("<{}> cannot stand here", spec.name)));
        };
        self.children(n)?.first().map_or(Ok(()), |c| {
            Err(SceneError::at(&self.tag_loc(*c), format!("<{}> takes no child elements; found <{}>", spec.name, c.tag_name().name())))
        })?;
        let a = self.attrs(n, spec)?;
        let mut t = Table::default();
        t.entries.push(entry("type", (a.loc.clone(), Node { value: Value::Str(ty.into()), loc: a.loc.clone() })));
        for s in spec.attrs {
            if let Some(v) = self.value(&a, s.names[0])? {
                t.entries.push(entry(s.key, v));
            }
        }
        if let Some(i) = t.entries.iter().position(|e| e.key == "name") {
            let name = t.entries.remove(i);
            t.entries.insert(1, name);
        }
        if spec.material && a.found.iter().any(|(s, _)| MATERIAL_ATTRS.iter().any(|m| std::ptr::eq(m, *s))) {
            let mut m = Table::default();
            for s in MATERIAL_ATTRS {
                if let Some(v) = self.value(&a, s.names[0])? {
                    m.entries.push(entry(s.key, v));
                }
            }
            t.entries.push(entry("material", (a.loc.clone(), Node { value: Value::Table(m), loc: a.loc.clone() })));
        }
        Ok(Node { value: Value::Table(t), loc: self.loc(n.range()) })
    }
}

/// True for the course's later dialect (from 2020 on), false for the report's own: a file with an
/// `<image>`, or a camera spelling `Vto`/`Vup` with a capital V, or neither a camera nor a
/// screen size on `<scene>` (the course's test files), is the later one.
pub fn is_later_dialect(scene: XmlNode, camera: Option<XmlNode>, image: Option<XmlNode>) -> bool {
    let screen = scene.attributes().any(|a| a.name().to_ascii_lowercase().starts_with("screen-"));
    image.is_some() || camera.is_some_and(|c| c.attributes().any(|a| matches!(a.name(), "Vto" | "Vup"))) || (camera.is_none() && !screen)
}

/// Gives an ambient light's table `ka` (at the table's location) when it has none.
fn give_ambient_factor(light: &mut Node, ka: f64) {
    let loc = light.loc.clone();
    let Value::Table(t) = &mut light.value else { return };
    let ambient = t.get("type").is_some_and(|n| matches!(&n.value, Value::Str(s) if s == "ambient"));
    if ambient && t.get("ka").is_none() {
        t.entries.push(Entry { key: "ka".into(), key_loc: loc.clone(), value: Node { value: Value::Float(ka), loc } });
    }
}

/// A value with the location of its key: (key location, value).
type Located = (Loc, Node);

/// A width and a height (of the screen or the image).
struct Size {
    width: Located,
    height: Located,
}

fn entry(key: &str, (key_loc, value): Located) -> Entry {
    Entry { key: key.to_string(), key_loc, value }
}

/// Points every location in `node` at `loc` (values that come from defaults, not from the text).
fn relocate(node: &mut Node, loc: &Loc) {
    node.loc = loc.clone();
    if let Value::Array(items) = &mut node.value {
        items.iter_mut().for_each(|i| relocate(i, loc));
    }
}

/// The screen size (scene units) and image size (pixels), each filled in from the other's aspect
/// ratio when absent (longer side [`DEFAULT_SIDE`]), or `DEFAULT_SIDE` square when both are.
/// Values filled in are located at `loc`.
fn sizes(screen: Option<Size>, pixels: Option<Size>, loc: &Loc) -> (Size, Size) {
    let num = |n: &Node| match n.value {
        Value::Float(v) => v,
        Value::Int(v) => v as f64,
        _ => 0.0,
    };
    let side = f64::from(DEFAULT_SIDE);
    let at = |v: Value| (loc.clone(), Node { value: v, loc: loc.clone() });
    let floats = |w: f64, h: f64| Size { width: at(Value::Float(w)), height: at(Value::Float(h)) };
    let ints =
        |w: f64, h: f64| Size { width: at(Value::Int((w.round() as i64).max(1))), height: at(Value::Int((h.round() as i64).max(1))) };
    // Width and height with the aspect ratio w : h and DEFAULT_SIDE on the longer side.
    let fit = |w: f64, h: f64| {
        if !(w > 0.0 && h > 0.0) {
            (side, side)
        } else if w >= h {
            (side, side * h / w)
        } else {
            (side * w / h, side)
        }
    };
    match (screen, pixels) {
        (Some(s), Some(p)) => (s, p),
        (Some(s), None) => {
            let (w, h) = fit(num(&s.width.1), num(&s.height.1));
            (s, ints(w, h))
        }
        (None, Some(p)) => {
            let (w, h) = fit(num(&p.width.1), num(&p.height.1));
            (floats(w, h), p)
        }
        (None, None) => (floats(side, side), ints(side, side)),
    }
}
