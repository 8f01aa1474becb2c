import os
import shutil
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
# TAMP_FIXTURES: for runs from a copy of the tree (mutation testing runs the tests from mutants/).
FIXTURES = Path(os.environ.get("TAMP_FIXTURES") or ROOT.parent / "shared" / "fixtures")
STRICT = os.environ.get("TAMP_STRICT") == "1"
# Offscreen rendering for tests that render in this process (the CLI and web app set it themselves).
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")


def run_cli(capsys, *argv) -> tuple[int, str, str]:
    """Run the tamp-os command line in this process: (exit code, stdout, stderr)."""
    from tamp_os.cli.commands import main

    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def need(condition: bool, what: str) -> None:
    """Skip when a tool or file is missing; under TAMP_STRICT=1 (CI) fail instead."""
    if not condition:
        if STRICT:
            pytest.fail(f"TAMP_STRICT=1 and {what} is missing")
        pytest.skip(f"{what} is missing")


def need_module(name: str):
    """Import a module a test needs; skip when it is missing, or under TAMP_STRICT=1 fail."""
    import importlib

    try:
        return importlib.import_module(name)
    except ImportError:
        need(False, f"the Python module {name}")


@pytest.fixture
def fixtures_dir() -> Path:
    need(FIXTURES.is_dir(), f"the fixtures folder {FIXTURES}")
    return FIXTURES


@pytest.fixture
def fixture(fixtures_dir):
    def get(name: str) -> Path:
        path = fixtures_dir / name
        need(path.is_file(), f"fixture {name}")
        return path

    return get


def node_validator() -> Path | None:
    script = ROOT / ".tools" / "node_modules" / "gltf-validator"
    return script if script.is_dir() and shutil.which("node") else None


@pytest.fixture
def gradient_image():
    """An asymmetric test picture: a horizontal ramp plus a bright block at the top left."""
    img = np.tile(np.linspace(0, 200, 64, dtype=np.float32), (48, 1))
    img[4:16, 4:20] = 255
    return img.astype(np.uint8)
