"""Shared fixtures and functions of the Python package's tests (run: `python -m pytest python/tests` in a venv
where `pip install ./python` and `pip install pytest miepython zstandard` were run; .ci/run does
this). Every dependency is imported unconditionally: a missing one fails the run, never skips."""

import os
import pathlib
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


def cli_path() -> pathlib.Path:
    """The `scatterbake` binary of this checkout: $SCATTERBAKE_CLI, else
    $CARGO_TARGET_DIR/debug/scatterbake (default target/), which `cargo test` builds."""
    env = os.environ.get("SCATTERBAKE_CLI")
    if env:
        p = pathlib.Path(env)
    else:
        target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
        p = target / "debug" / "scatterbake"
    assert p.is_file(), (
        f"the scatterbake command line is needed at {p} (run `cargo build -p scatterbake-cli` "
        "or set SCATTERBAKE_CLI)"
    )
    return p


@pytest.fixture(scope="module")
def pure_reader():
    """The pure-Python reader python/scatterbake_table.py (numpy + zstandard)."""
    sys.path.insert(0, str(ROOT / "python"))
    import scatterbake_table

    return scatterbake_table
