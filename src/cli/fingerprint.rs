//! `raylab fingerprint`: a render's fingerprint (the scene, every file it reads, the resolved
//! settings off their defaults) without rendering it: the value a farm's partial images and checkpoints carry, and
//! what `docs/images.toml` records to tell whether an image in `docs/` is current.

use super::{App, Failure, SceneArgs};
use clap::Args;
use std::io::Write;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub(crate) struct FingerprintArgs {
    /// Scene file (the bundled default scene when omitted).
    scene: Option<PathBuf>,
    #[command(flatten)]
    scene_args: SceneArgs,
}

pub(crate) fn run(app: &App, a: FingerprintArgs) -> Result<(), Failure> {
    let (job, _) = super::load(app, a.scene.as_deref(), &a.scene_args, crate::image::output::ImagePlan::EIGHT_BIT)?;
    let _ = writeln!(std::io::stdout(), "{}", job.fingerprint);
    Ok(())
}
