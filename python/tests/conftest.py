# SPDX-License-Identifier: Apache-2.0
"""Shared fixtures: the CLI (for bit-for-bit comparisons), a small real DEM, a temporary folder.

Run by ctest (test `python_pytest`), which sets PYTHONPATH to build/python, TERRACL_CLI and
TERRACL_SOURCE_DIR; by hand: PYTHONPATH=build/python TERRACL_CLI=build/bin/terracl
/usr/bin/python3 -m pytest python/tests
"""
import os
import subprocess

import numpy as np
import pytest

import terracl

SOURCE_DIR = os.environ.get("TERRACL_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
CLI = os.environ.get("TERRACL_CLI", os.path.join(SOURCE_DIR, "build", "bin", "terracl"))


@pytest.fixture(scope="session")
def cli():
    """run(*args) -> CompletedProcess of the terracl CLI; raises with its stderr when it fails."""
    if not os.path.exists(CLI):
        raise RuntimeError("the terracl CLI is not built: %s (set TERRACL_CLI)" % CLI)

    def run(*args, check=True):
        p = subprocess.run([CLI, "-q"] + [str(a) for a in args], capture_output=True, text=True)
        if check and p.returncode != 0:
            raise AssertionError("terracl %s failed (%d): %s" % (" ".join(map(str, args)), p.returncode, p.stderr))
        return p
    return run


@pytest.fixture(scope="session")
def dem_path(tmp_path_factory):
    """A 97 x 80 window of the real SRTM tile N44W072 (White Mountains) as GeoTIFF, with a few
    depressions for fill/breach: small enough that every stage runs in well under a second."""
    h = terracl.read(os.path.join(SOURCE_DIR, "data", "dem", "N44W072.hgt"))
    w = terracl.crop(h, x=600, y=500, width=97, height=80)
    path = tmp_path_factory.mktemp("dem") / "window.tif"
    terracl.write(w, path)
    return path


@pytest.fixture
def dem(dem_path):
    return terracl.read(dem_path)


def same_bits(a, b):
    """Equal arrays, NaN where the other has NaN (bit for bit for finite values)."""
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and np.array_equal(a, b, equal_nan=True)
