//! Rendering a frame on many machines from the command line: which share of the frame a render
//! does (`--crop`, `--tile I/N` or `auto` from a scheduler's environment, `--pass K/N`), and
//! the resume information a checkpoint carries.

use super::Failure;
use crate::render::RenderJob;
use crate::render::share::{Rect, Share};
use std::path::{Path, PathBuf};

/// Environment variables `--tile auto` reads: the task's index, and the count (Kubernetes
/// Indexed Jobs give no count, so it is set in the job's spec).
pub const TILE_INDEX_VARS: [&str; 2] = ["SLURM_ARRAY_TASK_ID", "JOB_COMPLETION_INDEX"];
/// The tile count for `--tile auto`, when the scheduler does not give it (or to override it).
pub const TILE_COUNT_VAR: &str = "RAYLAB_TILE_COUNT";

/// `A/B` as two integers with `A < B`.
fn fraction(flag: &str, s: &str) -> Result<(u32, u32), Failure> {
    let bad = || Failure::Other(format!("{flag}: expected I/N with 0 ≤ I < N (e.g. 3/16), found \"{s}\""));
    let (a, b) = s.split_once('/').ok_or_else(bad)?;
    let (a, b): (u32, u32) = (a.trim().parse().map_err(|_| bad())?, b.trim().parse().map_err(|_| bad())?);
    if b == 0 || a >= b {
        return Err(bad());
    }
    Ok((a, b))
}

/// The tile index and count a scheduler gives this task: `SLURM_ARRAY_TASK_ID` with
/// `SLURM_ARRAY_TASK_COUNT` (only for a whole array `0..COUNT`, step 1: a re-run of some tasks
/// such as `--array=1,3` would otherwise pick the wrong pixels), or `JOB_COMPLETION_INDEX`; the
/// count from `RAYLAB_TILE_COUNT` when set.
pub fn tile_from_env(var: &dyn Fn(&str) -> Option<String>) -> Result<(u32, u32), Failure> {
    let num = |name: &str| -> Result<Option<u32>, Failure> {
        match var(name) {
            None => Ok(None),
            Some(v) => v.trim().parse().map(Some).map_err(|_| Failure::Other(format!("--tile auto: {name}=\"{v}\" is not a whole number"))),
        }
    };
    let (index, from) = match (num("SLURM_ARRAY_TASK_ID")?, num("JOB_COMPLETION_INDEX")?) {
        (Some(i), _) => (i, "SLURM_ARRAY_TASK_ID"),
        (None, Some(i)) => (i, "JOB_COMPLETION_INDEX"),
        (None, None) => {
            return Err(Failure::Other(
                "--tile auto: neither SLURM_ARRAY_TASK_ID (a Slurm job array) nor JOB_COMPLETION_INDEX (a Kubernetes Indexed Job) is set; give --tile I/N".into(),
            ));
        }
    };
    let count = match num(TILE_COUNT_VAR)? {
        Some(n) => n,
        None if from == "SLURM_ARRAY_TASK_ID" => {
            let count = num("SLURM_ARRAY_TASK_COUNT")?.ok_or_else(|| {
                Failure::Other(format!("--tile auto: SLURM_ARRAY_TASK_COUNT is not set; set {TILE_COUNT_VAR} to the number of tiles"))
            })?;
            let (min, max, step) = (num("SLURM_ARRAY_TASK_MIN")?, num("SLURM_ARRAY_TASK_MAX")?, num("SLURM_ARRAY_TASK_STEP")?);
            if min.is_some_and(|m| m != 0) || max.is_some_and(|m| Some(m + 1) != Some(count)) || step.is_some_and(|s| s != 1) {
                return Err(Failure::Other(format!(
                    "--tile auto: this Slurm array is not 0..{count} with step 1 (min {min:?}, max {max:?}, step {step:?}), so its count is not the number of tiles; set {TILE_COUNT_VAR}"
                )));
            }
            count
        }
        None => return Err(Failure::Other(format!("--tile auto: {from} gives the index but not the count; set {TILE_COUNT_VAR}"))),
    };
    if count == 0 || index >= count {
        return Err(Failure::Other(format!("--tile auto: tile {index} of {count} ({from}): expected 0 ≤ index < count")));
    }
    Ok((index, count))
}

