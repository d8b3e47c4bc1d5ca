# test_install.py — after `cmake --install`, Debian's python3 imports palpate with no environment
# variable: the package lands in a folder on python3's own sys.path for the default prefix
# (/usr/local), and the extension finds the palpate libraries through its RPATH.
import os
import pathlib
import re
import subprocess

import pytest

PY = "/usr/bin/python3"


def build_dir():
    d = os.environ.get("PALPATE_BUILD_DIR")
    if not d:
        pytest.fail("PALPATE_BUILD_DIR is not set (run through ctest)")
    return pathlib.Path(d)


def test_the_default_install_folder_is_on_pythons_own_path():
    cache = (build_dir() / "CMakeCache.txt").read_text()
    prefix = re.search(r"^CMAKE_INSTALL_PREFIX:PATH=(.*)$", cache, re.M).group(1)
    folder = re.search(r"^PALPATE_PYTHON_INSTALL_DIR:STRING=(.*)$", cache, re.M).group(1)
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "LD_LIBRARY_PATH")}
    path = subprocess.run([PY, "-c", "import sys; print('\\n'.join(sys.path))"], env=env,
                          capture_output=True, text=True, check=True).stdout.split()
    if prefix in ("/usr/local", "/usr"):
        assert str(pathlib.Path(prefix) / folder) in path


def test_an_installed_palpate_imports_without_ld_library_path(tmp_path):
    cmake = os.environ.get("CMAKE_COMMAND", "cmake")
    subprocess.run([cmake, "--install", str(build_dir()), "--prefix", str(tmp_path)], check=True,
                   capture_output=True)
    cache = (build_dir() / "CMakeCache.txt").read_text()
    folder = re.search(r"^PALPATE_PYTHON_INSTALL_DIR:STRING=(.*)$", cache, re.M).group(1)
    site = tmp_path / folder
    assert (site / "palpate" / "__init__.py").exists()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "LD_LIBRARY_PATH")}
    # site.addsitedir stands in for the prefix being /usr/local (whose folder python3 already has).
    code = (f"import site; site.addsitedir({str(site)!r}); import palpate; "
            "print(palpate.__file__); print(palpate.load_scene(" + repr(str(
                pathlib.Path(os.environ['PALPATE_SOURCE_DIR']) / 'data/scenes/default.yaml')) + ").name)")
    r = subprocess.run([PY, "-c", code], env=env, capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert r.stdout.splitlines() == [str(site / "palpate" / "__init__.py"), "cvc-needle-insertion"]
