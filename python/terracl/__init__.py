# SPDX-License-Identifier: Apache-2.0
"""terracl: terrain authoring in the gradient domain on OpenCL devices, from Python.

Rasters are :class:`Heightfield` (float32 elevations in metres, NaN for nodata) and
:class:`GradientField` (gx, gy in m/m on the staggered grid); both convert to and from numpy
(``h.z`` is a zero-copy view; building one from an array copies it once). Every stage of
``terracl stages`` is a function taking the same options, with the same defaults, ranges and
units, as the CLI and pipelines (``terracl.erode(h, steps=200, rain="36000 mm/h")``).

Every function that runs on a device takes ``device=`` (an index or a name substring, as the
CLI's ``--device``; default: :func:`select_device`'s choice, else OCL_* / the first GPU) and
``progress=`` (``callback(fraction, message)``; returning False or raising stops the stage with
:class:`Cancelled`). The GIL is released while the device works. Failures raise
:class:`Error` (``.stage``, ``.message``). See docs/python.md.
"""

import inspect as _inspect
import json as _json
import os as _os
import tempfile as _tempfile
import warnings as _warnings

from ._terracl import (  # noqa: F401
    Cancelled,
    DeviceInfo,
    Error,
    GradientField,
    Georef,
    Heightfield,
    MissingFileError,
    Session,
    UsageError,
    __version__,
    device,
    devices,
    select_device,
)
from . import _terracl
from . import _interop

__license__ = "Apache-2.0"

# --- Georeferencing, masks, rasterio and xarray (python/terracl/_interop.py) --------------------
# The C++ constructors stay the one place that checks and copies arrays; these wrappers first turn
# masked arrays, nodata values, DataArrays and rasterio's Affine/CRS into what they take, and refuse
# a raster whose cell size would be a guess.
_interop._CPP_HEIGHTFIELD_INIT = Heightfield.__init__
_interop._CPP_GEOREF_INIT = Georef.__init__
_CPP_SESSION_INIT = Session.__init__
_CPP_GRADIENT_INIT = GradientField.__init__


def _heightfield_init(self, array, georef=None, cell_size=None, *, transform=None, crs=None, nodata=None):
    """Heightfield(array, georef=None, cell_size=None, *, transform=None, crs=None, nodata=None).

    array: a 2-D float32 array (or int8/int16/uint8/uint16, exact in float32), a numpy masked array
    (masked cells become NaN), an xarray DataArray (georeferencing from its coordinates, attrs or rio
    accessor) or a rasterio dataset. The cell size must be known: cell_size= (metres; a number or
    (x, y)), transform= (rasterio's Affine) with crs= (a rasterio/pyproj CRS, WKT, 'EPSG:n'), or georef=.
    nodata=: cells equal to it become NaN."""
    _interop.as_heightfield(array, georef=georef, cell_size=cell_size, transform=transform, crs=crs, nodata=nodata,
                            into=self)


def _georef_init(self, geotransform=None, crs_wkt="", geographic=None, nodata=None, vertical_units="m",
                 cell_size=None, *, transform=None, crs=None):
    """Georef(geotransform=None, crs_wkt='', geographic=None, nodata=None, vertical_units='m', cell_size=None,
    *, transform=None, crs=None): geotransform in GDAL's order (c, a, b, f, d, e) or transform= as
    rasterio's Affine; crs= a rasterio/pyproj CRS, WKT, 'EPSG:n' or an EPSG code (crs_wkt= the same).
    A transform needs a CRS (its units) unless cell_size= (metres) is given; no transform needs cell_size=."""
    _interop.make_georef(geotransform=geotransform, transform=transform, crs=crs, crs_wkt=crs_wkt or None,
                         geographic=geographic, nodata=nodata, vertical_units=vertical_units, cell_size=cell_size,
                         into=self)


def _session_init(self, base, *, device=None, progress=None, base_dir=None, local=None, cell_size=None,
                  transform=None, crs=None, nodata=None):
    if _interop.is_raster_like(base):
        base = _interop.as_heightfield(base, cell_size=cell_size, transform=transform, crs=crs, nodata=nodata,
                                       what="Session base")
    _CPP_SESSION_INIT(self, base, device=device, progress=progress, base_dir=base_dir, local=local)