/// The share asked for by `--crop`, `--tile` and `--pass` (`None`: the whole frame).
pub fn share(job: &RenderJob, crop: Option<&str>, tile: Option<&str>, pass: Option<&str>) -> Result<Option<Share>, Failure> {
    let s = &job.settings;
    let frame = Rect::frame(s.width, s.height);
    let bounds = match (crop, tile) {
        (Some(_), Some(_)) => return Err(Failure::Other("give --crop or --tile, not both".into())),
        (Some(c), None) => {
            let bad = || {
                Failure::Other(format!(
                    "--crop: expected X0,X1,Y0,Y1 (pixel bounds [X0, X1) × [Y0, Y1) of the {}×{} frame), found \"{c}\"",
                    s.width, s.height
                ))
            };
            let v: Vec<u32> = c.split(',').map(|p| p.trim().parse::<u32>()).collect::<Result<_, _>>().map_err(|_| bad())?;
            let [x0, x1, y0, y1] = v[..] else { return Err(bad()) };
            let r = Rect { x0, y0, x1, y1 };
            if r.is_empty() || !r.within(&frame) {
                return Err(bad());
            }
            r
        }
        (None, Some(t)) => {
            let (i, n) = if t == "auto" { tile_from_env(&|k| std::env::var(k).ok())? } else { fraction("--tile", t)? };
            let costs = crate::render::split::row_costs(job);
            // On sub-pixels that stop in blocks (`--subpixels K`), bands of whole blocks: the
            // rows balanced K at a time.
            let k = s.subpixels.max(1);
            let blocks: Vec<f64> = costs.chunks(k as usize).map(|c| c.iter().sum()).collect();
            let r = crate::render::split::tile_bounds(s.width, &blocks, i, n).map_err(Failure::Other)?;
            Rect { y0: r.y0 * k, y1: (r.y1 * k).min(s.height), ..r }
        }
        (None, None) => frame,
    };
    let (k, n) = match pass {
        Some(p) => fraction("--pass", p)?,
        None => (0, 1),
    };
    if crop.is_none() && tile.is_none() && pass.is_none() {
        return Ok(None);
    }
    Ok(Some(Share { bounds, pass: k, passes: n }))
}

/// How to continue a render, as a checkpoint stores it: the arguments of the `render` command
/// and the folder they were given in.
#[derive(serde::Serialize, serde::Deserialize)]
pub struct ResumeInfo {
    /// The working folder (relative paths in `args` are relative to it).
    pub cwd: PathBuf,
    /// The arguments after `render`.
    pub args: Vec<String>,
}

/// The default checkpoint beside `output`: `NAME.checkpoint.exr`.
pub fn default_checkpoint(output: &Path) -> PathBuf {
    let stem = output.file_stem().map_or_else(|| "render".into(), |s| s.to_string_lossy().into_owned());
    output.with_file_name(format!("{stem}.checkpoint.exr"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env(pairs: &[(&str, &str)]) -> impl Fn(&str) -> Option<String> {
        let map: std::collections::HashMap<String, String> = pairs.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
        move |k| map.get(k).cloned()
    }

    #[test]
    fn tile_auto_reads_slurm_and_kubernetes() {
        let slurm = env(&[
            ("SLURM_ARRAY_TASK_ID", "3"),
            ("SLURM_ARRAY_TASK_COUNT", "8"),
            ("SLURM_ARRAY_TASK_MIN", "0"),
            ("SLURM_ARRAY_TASK_MAX", "7"),
            ("SLURM_ARRAY_TASK_STEP", "1"),
        ]);
        assert_eq!(tile_from_env(&slurm).unwrap(), (3, 8));
        // A re-run of tasks 1 and 3 of an 8-tile array: the count (2) is not the tile count.
        let rerun = env(&[
            ("SLURM_ARRAY_TASK_ID", "3"),
            ("SLURM_ARRAY_TASK_COUNT", "2"),
            ("SLURM_ARRAY_TASK_MIN", "1"),
            ("SLURM_ARRAY_TASK_MAX", "3"),
        ]);
        assert!(tile_from_env(&rerun).is_err());
        let rerun = env(&[
            ("SLURM_ARRAY_TASK_ID", "3"),
            ("SLURM_ARRAY_TASK_COUNT", "2"),
            ("SLURM_ARRAY_TASK_MIN", "1"),
            ("RAYLAB_TILE_COUNT", "8"),
        ]);
        assert_eq!(tile_from_env(&rerun).unwrap(), (3, 8));
        let k8s = env(&[("JOB_COMPLETION_INDEX", "5"), ("RAYLAB_TILE_COUNT", "16")]);
        assert_eq!(tile_from_env(&k8s).unwrap(), (5, 16));
        assert!(tile_from_env(&env(&[("JOB_COMPLETION_INDEX", "5")])).is_err());
        assert!(tile_from_env(&env(&[])).is_err());
        assert!(tile_from_env(&env(&[("JOB_COMPLETION_INDEX", "16"), ("RAYLAB_TILE_COUNT", "16")])).is_err());
        assert!(tile_from_env(&env(&[("JOB_COMPLETION_INDEX", "x"), ("RAYLAB_TILE_COUNT", "16")])).is_err());
    }

    #[test]
    fn fractions_are_checked() {
        assert_eq!(fraction("--pass", "2/5").unwrap(), (2, 5));
        for bad in ["5/5", "1/0", "a/b", "3", "-1/4"] {
            assert!(fraction("--pass", bad).is_err(), "{bad}");
        }
    }
}
