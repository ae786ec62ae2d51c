"""Fixtures: the repository root and the `raylab` CLI binary of the same checkout.

The tests compare the Python package with the CLI, so both must come from one tree: the binary
is `$RAYLAB_BIN` when set (`.ci/run` sets it to the one `cargo test --all-features` built), else
it is built here with `cargo build -p raylab-plugins --features mesh,bvh,exr`.
"""

import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def root() -> pathlib.Path:
    return ROOT


@pytest.fixture(scope="session")
def cli(root):
    """Runs the CLI from the repository root: ``cli("render", ...)`` → CompletedProcess."""
    binary = os.environ.get("RAYLAB_BIN")
    if not binary:
        subprocess.run(
            ["cargo", "build", "-q", "-p", "raylab-plugins", "--features", "mesh,bvh,exr", "--bin", "raylab"],
            cwd=root,
            check=True,
        )
        binary = str(root / "target" / "debug" / "raylab")

    def run(*args, check=True):
        return subprocess.run([binary, *map(str, args)], cwd=root, capture_output=True, text=True, check=check)

    return run


@pytest.fixture(autouse=True)
def in_root(root, monkeypatch):
    """Scene paths are given relative to the repository root, as to the CLI."""
    monkeypatch.chdir(root)
