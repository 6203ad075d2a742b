# SPDX-License-Identifier: Apache-2.0
"""No silent wrong answers: masked arrays and nodata as NaN, no assumed cell size, rasterio's Affine,
CRS and datasets, xarray DataArrays in and out, terrain values from render as the CLI writes them."""
import math

import numpy as np
import pytest

import terracl

# python3-rasterio and python3-xarray (scripts/install-deps.sh): imported, not skipped, so that a CI
# machine without them fails instead of passing without these checks.
import rasterio
import xarray as xr
from affine import Affine  # rasterio's dependency
from rasterio.crs import CRS

UTM19 = CRS.from_epsg(32619)
TRANSFORM = Affine(30.0, 0.0, 500000.0, 0.0, -30.0, 4900000.0)


def terrain(n=64, seed=5):
    """A tilted surface with bumps and pits: something to fill and route."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:n, 0:n]
    return (200 + 0.8 * x + 0.5 * y + 6 * np.sin(x / 3.0) * np.cos(y / 4.0) + rng.random((n, n)) * 2).astype(np.float32)


# --- masks and nodata --------------------------------------------------------------------------

def test_masked_cells_become_nan_and_are_not_routed_as_terrain():
    z = terrain()
    z[7:57, 7:57] = -9999  # 2,500 masked cells holding -9999
    m = np.ma.masked_equal(z, -9999)
    h = terracl.Heightfield(m, cell_size=30)
    assert h.count_nodata() == 2500 and np.isnan(h.z[7:57, 7:57]).all()
    assert np.array_equal(h.z[~m.mask], z[~m.mask])
    # Given as nodata= instead of a mask: the same raster.
    assert np.array_equal(terracl.Heightfield(z, cell_size=30, nodata=-9999).z, h.z, equal_nan=True)
    # The stages see holes, not a 9,999 m deep pit.
    filled = terracl.fill(m, cell_size=30)
    assert np.isnan(filled.z[7:57, 7:57]).all() and np.nanmin(filled.z) > 100
    as_terrain = terracl.fill(z, cell_size=30)
    assert np.nanmin(as_terrain.z) > 0 and not np.array_equal(as_terrain.z, filled.z, equal_nan=True)
    assert not np.array_equal(terracl.flow(m, cell_size=30).z, terracl.flow(z, cell_size=30).z, equal_nan=True)


def test_masked_int16_is_converted_exactly():
    z = (terrain() * 10).astype(np.int16)
    m = np.ma.masked_array(z, mask=z < 2100)
    h = terracl.Heightfield(m, cell_size=(10, 12))
    assert h.cell_size == (10.0, 12.0) and h.count_nodata() == int(m.mask.sum()) > 0
    assert np.array_equal(h.z[~m.mask], z[~m.mask].astype(np.float32))
    with pytest.raises(TypeError, match="float64"):
        terracl.Heightfield(np.ma.masked_array(z.astype(np.float64)), cell_size=10)


# --- no assumed cell size ----------------------------------------------------------------------

@pytest.mark.parametrize("call", [
    lambda z: terracl.Heightfield(z),
    lambda z: terracl.fill(z),
    lambda z: terracl.flow(z),
    lambda z: terracl.extract(z),
    lambda z: terracl.stage("erode", z, steps=1),
    lambda z: terracl.render(z),
    lambda z: terracl.edit(z, {"operations": []}),
    lambda z: terracl.Session(z),
    lambda z: terracl.write(z, "/nonexistent/never-written.tif"),
    lambda z: terracl.Heightfield(np.ma.masked_array(z)),
    lambda z: terracl.fill(xr.DataArray(z)),
    lambda z: terracl.GradientField(z, z),
    lambda z: terracl.Georef(),
    lambda z: terracl.Georef(geotransform=(0, 30, 0, 0, 0, -30)),  # map units unknown without a CRS
], ids=["Heightfield", "fill", "flow", "extract", "stage", "render", "edit", "Session", "write", "masked", "DataArray",
        "GradientField", "Georef", "Georef-no-crs"])
def test_a_bare_array_without_cell_size_is_refused(call):
    with pytest.raises(ValueError) as e:
        call(terrain(16))
    assert "cell_size=" in str(e.value)


def test_flow_areas_scale_with_the_cell_size():
    z = terrain()
    one = terracl.flow(z, cell_size=1)
    thirty = terracl.flow(z, cell_size=30)
    assert thirty.cell_size == (30.0, 30.0)
    np.testing.assert_allclose(thirty.z, 900 * one.z, rtol=1e-6)
    assert np.array_equal(terracl.flow(terracl.Heightfield(z, cell_size=30)).z, thirty.z)


def test_cell_size_is_only_for_array_inputs():
    h = terracl.Heightfield(terrain(16), cell_size=30)
    with pytest.raises(ValueError, match="cell_size="):
        terracl.fill(h, cell_size=10)


# --- Affine, CRS -------------------------------------------------------------------------------

def test_georef_takes_rasterio_affine_and_crs():
    g = terracl.Georef(transform=TRANSFORM, crs=UTM19, nodata=-9999)
    assert g.geotransform == [500000.0, 30.0, 0.0, 4900000.0, 0.0, -30.0] and g.cell_size == (30.0, 30.0)
    assert g.transform == TRANSFORM and g.crs == UTM19 and not g.geographic
    # geotransform= (GDAL's order) also takes an Affine: src.transform as the issue passed it.
    assert terracl.Georef(geotransform=TRANSFORM, crs=UTM19).geotransform == g.geotransform
    for crs in ("EPSG:32619", 32619, UTM19.to_wkt(), UTM19):
        assert terracl.Georef(transform=TRANSFORM, crs=crs).crs == UTM19
    # The spelling: GDAL's names given rasterio's objects.
    assert terracl.Georef(geotransform=TRANSFORM, crs_wkt=UTM19).crs == UTM19
    h = terracl.Heightfield(terrain(8), transform=TRANSFORM, crs=UTM19)
    assert h.transform == TRANSFORM and h.crs == UTM19 and h.cell_size == (30.0, 30.0)
    geo = terracl.Heightfield(terrain(8), transform=Affine(1 / 1200, 0, -72, 0, -1 / 1200, 45), crs="EPSG:4326")
    assert geo.georef.geographic and 60 < geo.cell_size[0] < 70 and 90 < geo.cell_size[1] < 95


@pytest.mark.parametrize("kw, exc, words", [
    (dict(transform=(30, 0, 500000, 0, -30, 4900000)), ValueError, ["transform", "ambiguous", "geotransform="]),
    (dict(transform="north up"), TypeError, ["transform", "Affine"]),
    (dict(geotransform=(1, 2, 3)), ValueError, ["geotransform", "6 numbers"]),
    (dict(transform=TRANSFORM, crs="EPSG:999999999"), ValueError, ["crs"]),
    (dict(transform=TRANSFORM, crs=object()), TypeError, ["crs"]),
    (dict(transform=TRANSFORM, geotransform=TRANSFORM.to_gdal(), crs=UTM19), ValueError, ["not both"]),
])
def test_bad_georeferencing_names_the_argument(kw, exc, words):
    with pytest.raises(exc) as e:
        terracl.Heightfield(terrain(8), **kw) if "geotransform" not in kw else terracl.Georef(**kw)
    for w in words:
        assert w in str(e.value)


def test_a_crs_in_feet_gives_metric_cells():
    ft = CRS.from_epsg(2249)  # NAD83 / Massachusetts Mainland (US survey feet)
    h = terracl.Heightfield(terrain(8), transform=Affine(100, 0, 700000, 0, -100, 3000000), crs=ft)
    assert h.cell_size == pytest.approx((30.480061, 30.480061))
    assert h.transform == Affine(100, 0, 700000, 0, -100, 3000000)  # the map's own units stay


# --- rasterio round trips ----------------------------------------------------------------------

def write_int16_geotiff(path, crs=UTM19, transform=TRANSFORM, units=None):
    """A small GeoTIFF as a survey would ship it: Int16 decimetres (scale 0.1, offset 5), nodata -32768."""
    z = np.round((terrain(40, seed=2) - 5) * 10).astype(np.int16)
    z[3:6, 10:14] = -32768
    with rasterio.open(path, "w", driver="GTiff", width=40, height=40, count=1, dtype="int16", crs=crs,
                       transform=transform, nodata=-32768) as dst:
        dst.write(z, 1)
        dst.scales = (0.1,)
        dst.offsets = (5.0,)
        if units:
            dst.units = (units,)
    return z


def test_rasterio_file_to_terracl_and_back(tmp_path):
    path = tmp_path / "dem.tif"
    raw = write_int16_geotiff(path)
    h = terracl.Heightfield.from_rasterio(path)
    expect = (raw.astype(np.float64) * 0.1 + 5).astype(np.float32)
    hole = raw == -32768
    assert np.array_equal(h.z[~hole], expect[~hole]) and np.isnan(h.z[hole]).all() and h.count_nodata() == 12
    assert h.transform == TRANSFORM and h.crs == UTM19 and h.cell_size == (30.0, 30.0)
    assert h.georef.nodata == -32768
    with rasterio.open(path) as src:  # an open dataset, and a stage given the dataset itself
        assert np.array_equal(terracl.Heightfield(src).z, h.z, equal_nan=True)
        f = terracl.fill(src)
    assert f.transform == TRANSFORM and f.crs == UTM19
    # Back through rasterio with the result's profile, and through terracl.write.
    with rasterio.open(tmp_path / "out.tif", "w", **f.profile) as dst:
        dst.write(f.z, 1)
    terracl.write(f, tmp_path / "out2.tif")
    for name in ("out.tif", "out2.tif"):
        with rasterio.open(tmp_path / name) as src:
            assert src.transform == TRANSFORM and src.crs == UTM19 and src.dtypes[0] == "float32"
            back = src.read(1, masked=True)
            assert np.array_equal(back.filled(np.nan), f.z, equal_nan=True)
    assert terracl.read(tmp_path / "out.tif").georef.geotransform == list(TRANSFORM.to_gdal())


def test_rasterio_elevations_in_feet_become_metres(tmp_path):
    path = tmp_path / "feet.tif"
    raw = write_int16_geotiff(path, crs=CRS.from_epsg(2249), transform=Affine(100, 0, 700000, 0, -100, 3000000),
                              units="ft")
    h = terracl.Heightfield.from_rasterio(path)
    ok = raw != -32768
    np.testing.assert_allclose(h.z[ok], ((raw[ok] * 0.1 + 5) * 0.3048).astype(np.float32), rtol=1e-6)
    assert h.cell_size == pytest.approx((30.480061, 30.480061)) and h.georef.vertical_units == "m"
    with rasterio.open(path, "r+") as dst:
        dst.units = ("furlong",)
    with pytest.raises(ValueError, match="furlong"):
        terracl.Heightfield.from_rasterio(path)


def test_terracl_read_and_crop_of_a_crs_in_feet(tmp_path):
    """The library's own reader and crop: cells of 100 US survey feet are 30.48 m, not 100 m."""
    path = tmp_path / "feet32.tif"
    z = terrain(40)
    with rasterio.open(path, "w", driver="GTiff", width=40, height=40, count=1, dtype="float32",
                       crs=CRS.from_epsg(2249), transform=Affine(100, 0, 700000, 0, -100, 3000000)) as dst:
        dst.write(z, 1)
    h = terracl.read(path)
    assert h.cell_size == pytest.approx((30.480061, 30.480061))
    assert terracl.crop(h, x=3, y=4, width=20, height=20).cell_size == h.cell_size
    assert np.array_equal(terracl.flow(h).z, terracl.flow(z, cell_size=h.cell_size).z)


