//! The command line parsed and handed to its subcommand: one file per subcommand, each reading
//! what they share from the module (`mod.rs`: the app, the scene options, the failure type).

#[cfg(feature = "view")]
use super::view;
use super::{App, Failure, bench, convert, denoise, fingerprint, merge, plugins, render, sweep, tonemap, trace};
use clap::{Parser, Subcommand};
use std::process::ExitCode;

#[derive(Parser, Debug)]
#[command(name = "raylab", version, about = "raylab: an extensible, plugin-based ray tracer", long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Render a scene to an image (the bundled default scene when SCENE is omitted).
    Render(Box<render::RenderArgs>),
    /// Explain one pixel (or one ray): every hit, light test and child ray, and the final colour.
    Trace(Box<trace::TraceArgs>),
    /// List the registered plugins and their parameters.
    Plugins(plugins::PluginsArgs),
    /// Measure the speed/accuracy trade: render at many settings of the quality knobs, time each,
    /// compare with a reference (RMSE, PSNR, SSIM), and plot error against time.
    Sweep(Box<sweep::SweepArgs>),
    /// Merge partial images (tiles, crops, sample passes from `render --tile/--crop/--pass`) into
    /// one image: the same bits as one whole render.
    Merge(merge::MergeArgs),
    /// Convert a scene (e.g. the report's XML) to raylab's TOML format.
    Convert(convert::ConvertArgs),
    /// Measure mesh loading, BVH building and ray throughput, from 1k to 1M triangles.
    Bench(bench::BenchArgs),
    /// Turn an HDR image (OpenEXR, PFM) or one of its layers (depth, normal, albedo) into a
    /// viewable PNG or JPEG.
    Tonemap(tonemap::TonemapArgs),
    /// Print a render's fingerprint (the scene, every file it reads, the resolved settings that differ from their defaults)
    /// without rendering: what partial images carry, and what tells a docs image is current.
    Fingerprint(Box<fingerprint::FingerprintArgs>),
    /// Denoise a finished image (an EXR with albedo and normal layers, e.g. a merged farm frame)
    /// with Intel Open Image Denoise (its `oidnDenoise` tool: `pip install pyoidn`).
    Denoise(denoise::DenoiseArgs),
    /// Watch a scene render live in the browser: quality knobs as controls, and any pixel's ray
    /// tree on a click (serves a page on 127.0.0.1).
    #[cfg(feature = "view")]
    View(Box<view::ViewArgs>),
    /// (Built without the `view` feature: says so.)
    #[cfg(not(feature = "view"))]
    #[command(hide = true, disable_help_flag = true)]
    View {
        #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
        args: Vec<String>,
    },
}

/// Parses `std::env::args` and runs the command. Output into a closed pipe (`raylab trace … |
/// head -5`) ends the process quietly, as it does any Unix filter: killed by SIGPIPE (status 141
/// in a shell), never a panic on a failed print.
pub fn run(app: App) -> ExitCode {
    quiet_on_closed_pipe();
    run_with_args(app, std::env::args_os())
}

/// Restores SIGPIPE's default action, which the Rust runtime sets to "ignore" (so that `println!`
/// panics with "failed printing to stdout: Broken pipe"). Sockets are unaffected: the standard
/// library sends on them with `MSG_NOSIGNAL` (or `SO_NOSIGPIPE`), so a browser or tev that hangs
/// up is still an error, not a signal.
fn quiet_on_closed_pipe() {
    #[cfg(unix)]
    // SAFETY: called once at the start of `main`, before any thread is started; `signal` with
    // `SIG_DFL` only changes the process's disposition for SIGPIPE.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

/// Runs the command given by `args` (the first item is the program name). Exit status 0 on
/// success, 1 when the command fails (the error is printed to stderr), 2 on a usage error, 130
/// when a render is interrupted by Ctrl-C (its partial image is written beside the target).
pub fn run_with_args<I, T>(app: App, args: I) -> ExitCode
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let args: Vec<std::ffi::OsString> = args.into_iter().map(Into::into).collect();
    let cli = match Cli::try_parse_from(&args) {
        Ok(c) => c,
        Err(e) => {
            let _ = e.print();
            return if e.use_stderr() { ExitCode::from(2) } else { ExitCode::SUCCESS };
        }
    };
    let result = match cli.command {
        None => render::run(&app, render::RenderArgs::default_scene()),
        Some(Command::Render(a)) => {
            let mut a = *a;
            // The arguments after `render`, for checkpoints to continue the same command.
            let at = args.iter().position(|x| x == "render").map_or(args.len(), |i| i + 1);
            a.raw = args[at..].iter().map(|x| x.to_string_lossy().into_owned()).collect();
            render::run(&app, a)
        }
        Some(Command::Merge(a)) => merge::run(&app, a),
        Some(Command::Trace(a)) => trace::run(&app, *a),
        Some(Command::Plugins(a)) => plugins::run(&app, a),
        Some(Command::Sweep(a)) => sweep::run(&app, *a),
        Some(Command::Convert(a)) => convert::run(&app, a),
        Some(Command::Bench(a)) => bench::run(&app, a),
        Some(Command::Tonemap(a)) => tonemap::run(&app, a),
        Some(Command::Denoise(a)) => denoise::run(&app, a),
        Some(Command::Fingerprint(a)) => fingerprint::run(&app, *a),
        #[cfg(feature = "view")]
        Some(Command::View(a)) => view::run(&app, *a),
        #[cfg(not(feature = "view"))]
        Some(Command::View { .. }) => {
            Err(Failure::Other(format!("`raylab view` needs the `view` feature; {}", crate::param::error::built_without("view"))))
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure::Interrupted(message)) => {
            eprintln!("{message}");
            ExitCode::from(130)
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
