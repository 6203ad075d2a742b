# SPDX-License-Identifier: Apache-2.0
"""Each stage from Python gives the CLI's result on the same input, bit for bit (same device)."""
import json

import numpy as np
import pytest

import terracl
from conftest import same_bits

# (stage function, CLI subcommand, options as Python keywords, the same as CLI flags)
HEIGHT_STAGES = [
    (terracl.erode, "erode", dict(steps=30, rain="36000 mm/h"), ["--steps", "30", "--rain", "36000 mm/h"]),
    (terracl.erode, "erode", dict(steps=10, thermal_only=True, talus=30), ["--steps", "10", "--thermal-only", "--talus", "30"]),
    (terracl.fill, "fill_depressions", dict(epsilon=True), ["--epsilon"]),
    (terracl.breach, "breach", {}, []),
    (terracl.flow, "drainage", dict(method="dinf"), ["--method", "dinf"]),
    (terracl.fill_nodata, "fill_nodata", {}, []),
    (terracl.crop, "crop", dict(x=5, y=7, width=40, height=30), ["--x", "5", "--y", "7", "--width", "40", "--height", "30"]),
    (terracl.downsample, "downsample", dict(factor=3), ["--factor", "3"]),
]


@pytest.mark.parametrize("fn, sub, kw, flags", HEIGHT_STAGES, ids=[s[1] + str(i) for i, s in enumerate(HEIGHT_STAGES)])
def test_heightfield_stage_equals_cli(fn, sub, kw, flags, dem, dem_path, cli, tmp_path):
    out = tmp_path / "cli.tif"
    cli(sub, dem_path, "-o", out, *flags)
    mine = fn(dem, **kw)
    theirs = terracl.read(out)
    assert isinstance(mine, terracl.Heightfield)
    assert same_bits(mine.z, theirs.z), "%s differs from the CLI" % sub
    assert mine.georef.geotransform == theirs.georef.geotransform
    assert mine.metadata["terracl:version"] == terracl.__version__


def test_amplify_equals_cli(dem, dem_path, cli, tmp_path):
    # A coarse input (block means by 4) amplified back with the full-resolution window as exemplar.
    coarse = terracl.downsample(dem, factor=4)
    terracl.write(coarse, tmp_path / "coarse.tif")
    opts = dict(factor=4, exemplar=str(dem_path), atoms=64)
    cli("amplify", tmp_path / "coarse.tif", "-o", tmp_path / "up.tif", "--factor", "4", "--exemplar", dem_path,
        "--atoms", "64")
    up = terracl.amplify(coarse, **opts)
    assert up.shape == (coarse.height * 4, coarse.width * 4)
    assert same_bits(up.z, terracl.read(tmp_path / "up.tif").z)


def test_extract_and_reconstruct_equal_cli(dem, dem_path, cli, tmp_path):
    cli("extract", dem_path, "-o", tmp_path / "g.exr")
    g = terracl.extract(dem)
    gc = terracl.read(tmp_path / "g.exr")
    assert same_bits(g.gx, gc.gx) and same_bits(g.gy, gc.gy)
    # Reconstruct with a constraint file given as a dict (written to a file for the stage).
    cons = {"points": [{"x": 10, "y": 12, "z": 1500.0}, {"x": 60, "y": 50, "z": 900.0}]}
    (tmp_path / "c.json").write_text(json.dumps(cons))
    cli("reconstruct", tmp_path / "g.exr", "-o", tmp_path / "r.tif", "--constraints", tmp_path / "c.json",
        "--tolerance", "1e-7")
    r = terracl.reconstruct(g, constraints=cons, tolerance=1e-7)
    assert same_bits(r.z, terracl.read(tmp_path / "r.tif").z)
    assert r.z[12, 10] == np.float32(1500.0)
    # Round trip to solver tolerance (one anchor: the source mean).
    r0 = terracl.reconstruct(g, tolerance=1e-7)
    assert np.max(np.abs(r0.z - dem.z)) < 1e-2 * (dem.z.max() - dem.z.min())


def test_reconstruct_with_gradient_option_and_report(dem, tmp_path):
    g = terracl.extract(dem)
    r1 = terracl.reconstruct(g)
    r2 = terracl.reconstruct(gradient=g, report=tmp_path / "rep.json")  # an object for a file option
    assert same_bits(r1.z, r2.z)
    rep = json.loads((tmp_path / "rep.json").read_text())
    assert rep["cycles"] >= 1 and (rep["converged"] or rep["stagnated_at_float32_floor"])
    assert rep["final_relative_residual"] < 1e-5


def png_rgb(path):
    from osgeo import gdal  # python3-gdal (scripts/install-deps.sh) decodes the CLI's PNG
    a = gdal.Open(str(path)).ReadAsArray()
    return a[:, :, None] if a.ndim == 2 else np.moveaxis(a, 0, -1)


