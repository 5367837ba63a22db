"""Shared fixtures: the `btfpt` CLI binary (the oracle the module is compared with) and a small
synthetic material, measured and fitted once per test session."""

import os
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def cli() -> Path:
    """The btfpt binary: $BTFPT_BIN, else target/release/btfpt of this checkout."""
    p = Path(os.environ.get("BTFPT_BIN", REPO / "target" / "release" / "btfpt"))
    if not p.is_file():
        pytest.fail(f"{p}: the btfpt binary is needed (cargo build --release, or set BTFPT_BIN)")
    return p


def run_cli(cli: Path, *args, cwd=None) -> subprocess.CompletedProcess:
    """Runs the CLI, failing the test with its stderr when it fails."""
    r = subprocess.run([str(cli), *map(str, args)], capture_output=True, text=True, cwd=cwd)
    if r.returncode != 0:
        pytest.fail(f"btfpt {' '.join(map(str, args))} failed:\n{r.stderr}")
    return r


@pytest.fixture(scope="session")
def material(cli, tmp_path_factory) -> dict:
    """A 8×8-texel synthetic wool (linear EXR, 81 × 81 directions) and its PLM-C fit (16
    clusters): {"data": folder, "plmc": model file}."""
    d = tmp_path_factory.mktemp("material")
    data = d / "w8"
    run_cli(cli, "synth", "wool", "--size", "8", "--format", "exr", "-o", data)
    plmc = d / "w8.plmc"
    run_cli(cli, "fit", data, "-o", plmc, "--clusters", "16")
    return {"data": data, "plmc": plmc}
