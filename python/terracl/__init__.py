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
    Session,
    UsageError,
    __version__,
    device,
    devices,
    select_device,
)
from . import _terracl

__license__ = "Apache-2.0"

_STAGES = _terracl._stage_table()

__all__ = [
    "Cancelled", "DeviceInfo", "Error", "GradientField", "Georef", "Heightfield", "Session", "UsageError",
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


def stage(name, input=None, *, device=None, progress=None, **options):
    """Runs stage `name` of the stage table on `input` (a Heightfield, a float32 array, a
    GradientField or None) with `options`, as `terracl <name> IN -o OUT --options` does, and returns
    what the stage produces (a Heightfield or a GradientField; stages that only write files return
    their input)."""
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
    return "\n".join(lines)


def _make_stage_function(name, public):
    def f(input=None, *, device=None, progress=None, **options):
        return stage(name, input, device=device, progress=progress, **options)
    f.__name__ = f.__qualname__ = public
    f.__doc__ = _doc(name)
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


def write(data, path, **options):
    """Writes a Heightfield (.tif .exr .png .r16) or a GradientField (.exr, .tif), atomically (a temporary
    name, then a rename). Options of the `write` stage: zmin, zmax (PNG16/RAW16 range)."""
    _terracl._run_stage("write", data, dict(options, filename=_os.fspath(path)))


def edit(base, script, *, base_dir=None, device=None, progress=None, return_report=False):
    """Applies an edit script (docs/authoring.md) to `base` and reconstructs, as `terracl edit`.

    base: a Heightfield, a float32 array, a raster file, 'flat:WxH[@cell]', or None when the script
    names its base. script: a dict ({"units", "seed", "operations": [...]}), a list of operations or
    a script file. Warnings (an operation that may do nothing visible) go through `warnings`.
    Returns the Heightfield, or (Heightfield, report) with return_report=True."""
    h, report = _terracl._edit(base, script, base_dir, device, progress)
    for w in report.get("warnings", []):
        _warnings.warn("terracl edit: " + w, stacklevel=2)
    return (h, report) if return_report else h


def render(input, *, device=None, progress=None, **options):
    """The `render` stage's picture as a (height, width, 3) uint8 array (also written to `file`
    when given). Options: mode (hillshade|relief|slope|shaded-relief), azimuth, altitude, z_factor,
    ramp, slope_max, backend (device|host), file."""
    return _terracl._render(input, options, device, progress)


def run_pipeline(pipeline, *, overrides=(), name="python", write_resolved=True, device=None, progress=None):
    """Runs a pipeline (a list of stages as `terracl run` reads it, a dict with "pipeline", or a
    pipeline file) after validating it. overrides: ["TAG.OPTION=VALUE", ...] as `--set`. Returns
    {stages: [{type, tag, seconds, outputs}], outputs, resolved, seconds, pipeline_hash}."""
    if isinstance(pipeline, _os.PathLike):
        pipeline = _os.fspath(pipeline)
    return _terracl._run_pipeline(pipeline, list(overrides), name, write_resolved, device, progress)
