//! `raylab view`: the live view in the browser (see [`crate::view`]).

use super::{App, Failure, SceneArgs};
use crate::view::session::{SceneSource, Session};
use clap::Args;
use std::io::Write;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub(crate) struct ViewArgs {
    /// Scene file, watched: saving it renders it again. Omit for the bundled default scene.
    scene: Option<PathBuf>,
    /// Port on 127.0.0.1 to serve the page on (0: any free port).
    #[arg(long, default_value_t = 0)]
    port: u16,
    /// Worker threads for rendering (default: all cores).
    #[arg(long, allow_hyphen_values = true, value_parser = super::int_in::<usize>(1, super::MAX_THREADS))]
    threads: Option<usize>,
    /// Stop at the scene's samples (the image `raylab render` writes) instead of refining further
    /// until the error target, the work budget or the page's Stop button.
    #[arg(long)]
    no_refine: bool,
    #[command(flatten)]
    scene_args: SceneArgs,
}

pub(crate) fn run(app: &App, a: ViewArgs) -> Result<(), Failure> {
    let base = a.scene_args.load_options()?;
    let source = match a.scene {
        Some(p) => {
            // A misspelt path fails here; an error inside the file is shown on the page.
            if !p.is_file() {
                return Err(Failure::Other(format!("{}: no such scene file", p.display())));
            }
            SceneSource::File(p)
        }
        None => SceneSource::Bundled { name: app.default_scene.0, text: app.default_scene.1 },
    };
    let running = crate::view::http::bind(a.port)?;
    let session = Session::new(app.registry.clone(), source, base, a.threads);
    session.set_refine(!a.no_refine);
    session.start();
    let mut out = std::io::stdout();
    let _ = writeln!(out, "raylab view: open {} in a browser (only this machine can; Ctrl-C stops)", running.url());
    let _ = out.flush();
    running.serve(session);
    Ok(())
}