def _gradient_init(self, gx, gy, georef=None, cell_size=None, mean_elevation=float("nan"), *, transform=None,
                   crs=None):
    """GradientField(gx, gy, georef=None, cell_size=None, mean_elevation=nan, *, transform=None, crs=None):
    gx, gy float32 arrays in m/m. The cell size must be known (it turns slopes into heights):
    cell_size= (metres), transform= with crs=, or georef=."""
    if georef is None and (transform is not None or crs is not None):
        georef = _interop.make_georef(transform=transform, crs=crs, cell_size=cell_size, what="GradientField")
        cell_size = None
    _CPP_GRADIENT_INIT(self, gx, gy, georef, cell_size, mean_elevation)  # checks the arrays
    if georef is None and cell_size is None:
        raise ValueError(_interop._NO_CELL.format(what="GradientField"))


_heightfield_init.__name__ = _georef_init.__name__ = _session_init.__name__ = _gradient_init.__name__ = "__init__"
GradientField.__init__ = _gradient_init
Heightfield.__init__ = _heightfield_init
Georef.__init__ = _georef_init
Session.__init__ = _session_init
Heightfield.transform = property(lambda h: _interop.transform_of(h.georef.geotransform),
                                 doc="The geotransform as rasterio's affine.Affine (the GDAL tuple without the "
                                     "affine package; None without georeferencing)")
Heightfield.crs = property(lambda h: _interop.crs_of(h.georef.crs_wkt),
                           doc="The CRS as a rasterio CRS (WKT without rasterio; None when unknown)")
Heightfield.profile = property(_interop.profile_of,
                               doc="rasterio's profile for writing .z: rasterio.open(path, 'w', **h.profile)")
Heightfield.to_xarray = _interop.to_xarray
Heightfield.from_rasterio = staticmethod(_interop.from_rasterio)
GradientField.transform = property(lambda g: _interop.transform_of(g.georef.geotransform))
GradientField.crs = property(lambda g: _interop.crs_of(g.georef.crs_wkt))
Georef.transform = property(lambda g: _interop.transform_of(g.geotransform),
                            doc="The geotransform as rasterio's affine.Affine (GDAL tuple without affine; or None)")
Georef.crs = property(lambda g: _interop.crs_of(g.crs_wkt), doc="rasterio CRS (WKT without rasterio; or None)")


def _input(value, what, cell_size=None, transform=None, crs=None, nodata=None):
    """A stage's input: arrays, masked arrays, DataArrays and rasterio datasets as a Heightfield (the cell
    size must be known); a Heightfield or GradientField as it is (it has its own georeferencing)."""
    if _interop.is_raster_like(value):
        return _interop.as_heightfield(value, cell_size=cell_size, transform=transform, crs=crs, nodata=nodata,
                                       what=what)
    given = [n for n, v in (("cell_size", cell_size), ("transform", transform), ("crs", crs), ("nodata", nodata))
             if v is not None]
    if given and isinstance(value, (Heightfield, GradientField)):
        raise ValueError("%s: %s= is for an array input; a %s has its own georeferencing (set h.cell_size or "
                         "h.georef)" % (what, given[0], type(value).__name__))
    return value

_STAGES = _terracl._stage_table()

__all__ = [
    "Cancelled", "DeviceInfo", "Error", "GradientField", "Georef", "Heightfield", "MissingFileError", "Session",
    "UsageError",
    "device", "devices", "select_device", "stages", "stage", "read", "write", "edit", "render",
    "run_pipeline", "fill", "flow",
]


def stages():
    """The stage table: {name: {description, input, output, options: [{name, type, default, unit, help, ...}]}}."""
    return _STAGES


def _materialise(name, options, tmp):
    """Values given for file options as objects (a Heightfield, a GradientField, a dict or list of
    JSON) are written to files in `tmp` so that the stage reads them exactly as it reads the CLI's."""
    kinds = {o["name"]: o["type"] for o in _STAGES[name]["options"]}
    out = dict(options)
    for key, value in options.items():
        if kinds.get(key) != "input file" or value is None or isinstance(value, (str, _os.PathLike)):
            continue
        if isinstance(value, GradientField):
            path = _os.path.join(tmp, key + ".exr")
            _terracl._run_stage("write", value, {"filename": path})
        elif isinstance(value, (dict, list)):
            path = _os.path.join(tmp, key + ".json")
            with open(path, "w") as f:
                _json.dump(value, f)
        else:  # a Heightfield or a 2-D float32 array
            path = _os.path.join(tmp, key + ".tif")
            _terracl._run_stage("write", value, {"filename": path})
        out[key] = path
    return out


