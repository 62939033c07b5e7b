"""Shared fixtures: the workspace, the `vbap` binary the cargo tests built, a CLI runner."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
MISSIONS = ROOT / "deploy" / "missions"


def vbap_binary() -> Path:
    exe = ROOT / "target" / "release" / "vbap"
    if not exe.is_file():
        raise RuntimeError(f"{exe} is missing: build it first (cargo build --release --bin vbap)")
    return exe


def cli(*args: str) -> subprocess.CompletedProcess:
    """`vbap ARGS`, its output captured."""
    return subprocess.run(
        [str(vbap_binary()), *map(str, args)], capture_output=True, text=True, check=False
    )


def same_run(a: Path, b: Path) -> None:
    """`vbap compare A B` must say "the same run"."""
    out = cli("compare", a, b)
    assert out.returncode == 0, out.stdout + out.stderr


@pytest.fixture
def missions() -> Path:
    return MISSIONS