def as_rgb(picture):
    """A picture as render returns it: grey expanded to three channels, alpha kept."""
    grey = picture.shape[2] <= 2
    rgb = np.repeat(picture[:, :, :1], 3, axis=2) if grey else picture[:, :, :3]
    return np.concatenate([rgb, picture[:, :, -1:]], axis=2) if picture.shape[2] in (2, 4) else rgb


def test_render_equals_cli(dem, dem_path, cli, tmp_path):
    for mode in ("hillshade", "shaded-relief"):
        out = tmp_path / (mode + ".png")
        cli("render", dem_path, "-o", out, "--mode", mode, "--z-factor", "2")
        img = terracl.render(dem, mode=mode, z_factor=2, file=tmp_path / ("py-" + mode + ".png"))
        # RGB, or RGBA where the picture has alpha (hillshade's border cells, without compute_edges)
        theirs = png_rgb(out)
        assert img.dtype == np.uint8 and img.shape == (dem.height, dem.width, 4 if theirs.shape[2] in (2, 4) else 3)
        assert theirs.shape[2] in ((1, 2) if mode == "hillshade" else (3, 4))  # the file: grey or RGB (+ alpha)
        assert np.array_equal(img, as_rgb(theirs))
        assert np.array_equal(png_rgb(tmp_path / ("py-" + mode + ".png")), theirs)
    assert terracl.render(dem, compute_edges=True).shape == (dem.height, dem.width, 3)  # no alpha: RGB
    assert not np.array_equal(terracl.render(dem, azimuth=90), terracl.render(dem))


def test_render_perspective_equals_cli(dem, dem_path, cli, tmp_path):
    out = tmp_path / "view.png"
    flags = ["--mode", "perspective", "--size", "96x60", "--view-azimuth", "120", "--view-target", "20,15"]
    cli("render", dem_path, "-o", out, *flags)
    img = terracl.render(dem, mode="perspective", size="96x60", view_azimuth=120, view_target="20,15")
    assert img.shape == (60, 96, 3)
    assert np.array_equal(img, png_rgb(out))


def test_edit_equals_cli(cli, tmp_path):
    script = {"units": "cells", "operations": [
        {"op": "crest", "points": [[20, 60], [100, 40]], "elevation": 400, "radius": 10, "height": 150},
        {"op": "river", "points": [[10, 100], [110, 110]], "elevation": 20, "radius": 5},
        {"op": "noise", "amplitude": 5, "wavelength": 30},
    ]}
    (tmp_path / "s.json").write_text(json.dumps(script))
    cli("edit", "flat:129x129@10", "--script", tmp_path / "s.json", "-o", tmp_path / "e.tif")
    h, report = terracl.edit("flat:129x129@10", script, return_report=True)
    assert same_bits(h.z, terracl.read(tmp_path / "e.tif").z)
    assert len(report["operations"]) == 3
    # The same from a script file and from an array base.
    flat = terracl.Heightfield(np.zeros((129, 129), np.float32), cell_size=10)
    assert same_bits(terracl.edit(flat, tmp_path / "s.json").z, h.z)


def test_run_pipeline_equals_cli(dem_path, cli, tmp_path):
    def pipeline(folder):
        return [str(dem_path), {"type": "erode", "steps": 20}, {"type": "render", "file": str(folder / "hs.png")},
                str(folder / "out.tif")]
    (tmp_path / "cli").mkdir()
    (tmp_path / "py").mkdir()
    (tmp_path / "p.json").write_text(json.dumps(pipeline(tmp_path / "cli")))
    cli("run", tmp_path / "p.json", "--set", "erode.rain=0.02")
    seen = []
    rep = terracl.run_pipeline(pipeline(tmp_path / "py"), overrides=["erode.rain=0.02"],
                               progress=lambda f, m: seen.append(f))
    assert [s["type"] for s in rep["stages"]] == ["read", "erode", "render", "write"]
    assert str(tmp_path / "py" / "out.tif") in rep["outputs"]
    assert same_bits(terracl.read(tmp_path / "py" / "out.tif").z, terracl.read(tmp_path / "cli" / "out.tif").z)
    assert seen and max(seen) <= 1.0 and seen == sorted(seen)


def test_options_accept_units_like_the_cli(dem):
    a = terracl.erode(dem, steps=5, rain="36000 mm/h")
    b = terracl.erode(dem, steps=5, rain=0.01)
    assert same_bits(a.z, b.z)


def test_stage_table_and_docstrings():
    table = terracl.stages()
    assert "erode" in table and any(o["name"] == "steps" for o in table["erode"]["options"])
    assert "steps" in terracl.erode.__doc__ and "m/s" in terracl.erode.__doc__
