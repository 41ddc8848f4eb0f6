"""Shared fixtures: the repository root and the `hal-sim` CLI binary the round-trip tests compare
the Python package with.

The binary is ``$HAL_SIM_BIN`` (scripts/test.sh sets it), else it is built with
``cargo build -p hal-sim --bin hal-sim`` (the same code as the extension module).
"""

import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def root() -> Path:
    return ROOT


@pytest.fixture(scope="session")
def hal_sim() -> str:
    exe = os.environ.get("HAL_SIM_BIN")
    if exe:
        if not Path(exe).is_file():
            pytest.fail(f"HAL_SIM_BIN={exe}: no such file")
        return exe
    if shutil.which("cargo") is None:
        pytest.fail("neither HAL_SIM_BIN nor cargo is available to get the hal-sim CLI")
    subprocess.run(
        ["cargo", "build", "-j", "2", "-p", "hal-sim", "--bin", "hal-sim"], cwd=ROOT, check=True
    )
    target = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    if not target.is_absolute():
        target = ROOT / target
    return str(target / "debug" / "hal-sim")


def run_cli(exe: str, *args: str) -> str:
    """Runs the CLI; fails the test with its stderr on a non-zero exit."""
    p = subprocess.run([exe, *args], capture_output=True, text=True)
    if p.returncode != 0:
        pytest.fail(f"hal-sim {' '.join(args)} failed ({p.returncode}):\n{p.stderr}")
    return p.stdout