def test_rasterio_dataset_without_crs_is_refused(tmp_path):
    path = tmp_path / "nocrs.tif"
    write_int16_geotiff(path, crs=None)
    with pytest.raises(ValueError, match="cell_size="):
        terracl.Heightfield.from_rasterio(path)
    with rasterio.open(path) as src:
        assert terracl.Heightfield(src, cell_size=30).cell_size == (30.0, 30.0)


# --- xarray ------------------------------------------------------------------------------------

def data_array(z, transform=TRANSFORM, crs=UTM19):
    rows, cols = z.shape
    x = transform.c + transform.a * (np.arange(cols) + 0.5)
    y = transform.f + transform.e * (np.arange(rows) + 0.5)
    return xr.DataArray(z, dims=("y", "x"), coords={"y": y, "x": x}, attrs={"crs": crs.to_wkt(), "units": "m"})


def test_xarray_in_and_out():
    z = terrain(48)
    da = data_array(z)
    f = terracl.fill(da)
    assert f.transform == TRANSFORM and f.crs == UTM19 and f.cell_size == (30.0, 30.0)
    assert np.array_equal(f.z, terracl.fill(z, transform=TRANSFORM, crs=UTM19).z)
    out = f.to_xarray()
    assert out.dims == ("y", "x") and out.dtype == np.float32
    np.testing.assert_array_equal(out.x.values, da.x.values)
    np.testing.assert_array_equal(out.y.values, da.y.values)
    assert CRS.from_wkt(out.attrs["crs"]) == UTM19
    # What to_xarray gives comes back in unchanged (attrs transform in Affine's order, as rioxarray's).
    again = terracl.Heightfield(out)
    assert again.transform == TRANSFORM and np.array_equal(again.z, f.z)
    # South-up coordinates are flipped to terracl's north-up rows.
    up = da.isel(y=slice(None, None, -1))
    assert np.array_equal(terracl.Heightfield(up).z, z) and terracl.Heightfield(up).transform == TRANSFORM


