//! `raylab plugins`: every registered type with its parameter table (name, type, default, meaning).

use super::{App, Failure};
use crate::load::registry::{PluginInfo, Registry};
use clap::Args;

#[derive(Args, Debug)]
pub(crate) struct PluginsArgs {
    /// Print Markdown tables (for documentation).
    #[arg(long, conflicts_with = "json")]
    markdown: bool,
    /// Print JSON (every type, its parameters with their types, defaults and roles).
    #[arg(long)]
    json: bool,
}

pub(crate) fn run(app: &App, a: PluginsArgs) -> Result<(), Failure> {
    if a.json {
        println!("{}", serde_json::to_string_pretty(&app.registry.to_json()).map_err(|e| e.to_string())?);
        return Ok(());
    }
    print!("{}", if a.markdown { markdown(&app.registry) } else { text(&app.registry) });
    Ok(())
}

fn sections(reg: &Registry) -> [(&'static str, &'static str, Vec<&PluginInfo>); 5] {
    [
        ("GEOMETRIES", "[[object]] type = ...", reg.geometries().collect()),
        ("TEXTURES", "[textures.NAME] type = ..., or inline: kd = { type = ... }", reg.textures().collect()),
        ("MATERIALS", "[materials.NAME] type = ... (default \"phong\"), or inline: material = { type = ... }", reg.materials().collect()),
        ("LIGHTS", "[[light]] type = ...", reg.lights().collect()),
        ("INTEGRATORS", "[integrator] type = ...", reg.integrators().collect()),
    ]
}

/// The registry as plain text.
pub fn text(reg: &Registry) -> String {
    let mut out = String::new();
    for (title, usage, items) in sections(reg) {
        out.push_str(&format!("{title} ({usage})\n"));
        for p in items {
            out.push_str(&format!("\n  {}  — {}\n", p.name, p.summary));
            for s in p.params {
                out.push_str(&format!(
                    "    {:<16} {:<9} {:<18} {}{}\n",
                    s.name,
                    s.kind.name(),
                    s.default.to_string(),
                    s.doc,
                    role(&s.role)
                ));
            }
        }
        out.push('\n');
    }
    if !reg.formats().is_empty() {
        out.push_str("SCENE FORMATS (besides .toml)\n");
        for f in reg.formats() {
            out.push_str(&format!("  .{}  — {}\n", f.extensions.join(", ."), f.summary));
        }
    }
    if !reg.mesh_formats().is_empty() {
        out.push_str("\nMESH FORMATS ([[object]] type = \"mesh\", file = ...)\n");
        for f in reg.mesh_formats() {
            out.push_str(&format!("  .{}  — {}\n", f.extensions.join(", ."), f.summary));
        }
    }
    out.push_str("\nOUTPUT FORMATS (-o NAME.EXT)\n");
    for f in reg.output_formats() {
        out.push_str(&format!("  .{}  — {}\n", f.extensions.join(", ."), f.summary));
    }
    out
}

/// The registry as Markdown tables (what `docs/plugins.md` holds for the built-in plugins).
pub fn markdown(reg: &Registry) -> String {
    let mut out = String::from(
        "# Plugin reference\n\nEvery registered type and its parameters, written by `raylab plugins --markdown` from the \
         parameter tables in the plugins' sources. A new type is one file and one registration line \
         (docs/writing-a-plugin.md); a geometry registered with its sample generators \
         (`Registry::add_geometry_with_samples`) is property-, reintersection- and fuzz-tested from that line.\n\n",
    );
    out.push_str("## Scene file\n\nThe tables of a TOML scene around the plugins.\n\n");
    for (title, specs) in [
        ("The root", crate::load::loader::SCENE_PARAMS),
        ("`[render]`", crate::load::loader::RENDER_PARAMS),
        ("`[camera]`", crate::scene::camera::CAMERA_PARAMS),
        ("Every `[[object]]`", crate::load::loader::OBJECT_PARAMS),
        ("`[materials.NAME]` and inline materials", crate::scene::material::MATERIAL_PARAMS),
    ] {
        out.push_str(&format!("### {title}\n\n"));
        param_table(&mut out, specs);
        out.push('\n');
    }
    for (title, usage, items) in sections(reg) {
        let title = title[..1].to_string() + &title[1..].to_lowercase();
        out.push_str(&format!("## {title}\n\nIn a scene: `{usage}`.\n\n"));
        for p in items {
            out.push_str(&format!("### `{}`\n\n{}\n\n", p.name, p.summary));
            let sampled = reg.samplers_of(p.name);
            if title == "Geometries" && !sampled.is_empty() {
                out.push_str(&format!("Checked by the shape harnesses from its registration (samplers: `{}`).\n\n", sampled.join("`, `")));
            }
            if p.params.is_empty() {
                out.push_str("No parameters.\n\n");
                continue;
            }
            param_table(&mut out, p.params);
            out.push('\n');
        }
    }
    if !reg.formats().is_empty() {
        out.push_str("## Scene formats\n\nBesides raylab's own `.toml`, chosen by file extension:\n\n| extension | format |\n|---|---|\n");
        for f in reg.formats() {
            out.push_str(&format!("| `.{}` | {} |\n", f.extensions.join("`, `."), f.summary));
        }
    }
    if !reg.mesh_formats().is_empty() {
        out.push_str("\n## Mesh formats\n\nThe `file` of a `mesh` object, chosen by extension:\n\n| extension | format |\n|---|---|\n");
        for f in reg.mesh_formats() {
            out.push_str(&format!("| `.{}` | {} |\n", f.extensions.join("`, `."), f.summary));
        }
    }
    out.push_str("\n## Output formats\n\n`-o NAME.EXT`, chosen by extension:\n\n| extension | format |\n|---|---|\n");
    for f in reg.output_formats() {
        out.push_str(&format!("| `.{}` | {} |\n", f.extensions.join("`, `."), f.summary));
    }
    out
}

/// A parameter table as Markdown.
fn param_table(out: &mut String, specs: &[crate::param::spec::ParamSpec]) {
    out.push_str("| parameter | type | default | meaning |\n|---|---|---|---|\n");
    for s in specs {
        out.push_str(&format!("| `{}` | {} | {} | {}{} |\n", s.name, s.kind.name(), s.default, s.doc, role(&s.role)));
    }
}

/// What a parameter's role adds to its description.
fn role(r: &crate::param::spec::Role) -> String {
    use crate::param::spec::{Reference, Role};
    let reference = |r: &Reference| match r {
        Reference::Keep => String::new(),
        Reference::AtLeast(v) => format!("; reference renders use ≥ {v}"),
        Reference::AtMost(v) => format!("; reference renders use ≤ {v}"),
        Reference::Exactly(v) => format!("; reference renders use {v}"),
    };
    match r {
        Role::Setting => String::new(),
        Role::Depth(r) => format!(" *(the depth: `--depth`{})*", reference(r)),
        Role::Quality(r) => format!(" *(quality knob{})*", reference(r)),
    }
}
