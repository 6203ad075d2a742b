# SPDX-License-Identifier: Apache-2.0
"""Heightfield / GradientField / Georef <-> numpy: dtype, strides, copies, views, refusals."""
import gc
import math

import numpy as np
import pytest

import terracl


def test_heightfield_copies_array_and_views_are_zero_copy():
    a = np.arange(12, dtype=np.float32).reshape(3, 4)
    h = terracl.Heightfield(a, cell_size=10)
    assert (h.width, h.height, h.shape) == (4, 3, (3, 4))
    a[0, 0] = 99  # the heightfield owns a copy
    assert h.z[0, 0] == 0
    z = h.z
    assert z.dtype == np.float32 and z.shape == (3, 4) and z.strides == (16, 4) and z.flags.writeable
    z[1, 2] = -5  # a view: writes reach the heightfield
    assert h.z[1, 2] == -5 and np.shares_memory(z, h.z)
    assert np.asarray(h)[1, 2] == -5 and np.shares_memory(np.asarray(h), z)
    assert h.cell_size == (10.0, 10.0)


def test_view_keeps_the_heightfield_alive():
    z = terracl.Heightfield(np.full((5, 6), 7, np.float32), cell_size=1).z
    gc.collect()
    assert z.sum() == 7 * 30


@pytest.mark.parametrize("make", [
    lambda a: a[::2, ::3],           # strided rows and columns
    lambda a: np.asfortranarray(a),  # column-major
    lambda a: a.T,                   # transposed view
    lambda a: a[:, 1:-1],            # offset rows
])
def test_non_contiguous_input_is_copied_exactly(make):
    base = np.random.default_rng(1).standard_normal((9, 13)).astype(np.float32)
    a = make(base)
    h = terracl.Heightfield(a, cell_size=1)
    assert h.z.shape == a.shape and h.z.flags.c_contiguous
    assert np.array_equal(h.z, a)


@pytest.mark.parametrize("bad, exc, words", [
    (np.zeros((4, 4), np.float64), TypeError, ["float32", "float64", "astype"]),
    (np.zeros((4, 4), np.int32), TypeError, ["float32", "int32"]),
    (np.zeros((2, 4, 4), np.float32), ValueError, ["2-D", "3 dimensions"]),
    (np.zeros(16, np.float32), ValueError, ["2-D", "1 dimension"]),
    (np.zeros((0, 4), np.float32), ValueError, ["empty"]),
    ([[1.0, 2.0], [3.0, 4.0]], TypeError, ["numpy float32 array", "list"]),
])
def test_wrong_arrays_are_refused_clearly(bad, exc, words):
    with pytest.raises(exc) as e:
        terracl.Heightfield(bad, cell_size=1)
    for w in words:
        assert w in str(e.value)
    with pytest.raises(exc):
        terracl.extract(bad, cell_size=1)  # stage inputs go through the same check


def test_assigning_z_copies_in_place_and_checks_the_shape():
    h = terracl.Heightfield(np.zeros((3, 4), np.float32), cell_size=1)
    view = h.z
    h.z = np.ones((3, 4), np.float32)
    assert view.sum() == 12  # the old view sees the new values: same memory
    with pytest.raises(ValueError, match="differs"):
        h.z = np.ones((4, 3), np.float32)


def test_gradient_field_views_and_shape_check():
    gx = np.full((4, 5), 0.5, np.float32)
    gy = np.full((4, 5), -0.25, np.float32)
    g = terracl.GradientField(gx, gy, cell_size=(2, 3))
    assert g.shape == (4, 5) and g.cell_size == (2.0, 3.0) and math.isnan(g.mean_elevation)
    assert np.array_equal(g.gx, gx) and np.array_equal(g.gy, gy)
    g.gx[0, 0] = 1
    assert g.gx[0, 0] == 1
    with pytest.raises(ValueError, match="gy"):
        terracl.GradientField(gx, np.zeros((5, 4), np.float32), cell_size=1)


def test_georef_of_a_real_dem_and_nodata_as_nan(dem, tmp_path):
    g = dem.georef
    assert g.geotransform is not None and len(g.geotransform) == 6
    assert "WGS" in g.crs_wkt and g.geographic
    # SRTM 3'' at 44 N: about 66 m east-west, 93 m north-south.
    assert 60 < g.cell_x < 70 and 90 < g.cell_y < 95 and dem.cell_size == (g.cell_x, g.cell_y)
    # NaN cells are nodata: written and read back as NaN.
    h = dem.copy()
    h.z[3, 4] = np.nan
    terracl.write(h, tmp_path / "holes.tif")
    back = terracl.read(tmp_path / "holes.tif")
    assert np.isnan(back.z[3, 4]) and back.count_nodata() == 1
    assert back.georef.geotransform == g.geotransform
    filled = terracl.read(tmp_path / "holes.tif", fill_nodata=True)
    assert filled.count_nodata() == 0


def test_georef_object():
    g = terracl.Georef(geotransform=(500000, 30, 0, 4800000, 0, -30), crs_wkt="EPSG:32619", nodata=-9999)
    assert g.cell_size == (30.0, 30.0) and g.nodata == -9999 and g.geotransform[0] == 500000
    h = terracl.Heightfield(np.zeros((3, 3), np.float32), georef=g)
    assert h.cell_size == (30.0, 30.0) and "UTM zone 19N" in h.georef.crs_wkt  # 'EPSG:n' is stored as WKT
    h.georef.cell_x = 12.5  # the georef is the heightfield's own, not a copy
    assert h.cell_size[0] == 12.5
    with pytest.raises(ValueError):
        terracl.Heightfield(np.zeros((3, 3), np.float32), cell_size=-1)


def test_read_write_round_trip(dem, tmp_path):
    for ext in (".tif", ".exr"):
        terracl.write(dem, tmp_path / ("d" + ext))
        back = terracl.read(tmp_path / ("d" + ext))
        assert np.array_equal(back.z, dem.z)
    g = terracl.extract(dem)
    terracl.write(g, tmp_path / "g.exr")
    gb = terracl.read(tmp_path / "g.exr")
    assert isinstance(gb, terracl.GradientField)
    assert np.array_equal(gb.gx, g.gx) and np.array_equal(gb.gy, g.gy)
