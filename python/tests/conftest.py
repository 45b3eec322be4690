"""Shared fixtures: the repository's test meshes and the g1tess command line (the binary
`cargo test --release` built, or G1TESS_BIN)."""

import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data"
MESHES = ["stanford-bunny.obj", "spot.obj", "fandisk.obj", "suzanne.obj"]


@pytest.fixture(scope="session")
def cli():
    """Runs the g1tess binary; returns the CompletedProcess (text output)."""
    binary = Path(os.environ.get("G1TESS_BIN", ROOT / "target" / "release" / "g1tess"))
    if not binary.is_file():
        pytest.fail(f"no g1tess binary at {binary} (build it, or set G1TESS_BIN)")

    def run(*args, check=True):
        p = subprocess.run([str(binary), *map(str, args)], capture_output=True, text=True)
        if check and p.returncode != 0:
            raise AssertionError(f"g1tess {' '.join(map(str, args))}: {p.stderr}")
        return p

    return run