def stage(name, input=None, *, device=None, progress=None, cell_size=None, transform=None, crs=None, nodata=None,
          **options):
    """Runs stage `name` of the stage table on `input` with `options`, as `terracl <name> IN -o OUT
    --options` does, and returns what the stage produces (a Heightfield or a GradientField; stages
    that only write files return their input).

    input: a Heightfield, a GradientField, None, or an array / masked array / xarray DataArray /
    rasterio dataset, which needs a known cell size: cell_size= (metres), transform= with crs=, or
    georeferencing of its own. nodata=: cells equal to it become NaN (masked cells always do)."""
    return _stage(name, name, input, device, progress, cell_size, transform, crs, nodata, options)


def _stage(name, public, input, device, progress, cell_size, transform, crs, nodata, options):
    own = {o["name"] for o in _STAGES[name]["options"]} if name in _STAGES else set()
    if own & {"cell_size", "transform", "crs", "nodata"}:  # the stage's own option (read's cell_size)
        given = dict(cell_size=cell_size, transform=transform, crs=crs, nodata=nodata)
        for key in own & set(given):
            if given[key] is not None:
                options = dict(options, **{key: given[key]})
        cell_size, transform, crs, nodata = (None if k in own else given[k] for k in given)
    input = _input(input, "%s input" % public, cell_size, transform, crs, nodata)
    if name not in _STAGES:
        return _terracl._run_stage(name, input, options, device, progress)  # raises UsageError naming the stages
    needs_files = any(
        v is not None and not isinstance(v, (str, _os.PathLike)) and o["type"] == "input file"
        for o in _STAGES[name]["options"] for k, v in options.items() if k == o["name"])
    if not needs_files:
        return _terracl._run_stage(name, input, options, device, progress)
    with _tempfile.TemporaryDirectory(prefix="terracl-py-") as tmp:
        return _terracl._run_stage(name, input, _materialise(name, options, tmp), device, progress)


def _doc(name):
    s = _STAGES[name]
    lines = [s["description"], "", "Input: %s; output: %s." % (s["input"], s["output"]), "", "Options:"]
    for o in s["options"]:
        unit = " [%s]" % o["unit"] if o["unit"] else ""
        default = "" if o["default"] is None else " (default %r)" % (o["default"],)
        choices = " one of %s" % "|".join(o["choices"]) if o["choices"] else ""
        lines.append("  %s: %s%s%s%s - %s" % (o["name"], o["type"], unit, choices, default, o["help"]))
    lines.append("  device, progress: see the module's documentation")
    if s["input"] == "heightfield":
        lines.append("  cell_size, transform, crs, nodata: for an array input (its cell size must be known)")
    return "\n".join(lines)


_ANNOTATIONS = {"bool": "bool", "int": "int", "float": "float | str", "enum": "str", "string": "str",
                "json": "dict | list | str", "input file": "str | os.PathLike | Heightfield | GradientField | dict",
                "output file": "str | os.PathLike"}


def _signature(name):
    """The stage's real signature: its options (the CLI's names, defaults) as keyword-only parameters, so
    that help(), inspect.signature() and editors show them; a float option also takes a value with a
    unit ("36000 mm/h"), as the CLI does."""
    P = _inspect.Parameter
    s = _STAGES[name]
    params = [P("input", P.POSITIONAL_OR_KEYWORD, default=None)]
    reserved = {"input", "device", "progress", "cell_size", "transform", "crs", "nodata"}
    for o in s["options"]:
        if o["name"].isidentifier() and o["name"] not in reserved:
            params.append(P(o["name"], P.KEYWORD_ONLY, default=o["default"], annotation=_ANNOTATIONS.get(o["type"], "object")))
    params += [P("device", P.KEYWORD_ONLY, default=None, annotation="int | str | None"),
               P("progress", P.KEYWORD_ONLY, default=None, annotation="Callable[[float, str], bool] | None")]
    if s["input"] == "heightfield":
        params += [P("cell_size", P.KEYWORD_ONLY, default=None, annotation="float | tuple[float, float] | None"),
                   P("transform", P.KEYWORD_ONLY, default=None, annotation="affine.Affine | None"),
                   P("crs", P.KEYWORD_ONLY, default=None, annotation="rasterio.crs.CRS | str | int | None"),
                   P("nodata", P.KEYWORD_ONLY, default=None, annotation="float | None")]
    return _inspect.Signature(params, return_annotation="Heightfield | GradientField")


def _make_stage_function(name, public):
    def f(input=None, *, device=None, progress=None, cell_size=None, transform=None, crs=None, nodata=None,
          **options):
        return _stage(name, public, input, device, progress, cell_size, transform, crs, nodata, options)
    f.__name__ = f.__qualname__ = public
    f.__doc__ = _doc(name)
    f.__signature__ = _signature(name)
    return f