def test_xarray_masks_scale_and_attrs_from_rasterio(tmp_path):
    path = tmp_path / "dem.tif"
    write_int16_geotiff(path)
    with rasterio.open(path) as src:
        raw = src.read(1)
        da = xr.DataArray(raw, dims=("y", "x"),
                          attrs={"transform": tuple(src.transform)[:6], "crs": src.crs.to_string(),
                                 "nodatavals": src.nodatavals, "scales": src.scales, "offsets": src.offsets})
    h = terracl.Heightfield(da)
    ref = terracl.Heightfield.from_rasterio(path)
    assert np.array_equal(h.z, ref.z, equal_nan=True) and h.transform == TRANSFORM and h.crs == UTM19
    with pytest.raises(ValueError, match="cell_size="):
        terracl.Heightfield(xr.DataArray(terrain(8)))
    assert terracl.Heightfield(xr.DataArray(terrain(8)), cell_size=5).cell_size == (5.0, 5.0)
    with pytest.raises(ValueError, match="band"):
        terracl.Heightfield(xr.DataArray(np.zeros((2, 4, 4), np.float32), dims=("band", "y", "x")), cell_size=1)


# --- render values -----------------------------------------------------------------------------

@pytest.mark.parametrize("mode", ["slope", "aspect", "tri", "tpi", "roughness", "profile-curvature", "tangential-curvature"])
def test_render_values_equal_the_cli_float32_file(mode, dem, dem_path, cli, tmp_path):
    cli("render", dem_path, "-o", tmp_path / "cli.tif", "--mode", mode)
    values = terracl.render(dem, mode=mode, file=tmp_path / "py.tif")
    assert values.dtype == np.float32 and values.shape == dem.shape
    for name in ("cli.tif", "py.tif"):
        with rasterio.open(tmp_path / name) as src:
            assert src.count == 1 and src.dtypes[0] == "float32"
            theirs = src.read(1, masked=True).filled(np.nan)
        np.testing.assert_array_equal(values, theirs)
    assert np.isnan(values[0]).all()  # border cells are undefined without compute_edges
    inner = values[1:-1, 1:-1]
    if mode == "slope":
        assert 0 <= np.nanmin(inner) and np.nanmax(inner) < 90
    if mode == "aspect":
        assert 0 <= np.nanmin(inner) and np.nanmax(inner) < 360


