"""Shared fixtures: a small release built once per session by the drape binary.

Environment (CTest sets these; defaults suit a run from the repository root):
  DRAPE             the drape binary (default build/bin/drape)
  DRAPE_TEST_WORK   scratch folder (default build/python_tests)
  DRAPE_GALLERY_3D  0 when the binary has no 3D view (test_gallery3d.py then skips)
"""

import os
import shutil
import subprocess
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
REPO = HERE.parent.parent
DRAPE = os.environ.get("DRAPE", str(REPO / "build" / "bin" / "drape"))
WORK = Path(os.environ.get("DRAPE_TEST_WORK", str(REPO / "build" / "python_tests")))


def run_drape(*args, **kw):
    """Runs the drape binary; returns stdout (raises with its stderr on failure)."""
    p = subprocess.run([DRAPE, *map(str, args)], capture_output=True, text=True, **kw)
    if p.returncode != 0:
        raise AssertionError(f"drape {' '.join(map(str, args))} failed ({p.returncode}):\n{p.stderr}")
    return p.stdout


@pytest.fixture(scope="session")
def release_dir() -> Path:
    """tiny_sweeps.yaml built afresh (the code may have changed since the last run)."""
    out = WORK / "tiny-sweeps"
    shutil.rmtree(out, ignore_errors=True)
    WORK.mkdir(parents=True, exist_ok=True)
    run_drape("build", HERE / "tiny_sweeps.yaml", "-o", out, "-j", "2", "--quiet")
    return out


@pytest.fixture(scope="session")
def release(release_dir):
    import drape
    return drape.open_release(release_dir)
