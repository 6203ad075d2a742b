# SPDX-License-Identifier: Apache-2.0
"""The wheel from an already-built module: `TERRACL_BUILD_DIR=build pip wheel .` compiles nothing
and ships the build's extension byte for byte."""
import glob
import os
import shutil
import subprocess
import sys
import zipfile

import pytest

import terracl

SOURCE = os.environ.get("TERRACL_SOURCE_DIR", os.path.dirname(os.path.dirname(os.path.dirname(__file__))))


def test_wheel_from_the_built_module(tmp_path):
    if shutil.which("cmake") is None:
        pytest.fail("cmake is needed to package")
    built = os.path.dirname(terracl._terracl.__file__)  # build/python/terracl
    build_dir = os.path.dirname(os.path.dirname(built))
    # A copy of the sources without build folders (pip may build in the source tree).
    src = tmp_path / "src"
    shutil.copytree(SOURCE, src, ignore=shutil.ignore_patterns("build*", ".git", "*.egg-info", "__pycache__"))
    env = dict(os.environ, TERRACL_BUILD_DIR=build_dir)
    r = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-build-isolation", "--no-deps", "--no-index",
                        "-w", str(tmp_path / "wheels"), str(src)], env=env, capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    assert not glob.glob(str(src / "**" / "CMakeCache.txt"), recursive=True), "the wheel ran CMake"
    wheels = glob.glob(str(tmp_path / "wheels" / "terracl-*.whl"))
    assert len(wheels) == 1, wheels
    with zipfile.ZipFile(wheels[0]) as z:
        names = z.namelist()
        so = [n for n in names if n.startswith("terracl/_terracl") and n.endswith(".so")]
        assert len(so) == 1, names
        with open(terracl._terracl.__file__, "rb") as f:
            assert z.read(so[0]) == f.read()
        for want in ("terracl/__init__.py", "terracl/__init__.pyi", "terracl/py.typed"):
            assert want in names
        assert any(n.endswith("METADATA") and b"Apache-2.0" in z.read(n) for n in names)


def test_a_build_dir_without_the_module_is_refused(tmp_path):
    src = tmp_path / "src"
    shutil.copytree(SOURCE, src, ignore=shutil.ignore_patterns("build*", ".git", "*.egg-info", "__pycache__"))
    env = dict(os.environ, TERRACL_BUILD_DIR=str(tmp_path / "nothing"))
    r = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-build-isolation", "--no-deps", "--no-index",
                        "-w", str(tmp_path / "wheels"), str(src)], env=env, capture_output=True, text=True,
                       timeout=300)
    assert r.returncode != 0
    assert "no python/terracl/_terracl" in r.stdout + r.stderr