# One function per stage, named as the stage (terracl.erode, terracl.reconstruct, ...), plus the
# short names of the issue: fill (fill_depressions) and flow (drainage).
for _name in _STAGES:
    if _name not in ("render", "edit", "read", "write") and _name.isidentifier():
        globals()[_name] = _make_stage_function(_name, _name)
        __all__.append(_name)
fill = _make_stage_function("fill_depressions", "fill")
flow = _make_stage_function("drainage", "flow")


def read(path, *, device=None, progress=None, **options):
    """Reads a heightfield (any raster terracl reads; nodata cells become NaN) or a gradient field
    (two-channel .exr, or a 2-band gx/gy .tif). Options of the `read` stage: fill_nodata, zmin, zmax, width, height, cell_size."""
    return _terracl._run_stage("read", None, dict(options, filename=_os.fspath(path)), device, progress)


def write(data, path, *, cell_size=None, transform=None, crs=None, nodata=None, **options):
    """Writes a Heightfield (.tif .exr .png .r16) or a GradientField (.exr, .tif), atomically (a temporary
    name, then a rename). Options of the `write` stage: zmin, zmax (PNG16/RAW16 range). An array needs
    cell_size= (metres) or transform= with crs=, as everywhere: the file records its cell size."""
    data = _input(data, "write", cell_size, transform, crs, nodata)
    _terracl._run_stage("write", data, dict(options, filename=_os.fspath(path)))


def edit(base, script, *, base_dir=None, device=None, progress=None, return_report=False, cell_size=None,
         transform=None, crs=None, nodata=None):
    """Applies an edit script (docs/authoring.md) to `base` and reconstructs, as `terracl edit`.

    base: a Heightfield, a float32 array, a raster file, 'flat:WxH[@cell]', or None when the script
    names its base. script: a dict ({"units", "seed", "operations": [...]}), a list of operations or
    a script file. Warnings (an operation that may do nothing visible) go through `warnings`.
    An array base needs cell_size= (metres) or transform= with crs=.
    Returns the Heightfield, or (Heightfield, report) with return_report=True."""
    if _interop.is_raster_like(base):
        base = _interop.as_heightfield(base, cell_size=cell_size, transform=transform, crs=crs, nodata=nodata,
                                       what="edit base")
    h, report = _terracl._edit(base, script, base_dir, device, progress)
    for w in report.get("warnings", []):
        _warnings.warn("terracl edit: " + w, stacklevel=2)
    return (h, report) if return_report else h


def render(input, *, device=None, progress=None, cell_size=None, transform=None, crs=None, nodata=None, **options):
    """The `render` stage on `input` (a Heightfield, or an array with cell_size= / transform= and crs=).

    Pictures (mode hillshade, relief, shaded-relief, perspective) come back as a (rows, columns, 3) RGB
    uint8 array, or (rows, columns, 4) RGBA where the picture has alpha (nodata cells, and the border
    cells unless compute_edges=True); grey pictures have three equal channels. Values (mode slope,
    aspect, tri, tpi, roughness, profile-curvature, tangential-curvature) come back as a (rows,
    columns) float32 array, NaN where undefined:
    slope in degrees (percent with slope_format="percent"), aspect in degrees clockwise from north
    (counter-clockwise from east with trigonometric=True; NaN on flat cells unless zero_for_flat=True),
    TRI, TPI and roughness in metres, the curvatures in 1/m (GRASS r.slope.aspect's). file= writes what `terracl render IN --file FILE` writes: a
    value mode to .tif is gdaldem's Float32 raster, slope to .png the grey picture, a picture to .png
    or a georeferenced .tif. Options: those of the render stage (help(terracl.stage) / terracl.stages())."""
    input = _input(input, "render input", cell_size, transform, crs, nodata)
    return _terracl._render(input, options, device, progress)


def run_pipeline(pipeline, *, overrides=(), name="python", write_resolved=True, device=None, progress=None):
    """Runs a pipeline (a list of stages as `terracl run` reads it, a dict with "pipeline", or a
    pipeline file) after validating it. overrides: ["TAG.OPTION=VALUE", ...] as `--set`. Returns
    {stages: [{type, tag, seconds, outputs}], outputs, resolved, seconds, pipeline_hash}."""
    if isinstance(pipeline, _os.PathLike):
        pipeline = _os.fspath(pipeline)
    return _terracl._run_pipeline(pipeline, list(overrides), name, write_resolved, device, progress)
