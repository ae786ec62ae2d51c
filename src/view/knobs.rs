//! The page's controls: the quality knobs of the render (samples, anti-aliasing, lens samples)
//! and of whichever integrator the scene uses, found by the roles in its parameter table
//! ([`Role::Depth`], [`Role::Quality`]), so any integrator's knobs appear without the page
//! knowing their names.

use crate::load::context::LoadOptions;
use crate::load::loader::RENDER_PARAMS;
use crate::load::registry::Registry;
use crate::param::error::{Result, SceneError};
use crate::param::spec::{ParamDefault, ParamKind, ParamSpec, Role};
use crate::param::value::{Node, Value};
use crate::render::RenderJob;
use crate::render::job::{AdaptiveSettings, Antialiasing};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// What the page asks for, over the scene and the command line (absent: keep theirs).
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Settings {
    /// Samples per pixel (any integer: the loader checks it, and an error names the control).
    pub spp: Option<i64>,
    /// `stratified` or `adaptive`.
    pub aa: Option<String>,
    /// Adaptive threshold.
    pub aa_threshold: Option<f64>,
    /// Adaptive depth.
    pub aa_depth: Option<i64>,
    /// Adaptive: split along located edges.
    pub aa_edges: Option<bool>,
    /// Adaptive: refine where the corners saw different objects.
    pub aa_signature: Option<bool>,
    /// Adaptive: stratified samples inside each finest cell that still disagrees.
    pub aa_cell_samples: Option<i64>,
    /// Adaptive: levels above the pixel tested first.
    pub aa_coarse: Option<i64>,
    /// Lens samples per image sample.
    pub lens_samples: Option<i64>,
    /// Relative error each pixel refines to (stratified sampling only).
    pub target_error: Option<f64>,
    /// Samples a pixel takes before its error is first tested.
    pub target_min_spp: Option<i64>,
    /// Show the image denoised (Intel Open Image Denoise, guided by albedo and normal).
    pub denoise: Option<bool>,
    /// Integrator type.
    pub integrator: Option<String>,
    /// Integrator parameters by name (its depth and quality knobs).
    #[serde(default)]
    pub params: BTreeMap<String, serde_json::Value>,
}

/// Most integrator parameters one request may set (the page sends a handful).
const MAX_PARAMS: usize = 64;

/// Where a value from the page came from, for error messages: `page control "spp"`.
fn origin(key: &str) -> String {
    format!("page control \"{key}\"")
}

/// `base` (the command line's options) with the page's `settings` over them.
pub fn options(base: &LoadOptions, s: &Settings, registry: &Registry) -> Result<LoadOptions> {
    let mut o = base.clone();
    let ov = &mut o.overrides;
    // The page's spp replaces the command line's, as a parameter located at its control.
    if s.spp.is_some() {
        ov.spp = None;
    }
    let mut render = |key: &str, v: Value| ov.render_params.push((key.to_string(), Node::given(&origin(key), v)));
    if let Some(v) = s.spp {
        render("spp", Value::Int(v));
    }
    if let Some(v) = &s.aa {
        render("aa", Value::Str(v.clone()));
    }
    if let Some(v) = s.aa_threshold {
        render("aa_threshold", Value::Float(v));
    }
    if let Some(v) = s.aa_depth {
        render("aa_depth", Value::Int(v));
    }
    if let Some(v) = s.aa_edges {
        render("aa_edges", Value::Bool(v));
    }
    if let Some(v) = s.aa_signature {
        render("aa_signature", Value::Bool(v));
    }
    if let Some(v) = s.aa_cell_samples {
        render("aa_cell_samples", Value::Int(v));
    }
    if let Some(v) = s.aa_coarse {
        render("aa_coarse", Value::Int(v));
    }
    if let Some(v) = s.lens_samples {
        render("lens_samples", Value::Int(v));
    }
    if let Some(v) = s.target_error {
        render("target_error", Value::Float(v));
    }
    if let Some(v) = s.target_min_spp {
        render("target_min_spp", Value::Int(v));
    }
    if let Some(t) = &s.integrator {
        if registry.integrator(t).is_none() {
            let names: Vec<&str> = registry.integrators().map(|p| p.name).collect();
            return Err(SceneError::msg(format!("unknown integrator \"{t}\"")).with_help(format!("known: {}", names.join(", "))));
        }
        if ov.integrator.as_deref() != Some(t) {
            // The command line's parameters were for another integrator.
            ov.integrator_params.clear();
            ov.depth = None;
        }
        ov.integrator = Some(t.clone());
    }
    if s.params.len() > MAX_PARAMS {
        return Err(SceneError::msg(format!("{} integrator parameters in one request; at most {MAX_PARAMS}", s.params.len())));
    }
    for (k, v) in &s.params {
        let value = match v {
            serde_json::Value::Bool(b) => Value::Bool(*b),
            serde_json::Value::Number(n) => match n.as_i64() {
                Some(i) => Value::Int(i),
                None => Value::Float(n.as_f64().unwrap_or(f64::NAN)),
            },
            serde_json::Value::String(s) => Value::Str(s.clone()),
            _ => return Err(SceneError::msg(format!("{}: expected a number, a boolean or a string", origin(k)))),
        };
        ov.integrator_params.push((k.clone(), Node::given(&origin(k), value)));
    }
    Ok(o)
}

