# conftest.py — what the Python tests share: the source tree, the CLI, and a check that the module
# under test is the build tree's (ctest sets PYTHONPATH; an installed palpate must not stand in).
import os
import pathlib
import subprocess

import pytest

import palpate  # a module that does not import fails every test file (never a skip)

SOURCE = pathlib.Path(os.environ.get("PALPATE_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
SCENES = SOURCE / "data" / "scenes"
MESHES = SOURCE / "data" / "meshes"


def pytest_configure(config):
    build = os.environ.get("PALPATE_PYTHON_DIR")
    if build:
        here = pathlib.Path(palpate.__file__).resolve()
        assert pathlib.Path(build).resolve() in here.parents, f"palpate imported from {here}, not {build}"


@pytest.fixture
def cli():
    """Run the `palpate` command; returns the CompletedProcess (text)."""
    exe = os.environ.get("PALPATE_CLI")
    if not exe:
        pytest.fail("PALPATE_CLI is not set (run through ctest)")

    def run(*args):
        return subprocess.run([exe, *map(str, args)], capture_output=True, text=True, timeout=600)

    return run
