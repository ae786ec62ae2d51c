//! Support for tests, raylab's own and plugin crates': the χ² test of sampling routines
//! ([`chi2`]), seeds for randomised properties that a failure names and CI fixes ([`seed`]), and
//! tests that need a tool the machine may lack ([`missing_tool`], [`skipped`]): skipped with a
//! message on a developer's machine, a failure in CI.
//!
//! CI is recognised by the environment variable `CI` (set, and neither empty, `0` nor `false`),
//! as GitHub Actions, GitLab CI and `.ci/run` set it.
//!
//! A skip is announced on a line of its own starting with [`SKIPPED`], written straight to the
//! process's standard error (past the test harness's capture, so it shows even when the test
//! passes): `.ci/run` counts those lines and prints the count at the end.

pub mod chi2;

use std::io::Write;

/// What a skipped test's message starts with.
pub const SKIPPED: &str = "SKIPPED:";

/// The seed CI runs every randomised property with (unless `RAYLAB_SEED` says otherwise).
pub const CI_SEED: u64 = 0x5eed_2026;

/// True when running in CI (`CI` set, not empty, `0` or `false`).
pub fn in_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| !matches!(v.trim().to_ascii_lowercase().as_str(), "" | "0" | "false"))
}

/// Announces that `test` skipped (part of) its work because of `why`, on the process's standard
/// error past the harness's capture. For what CI may lack too (a CPU feature); a tool CI installs
/// goes through [`missing_tool`].
pub fn skipped(test: &str, why: &str) {
    let line = format!("{SKIPPED} {test}: {why}\n");
    let _ = std::io::stderr().lock().write_all(line.as_bytes());
}

/// `test` cannot run without `tool` (`install`: how to get it). In CI this panics: CI installs
/// every tool a test needs, so a missing one is a broken run, not a skip. Elsewhere it announces
/// the skip ([`skipped`]); the caller then returns.
#[track_caller]
pub fn missing_tool(test: &str, tool: &str, install: &str) {
    if in_ci() {
        panic!("{test} needs {tool}, which is missing in CI ({install}): CI must install it");
    }
    skipped(test, &format!("{tool} is missing ({install}); CI installs it and runs this test"));
}

/// The seed of randomised property `name`: `RAYLAB_SEED` if set (to replay a failure), else
/// [`CI_SEED`] in CI (a CI run is reproducible), else a fresh random one (a developer's runs
/// explore). It is printed through the test harness, which shows it when the test fails, with
/// the command line that replays it.
pub fn seed(name: &str) -> u64 {
    let seed = match std::env::var("RAYLAB_SEED") {
        Ok(v) => v.trim().parse().unwrap_or_else(|_| panic!("RAYLAB_SEED={v}: expected an unsigned integer")),
        Err(_) if in_ci() => CI_SEED,
        Err(_) => {
            use std::hash::{BuildHasher, Hasher};
            let mut h = std::collections::hash_map::RandomState::new().build_hasher();
            h.write(name.as_bytes());
            h.write_u128(std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos()));
            h.finish()
        }
    };
    eprintln!("{name}: seed {seed} (replay: RAYLAB_SEED={seed} cargo test … {name})");
    seed
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seeds_are_fixed_by_the_environment() {
        // The variables are read, not set, here: tests run in parallel in one process.
        match std::env::var("RAYLAB_SEED") {
            Ok(v) => assert_eq!(seed("a"), v.parse::<u64>().unwrap()),
            Err(_) if in_ci() => assert_eq!((seed("a"), seed("b")), (CI_SEED, CI_SEED)),
            Err(_) => assert_ne!(seed("a"), seed("a"), "fresh seeds differ"),
        }
    }
}
