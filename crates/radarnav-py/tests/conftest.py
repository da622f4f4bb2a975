"""Shared fixtures of the radarnav package tests: the CLI binary to compare against."""

import os
import shutil

import pytest


@pytest.fixture(scope="session")
def cli():
    """The `radarnav` binary (RADARNAV, else target/release/radarnav, else on PATH)."""
    path = os.environ.get("RADARNAV")
    if not path:
        here = os.path.dirname(os.path.abspath(__file__))
        candidate = os.path.join(here, "..", "..", "..", "target", "release", "radarnav")
        path = candidate if os.path.exists(candidate) else shutil.which("radarnav")
    if not path or not os.path.exists(path):
        pytest.fail("the radarnav CLI is not built: cargo build --release -p radarnav-cli")
    return path