def test_render_slope_of_a_known_plane():
    y, x = np.mgrid[0:20, 0:20]
    plane = (x * 30 * math.tan(math.radians(20))).astype(np.float32)  # rises eastwards, 20 degrees
    s = terracl.render(plane, mode="slope", cell_size=30, compute_edges=True)
    a = terracl.render(plane, mode="aspect", cell_size=30, compute_edges=True)
    np.testing.assert_allclose(s[1:-1, 1:-1], 20, atol=1e-3)  # (the edges are extrapolated)
    np.testing.assert_allclose(a[1:-1, 1:-1], 270, atol=1e-3)  # faces west (downhill)
    with pytest.raises(terracl.Error, match=r"\.tif"):
        terracl.render(plane, mode="aspect", cell_size=30, file="aspect.png")


# --- typed stub --------------------------------------------------------------------------------

def test_the_typed_stub_is_current_and_complete():
    import os
    import subprocess
    import sys
    here = os.path.dirname(os.path.abspath(__file__))
    package = os.path.dirname(terracl.__file__)
    assert os.path.exists(os.path.join(package, "py.typed")) and os.path.exists(os.path.join(package, "__init__.pyi"))
    p = subprocess.run([sys.executable, os.path.join(here, "..", "gen_stubs.py"), "--check"], capture_output=True,
                       text=True, env=dict(os.environ, PYTHONPATH=os.path.dirname(package)))
    assert p.returncode == 0, p.stdout + p.stderr
    import ast
    with open(os.path.join(package, "__init__.pyi")) as f:
        stub = {n.name for n in ast.parse(f.read()).body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
    missing = [n for n in terracl.__all__ if n not in stub and n not in ("Progress",)]
    assert not missing, missing
