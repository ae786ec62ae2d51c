//! `raylab-torus`: raylab's command line with every built-in plugin plus this crate's.
//! Run `raylab-torus render examples/torus/scenes/torus.toml -o torus.png`.

fn main() -> std::process::ExitCode {
    raylab::cli::run(raylab_torus::app())
}
