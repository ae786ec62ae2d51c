//! The `raylab` binary: the core's command line with the built-in plugins.

fn main() -> std::process::ExitCode {
    raylab::cli::run(raylab_plugins::app())
}
