//! `raylab convert`: read a scene in any registered format (e.g. the report's XML) and write it as
//! raylab's TOML scene format. The scene is built first, so only a valid scene is written; the
//! written file renders the same image as the original.

use super::{App, Failure};
use crate::load::context::{LoadContext, LoadOptions};
use clap::Args;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub(crate) struct ConvertArgs {
    /// Scene file to read (.toml, or any registered format such as .xml).
    scene: PathBuf,
    /// TOML file to write (replaced atomically).
    #[arg(short, long)]
    output: PathBuf,
    /// Let the scene read files outside its own folder while it is checked.
    #[arg(long)]
    allow_outside_paths: bool,
}

pub(crate) fn run(app: &App, a: ConvertArgs) -> Result<(), Failure> {
    if !a.output.extension().is_some_and(|e| e.eq_ignore_ascii_case("toml")) {
        return Err(format!("convert writes raylab's TOML format: the output must end in .toml, found \"{}\"", a.output.display()).into());
    }
    super::refuse_overwrite("convert", &[a.output.as_path()], [a.scene.as_path()])?;
    let options = LoadOptions { allow_outside_paths: a.allow_outside_paths, ..LoadOptions::default() };
    let desc = crate::load::loader::read_file(&app.registry, &a.scene, &options)?;
    let job = crate::load::loader::build(&app.registry, &desc, &LoadContext::new(crate::load::context::scene_dir(&a.scene), &options))?;
    let source_name = a.scene.file_name().map_or_else(|| a.scene.display().to_string(), |n| n.to_string_lossy().into_owned());
    let header = format!("Converted by `raylab convert` from {source_name}.");
    let text = crate::param::toml::to_toml(&desc, &header);
    crate::image::write::write_atomically(&a.output, |w| w.write_all(text.as_bytes()).map_err(|e| e.to_string()))
        .map_err(|e| e.to_string())?;
    println!(
        "wrote {} ({} objects, {} lights) from {}",
        a.output.display(),
        job.scene.objects.len(),
        job.scene.lights.len(),
        a.scene.display()
    );
    Ok(())
}
