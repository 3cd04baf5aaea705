"""Shared fixtures: the repository root and the `gloam` CLI binary."""

import os
import shutil
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def repo() -> Path:
    return REPO


@pytest.fixture(scope="session")
def gloam_bin() -> str:
    """The CLI the Python results are compared against (bit for bit).

    GLOAM_BIN, else `gloam` on PATH, else the workspace's debug build.
    Missing, the comparison fails rather than skips: it is part of the
    package's contract.
    """
    candidates = [os.environ.get("GLOAM_BIN"), shutil.which("gloam")]
    target = Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    candidates += [str(target / "debug" / "gloam"), str(target / "release" / "gloam")]
    for c in candidates:
        if c and Path(c).is_file() and os.access(c, os.X_OK):
            return c
    pytest.fail("no gloam binary: set GLOAM_BIN or run `cargo build --bin gloam` (python/test.sh does)")