/// The denoise toggle: `on` as the page asked; `denoiser` the tool found, or why there is none
/// (the control is then inactive and says so).
pub fn denoise_knob(on: bool, denoiser: Result<(), &str>) -> Knob {
    Knob {
        key: "denoise".into(),
        label: "Denoise".into(),
        kind: "bool",
        value: on.into(),
        default: false.into(),
        choices: Vec::new(),
        doc:
            "show the image denoised by Intel Open Image Denoise, guided by the albedo and normal at each pixel's first non-specular hit: \
              the scene's render once its samples are done (on raylab render --denoise's finer grid of sub-pixels where they divide evenly), \
              then every refined pass (the whole frame at once, never a tile)"
                .into(),
        group: "image",
        active: denoiser.is_ok(),
        note: denoiser.err().map(str::to_string),
    }
}

/// A choice of a `choice` control.
#[derive(Clone, Debug, Serialize)]
pub struct Choice {
    /// The value sent back.
    pub value: String,
    /// What the page shows.
    pub label: String,
    /// One line on what it is.
    pub doc: String,
}

/// One control of the page.
#[derive(Clone, Debug, Serialize)]
pub struct Knob {
    /// `spp`, `aa`, `aa_threshold`, `aa_depth`, `aa_edges`, `aa_signature`, `aa_cell_samples`,
    /// `aa_coarse`, `lens_samples`, `target_error`, `target_min_spp`, `denoise`, `integrator`, or
    /// `params.NAME`.
    pub key: String,
    /// What the page calls it.
    pub label: String,
    /// `int`, `float`, `bool` or `choice`.
    pub kind: &'static str,
    /// The value this render uses.
    pub value: serde_json::Value,
    /// The default when the scene says nothing.
    pub default: serde_json::Value,
    /// The choices of a `choice` control.
    pub choices: Vec<Choice>,
    /// What it does (its parameter table's meaning).
    pub doc: String,
    /// `sampling`, `image` or `integrator`.
    pub group: &'static str,
    /// False when it has no effect with the other settings (the page greys it out).
    pub active: bool,
    /// Why it is inactive, or a remark.
    pub note: Option<String>,
}

fn doc_of(table: &[ParamSpec], name: &str) -> String {
    table.iter().find(|s| s.name == name).map_or_else(String::new, |s| s.doc.to_string())
}

fn default_json(d: ParamDefault) -> serde_json::Value {
    match d {
        ParamDefault::Float(v) => v.into(),
        ParamDefault::Int(v) => v.into(),
        ParamDefault::Bool(v) => v.into(),
        ParamDefault::Str(v) => v.into(),
        _ => serde_json::Value::Null,
    }
}

fn value_json(v: &Value) -> serde_json::Value {
    match v {
        Value::Bool(b) => (*b).into(),
        Value::Int(i) => (*i).into(),
        Value::Float(f) => (*f).into(),
        Value::Str(s) => s.clone().into(),
        _ => serde_json::Value::Null,
    }
}

/// The controls for `job` (loaded with the page's settings), with the values it uses.
pub fn describe(registry: &Registry, job: &RenderJob) -> Vec<Knob> {
    let s = &job.settings;
    let adaptive = match s.aa {
        Antialiasing::Adaptive(a) => Some(a),
        Antialiasing::Stratified => None,
    };
    let render = |key: &str, label: &str, kind, value: serde_json::Value, active: bool, note: Option<String>| {
        let spec = RENDER_PARAMS.iter().find(|p| p.name == key);
        Knob {
            key: key.into(),
            label: label.into(),
            kind,
            value,
            default: spec.map_or(serde_json::Value::Null, |p| default_json(p.default)),
            choices: Vec::new(),
            doc: doc_of(RENDER_PARAMS, key),
            group: "sampling",
            active,
            note,
        }
    };
    let mut knobs = vec![Knob {
        choices: vec![
            Choice {
                value: "stratified".into(),
                label: "stratified".into(),
                doc: "the same number of samples in every pixel, jittered over it".into(),
            },
            Choice {
                value: "adaptive".into(),
                label: "adaptive".into(),
                doc: "rays through pixel corners; more only where neighbours disagree".into(),
            },
        ],
        ..render("aa", "Anti-aliasing", "choice", if adaptive.is_some() { "adaptive" } else { "stratified" }.into(), true, None)
    }];
    knobs.push(render(
        "spp",
        "Samples per pixel",
        "int",
        s.spp.into(),
        adaptive.is_none(),
        if adaptive.is_some() {
            Some("adaptive anti-aliasing chooses its own samples".to_string())
        } else {
            s.target.map(|_| "with an error target: the most a pixel takes in the scene's render (refining goes on past it)".to_string())
        },
    ));
    // The error target: what refining (and the scene's own render, spp its cap) stops at.
    let target = s.target;
    let target_note = if adaptive.is_some() {
        Some("error targets apply to stratified sampling".to_string())
    } else if target.is_none() {
        Some("empty: no target (refining stops when a pixel's samples all agree, or at Stop)".to_string())
    } else {
        None
    };
    knobs.push(render(
        "target_error",
        "Error target (relative)",
        "float",
        target.map_or(serde_json::Value::Null, |t| t.error.into()),
        adaptive.is_none(),
        target_note,
    ));
    let min_spp = RENDER_PARAMS.iter().find(|p| p.name == "target_min_spp").map_or(serde_json::Value::Null, |p| default_json(p.default));
    knobs.push(render(
        "target_min_spp",
        "Samples before the first error test",
        "int",
        target.map_or(min_spp, |t| t.min_spp.into()),
        target.is_some(),
        target.is_none().then(|| "used with an error target only".to_string()),
    ));
    let stratified_note = adaptive.is_none().then(|| "used by adaptive anti-aliasing only".to_string());
    // Stratified sampling shows the adaptive knobs greyed out at their defaults.
    type Of = fn(&AdaptiveSettings) -> serde_json::Value;
    let adaptive_knobs: [(&str, &str, &str, Of); 6] = [
        ("aa_threshold", "Adaptive threshold", "float", |a| a.threshold.into()),
        ("aa_depth", "Adaptive depth", "int", |a| a.max_depth.into()),
        ("aa_edges", "Split along edges", "bool", |a| a.edges.into()),
        ("aa_signature", "Refine where objects differ", "bool", |a| a.signature.into()),
        ("aa_cell_samples", "Samples per unresolved cell", "int", |a| a.cell_samples.into()),
        ("aa_coarse", "Coarse levels (blocks of 2^n pixels)", "int", |a| a.coarse.into()),
    ];
    for (key, label, kind, of) in adaptive_knobs {
        let spec_default = RENDER_PARAMS.iter().find(|p| p.name == key).map_or(serde_json::Value::Null, |p| default_json(p.default));
        let value = adaptive.as_ref().map_or(spec_default, of);
        knobs.push(render(key, label, kind, value, adaptive.is_some(), stratified_note.clone()));
    }
    let lens = job.scene.camera.aperture > 0.0;
    knobs.push(render(
        "lens_samples",
        "Lens samples",
        "int",
        s.lens_samples.into(),
        lens,
        (!lens).then(|| "the camera is a pinhole (aperture 0): no depth of field to sample".to_string()),
    ));
    knobs.push(Knob {
        key: "integrator".into(),
        label: "Integrator".into(),
        kind: "choice",
        value: job.integrator_name.clone().into(),
        default: registry.default_integrator().map_or(serde_json::Value::Null, Into::into),
        choices: registry.integrators().map(|p| Choice { value: p.name.into(), label: p.name.into(), doc: p.summary.into() }).collect(),
        doc: "how a camera ray becomes a colour".into(),
        group: "integrator",
        active: true,
        note: None,
    });
    if let Some(plugin) = registry.integrator(&job.integrator_name) {
        for p in plugin.info.params.iter().filter(|p| matches!(p.role, Role::Depth(_) | Role::Quality(_))) {
            let kind = match p.kind {
                ParamKind::Int => "int",
                ParamKind::Float => "float",
                ParamKind::Bool => "bool",
                _ => continue,
            };
            let value = job.integrator_params.get(p.name).map_or_else(|| default_json(p.default), |n| value_json(&n.value));
            let label = match p.role {
                Role::Depth(_) => format!("Recursion depth ({})", p.name),
                _ => p.name.replace('_', " "),
            };
            knobs.push(Knob {
                key: format!("params.{}", p.name),
                label,
                kind,
                value,
                default: default_json(p.default),
                choices: Vec::new(),
                doc: p.doc.into(),
                group: "integrator",
                active: true,
                note: None,
            });
        }
    }
    knobs
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_adaptive_setting_of_the_page_reaches_the_render_parameters() {
        let s = Settings {
            aa: Some("adaptive".into()),
            aa_threshold: Some(0.1),
            aa_depth: Some(2),
            aa_edges: Some(false),
            aa_signature: Some(true),
            aa_cell_samples: Some(4),
            aa_coarse: Some(2),
            ..Settings::default()
        };
        let o = options(&LoadOptions::default(), &s, &Registry::default()).unwrap();
        let given: Vec<String> = o.overrides.render_params.iter().map(|(k, n)| format!("{k}={:?}", n.value)).collect();
        assert_eq!(
            given,
            [
                "aa=Str(\"adaptive\")",
                "aa_threshold=Float(0.1)",
                "aa_depth=Int(2)",
                "aa_edges=Bool(false)",
                "aa_signature=Bool(true)",
                "aa_cell_samples=Int(4)",
                "aa_coarse=Int(2)"
            ]
        );
    }
}
