# SPDX-License-Identifier: Apache-2.0
"""Inputs and outputs without guessing: numpy masked arrays, nodata values, rasterio's Affine, CRS
and datasets, xarray DataArrays (docs/python.md "Georeferencing, masks, rasterio and xarray").

Every raster that reaches a stage has a known cell size in metres: from `cell_size=`, from a
transform whose CRS says what its units are, or from a Georef. A bare array without one is
refused with a ValueError naming `cell_size`; masked cells and cells equal to `nodata` become NaN
(nodata) and are never routed as terrain. rasterio and xarray are optional: they are imported only
when an input is one of theirs or a result is asked for in their types.
"""

import errno
import math
import os
import warnings

import numpy as np

from . import _terracl

# Integer types that float32 holds exactly (a DEM's Int16 band); wider ones and float64 are refused
# as the C++ side refuses them (a silent rounding is a wrong answer).
_EXACT_INTS = (np.int8, np.int16, np.uint8, np.uint16)
_FEET = {"ft", "foot", "feet", "international foot", "us survey foot", "us_survey_foot", "ftus", "us-ft",
         "foot_us", "us foot"}
_METRES = {"m", "metre", "metres", "meter", "meters"}
_US_FOOT = 1200.0 / 3937.0
_NO_CELL = ("{what}: a bare array has no cell size; give cell_size= (metres per cell, e.g. cell_size=30), "
            "transform= with crs=, or georef= (terracl never assumes 1 m cells)")


def _type_name(v):
    return type(v).__name__


def _is_xarray(v):
    t = type(v)
    return t.__name__ == "DataArray" and t.__module__.split(".")[0] == "xarray"


def _is_rasterio_dataset(v):
    t = type(v)
    return t.__module__.split(".")[0] == "rasterio" and hasattr(v, "read") and hasattr(v, "transform")


def is_raster_like(v):
    """True for what as_heightfield converts (arrays, masked arrays, DataArrays, rasterio datasets)."""
    return isinstance(v, np.ndarray) or _is_xarray(v) or _is_rasterio_dataset(v)


# --- transforms -------------------------------------------------------------------------------

def gdal_from_transform(t, what="transform"):
    """A rasterio/affine Affine (or a 9-number sequence in its order, last row 0 0 1) as GDAL's 6-number
    geotransform (c, a, b, f, d, e). A plain 6-number sequence is refused: GDAL's order and Affine's
    (a, b, c, d, e, f) cannot be told apart, and one read as the other is a silent wrong answer."""
    if hasattr(t, "to_gdal"):
        return tuple(float(x) for x in t.to_gdal())
    if all(hasattr(t, k) for k in "abcdef"):
        return (float(t.c), float(t.a), float(t.b), float(t.f), float(t.d), float(t.e))
    try:
        if isinstance(t, (str, bytes)):
            raise TypeError
        seq = [float(x) for x in t]
    except TypeError:
        raise TypeError("%s: expected an affine.Affine (rasterio's transform), got %s" % (what, _type_name(t))) from None
    if len(seq) == 9:
        if seq[6:] != [0.0, 0.0, 1.0]:
            raise ValueError("%s: a 9-number Affine must end in 0, 0, 1; got %s" % (what, seq[6:]))
        a, b, c, d, e, f = seq[:6]
        return (c, a, b, f, d, e)
    if len(seq) == 6:
        raise ValueError("%s: 6 plain numbers are ambiguous (GDAL's order c, a, b, f, d, e or Affine's a, b, c, "
                         "d, e, f); pass affine.Affine(a, b, c, d, e, f), or geotransform=(...) for GDAL's order"
                         % what)
    raise ValueError("%s: expected an affine.Affine, got %d numbers" % (what, len(seq)))


def gdal_geotransform(gt, what="geotransform"):
    """GDAL's 6 numbers (or an Affine object, converted) as a tuple of floats."""
    if hasattr(gt, "to_gdal") or all(hasattr(gt, k) for k in "abcdef"):
        return gdal_from_transform(gt, what)
    try:
        if isinstance(gt, (str, bytes)):
            raise TypeError
        seq = [float(x) for x in gt]
    except TypeError:
        raise TypeError("%s: expected 6 numbers in GDAL's order (or an affine.Affine), got %s"
                        % (what, _type_name(gt))) from None
    if len(seq) != 6:
        raise ValueError("%s: expected 6 numbers in GDAL's order (c, a, b, f, d, e), got %d" % (what, len(seq)))
    if not all(math.isfinite(x) for x in seq):
        raise ValueError("%s: the numbers must be finite, got %s" % (what, seq))
    return tuple(seq)


def transform_of(gt):
    """GDAL geotransform -> affine.Affine when the affine package (rasterio's) is importable, else the tuple."""
    if gt is None:
        return None
    try:
        from affine import Affine
    except ImportError:
        return tuple(gt)
    return Affine.from_gdal(*gt)


# --- CRS --------------------------------------------------------------------------------------

class CrsInfo:
    """WKT, whether the units are degrees, and metres per horizontal unit (None: unknown)."""

    def __init__(self, wkt="", geographic=False, metres_per_unit=None):
        self.wkt, self.geographic, self.metres_per_unit = wkt, geographic, metres_per_unit


def _osr_info(text, what):
    try:
        from osgeo import osr
    except ImportError:
        return None
    with warnings.catch_warnings():  # newer GDALs warn until UseExceptions() is chosen: not ours to choose
        warnings.simplefilter("ignore", FutureWarning)
        srs = osr.SpatialReference()
        try:
            ok = srs.SetFromUserInput(text) == 0
        except Exception:  # osr raises when the application enabled exceptions
            ok = False
    if not ok:
        raise ValueError("%s: not a CRS GDAL understands: %r" % (what, text[:80]))
    geographic = bool(srs.IsGeographic())
    return CrsInfo(srs.ExportToWkt(), geographic, None if geographic else float(srs.GetLinearUnits()))


def crs_info(crs, what="crs"):
    """A rasterio CRS, a pyproj CRS (anything with .to_wkt()), WKT, 'EPSG:n', '+proj=...' or an int EPSG code."""
    if crs is None:
        return CrsInfo()
    if isinstance(crs, bool):
        raise TypeError("%s: expected a CRS, WKT or EPSG code, got bool" % what)
    if isinstance(crs, (int, np.integer)):
        text = "EPSG:%d" % int(crs)
    elif isinstance(crs, str):
        text = crs.strip()
        if not text:
            return CrsInfo()
    elif hasattr(crs, "to_wkt"):
        text = crs.to_wkt()
        if not text:
            return CrsInfo()
    else:
        raise TypeError("%s: expected a rasterio/pyproj CRS, WKT, 'EPSG:n' or an EPSG code, got %s" % (what, _type_name(crs)))
    info = _osr_info(text, what)
    if info is not None:
        return info
    try:
        from rasterio.crs import CRS
    except ImportError:
        # Neither GDAL's Python bindings nor rasterio: keep the text (the library's GDAL reads it when
        # writing) but the units are unknown.
        return CrsInfo(text, text.upper().startswith(("GEOGCS", "GEOGCRS")), None)
    c = CRS.from_user_input(text)
    factor = None if c.is_geographic else float(c.linear_units_factor[1])
    return CrsInfo(c.to_wkt(), bool(c.is_geographic), factor)


def crs_of(wkt):
    """WKT -> rasterio.crs.CRS when rasterio is importable, else the WKT; None when unknown."""
    if not wkt:
        return None
    try:
        from rasterio.crs import CRS
    except ImportError:
        return wkt
    return CRS.from_wkt(wkt) if not wkt.upper().startswith("EPSG:") else CRS.from_user_input(wkt)


def _metric_cell(gt, info):
    """Cell size in metres of a projected transform (None: geographic, the library computes it)."""
    if info.geographic:
        return None
    f = info.metres_per_unit if info.metres_per_unit else 1.0
    return (math.hypot(gt[1], gt[4]) * f, math.hypot(gt[2], gt[5]) * f)


def make_georef(*, geotransform=None, transform=None, crs=None, crs_wkt=None, geographic=None, nodata=None,
                vertical_units="m", cell_size=None, what="Georef", require_cell_size=True, into=None):
    """A terracl.Georef from GDAL's or rasterio's names; refuses what would leave the cell size a guess."""
    if geotransform is not None and transform is not None:
        raise ValueError("%s: give transform= (rasterio's Affine) or geotransform= (GDAL's order), not both" % what)
    if crs is not None and crs_wkt:
        raise ValueError("%s: give crs= or crs_wkt=, not both" % what)
    gt = None
    if transform is not None:
        gt = gdal_from_transform(transform, "transform")
    elif geotransform is not None:
        gt = gdal_geotransform(geotransform, "geotransform")
    info = crs_info(crs if crs is not None else crs_wkt, "crs" if crs is not None else "crs_wkt")
    if geographic is not None:
        info.geographic = bool(geographic)
    if cell_size is None and gt is not None and not info.wkt and not _has_metric_units(info):
        # A transform without a CRS: its units could be metres, feet or degrees.
        raise ValueError("%s: a transform without crs= has no known units; give crs= (e.g. 'EPSG:32619') or "
                         "cell_size= in metres" % what)
    if cell_size is None and gt is None and require_cell_size:
        raise ValueError(_NO_CELL.format(what=what))
    if cell_size is None and gt is not None:
        cell_size = _metric_cell(gt, info)
    g = into if into is not None else _terracl.Georef.__new__(_terracl.Georef)
    _CPP_GEOREF_INIT(g, geotransform=gt, crs_wkt=info.wkt, geographic=info.geographic,
                     nodata=None if nodata is None else float(nodata), vertical_units=vertical_units,
                     cell_size=cell_size)
    return g


def _has_metric_units(info):
    return info.metres_per_unit is not None


# --- elevations -------------------------------------------------------------------------------

def _vertical_factor(units, what):
    """Metres per vertical unit of `units` (None or '' -> metres); unknown units are refused."""
    if units is None:
        return 1.0, "m"
    u = str(units).strip().lower()
    if u in ("",) or u in _METRES:
        return 1.0, "m"
    if u in _FEET:
        return (_US_FOOT if "us" in u else 0.3048), "m"
    raise ValueError("%s: elevations in %r: expected metres or feet (terracl works in metres)" % (what, units))


def float32_with_nan(values, nodata=None, scale=None, offset=None, vertical_factor=1.0, any_numeric=False):
    """A 2-D array (or masked array) as float32 with NaN for masked cells and cells equal to `nodata`,
    as (value * scale + offset) * vertical_factor. float32 and the integer types float32 holds exactly
    are converted; other dtypes only when `any_numeric` (a file's band, read as terracl.read reads it)
    or scale/offset is applied, else they go to the C++ check, which refuses them by name. A plain
    float32 array without nodata passes through unchanged (the C++ side copies it once)."""
    masked = np.ma.isMaskedArray(values)
    data = np.ma.getdata(values) if masked else values
    if not isinstance(data, np.ndarray) or data.ndim != 2 or data.dtype.kind not in "iuf":
        return data  # the C++ side names what was expected
    rescale = scale is not None or offset is not None or vertical_factor != 1.0
    if not (data.dtype == np.float32 or data.dtype.type in _EXACT_INTS or any_numeric or rescale):
        return data
    if not masked and nodata is None and not rescale and data.dtype == np.float32:
        return data
    bad = np.ma.getmaskarray(values) if masked else np.zeros(data.shape, bool)
    if nodata is not None:
        nd = float(nodata)
        if math.isnan(nd):
            bad = bad | np.isnan(data)
        elif data.dtype.kind in "iu":
            bad = bad | (data == nd)
        else:
            bad = bad | (data == data.dtype.type(nd))
    if rescale:
        out = data.astype(np.float64) * (1.0 if scale is None else float(scale)) + (0.0 if offset is None else float(offset))
        out = (out * vertical_factor).astype(np.float32)
    else:
        out = data.astype(np.float32, copy=True)
    out[bad] = np.nan
    return out


# --- xarray -----------------------------------------------------------------------------------

_X_NAMES = ("x", "lon", "longitude", "easting")
_Y_NAMES = ("y", "lat", "latitude", "northing")


def _coord_spacing(c, name):
    v = np.asarray(c.values, dtype=np.float64)
    if v.ndim != 1 or v.size < 2:
        raise ValueError("DataArray: coordinate %r needs at least 2 values to give a cell size; give cell_size=" % name)
    d = np.diff(v)
    step = (v[-1] - v[0]) / (v.size - 1)
    if step == 0 or np.max(np.abs(d - step)) > 1e-6 * abs(step):
        raise ValueError("DataArray: coordinate %r is not evenly spaced; terracl needs a regular grid" % name)
    return float(v[0]), float(step)


def _from_xarray(da, what):
    """(values, georef arguments) of a DataArray: dims (y, x) or with a length-1 band; georef from the
    rio accessor (rioxarray), then attrs transform/crs (rasterio's / xarray's open_rasterio), then the
    spatial_ref coordinate (CF grid mapping), then the x/y coordinates."""
    if da.ndim == 3:
        extra = [d for d in da.dims if da.sizes[d] == 1]
        if not extra:
            raise ValueError("%s: a 3-D DataArray %s; select one band (da.sel(band=1))" % (what, dict(da.sizes)))
        da = da.squeeze(extra[0], drop=True)
    if da.ndim != 2:
        raise ValueError("%s: expected a 2-D DataArray (y, x), got dims %s" % (what, da.dims))
    dims = [str(d).lower() for d in da.dims]
    if dims[0] in _X_NAMES and dims[1] in _Y_NAMES:
        da = da.transpose()
        dims = dims[::-1]
    attrs = dict(da.attrs)
    kw = {}
    rio = None
    try:
        rio = da.rio  # rioxarray's accessor, when installed
    except AttributeError:
        rio = None
    if rio is not None:
        if rio.crs is not None:
            kw["crs"] = rio.crs
        try:
            kw["transform"] = rio.transform()
        except Exception:
            pass
        if rio.nodata is not None:
            kw["nodata"] = rio.nodata
    if "crs" not in kw:
        if attrs.get("crs") not in (None, ""):
            kw["crs"] = attrs["crs"]
        elif "spatial_ref" in da.coords:
            sr = da.coords["spatial_ref"].attrs
            if sr.get("crs_wkt") or sr.get("spatial_ref"):
                kw["crs"] = sr.get("crs_wkt") or sr.get("spatial_ref")
    flip = False
    if "transform" not in kw:
        if "transform" in attrs:
            t = attrs["transform"]
            if not hasattr(t, "to_gdal"):
                t = [float(v) for v in t]
                if len(t) == 6:
                    t += [0.0, 0.0, 1.0]  # xarray's open_rasterio and rioxarray store Affine's order
            kw["transform"] = t
        elif "spatial_ref" in da.coords and da.coords["spatial_ref"].attrs.get("GeoTransform"):
            kw["geotransform"] = [float(x) for x in str(da.coords["spatial_ref"].attrs["GeoTransform"]).split()]
        elif da.dims[0] in da.coords and da.dims[1] in da.coords:
            y0, dy = _coord_spacing(da.coords[da.dims[0]], str(da.dims[0]))
            x0, dx = _coord_spacing(da.coords[da.dims[1]], str(da.dims[1]))
            if dy > 0:  # south-up: terracl's rows run north to south
                flip = True
                y0, dy = y0 + dy * (da.sizes[da.dims[0]] - 1), -dy
            kw["geotransform"] = (x0 - dx / 2, dx, 0.0, y0 - dy / 2, 0.0, dy)
            if "crs" not in kw:
                units = {str(da.coords[d].attrs.get("units", "")).lower() for d in da.dims}
                if units <= _METRES and "" not in units:
                    kw["cell_size"] = (abs(dx), abs(dy))
                elif {u for u in units} <= {"degrees_east", "degrees_north", "degree_east", "degree_north"}:
                    kw["crs"] = "EPSG:4326"
    nodata = kw.pop("nodata", None)
    for key in ("_FillValue", "nodata", "missing_value"):
        if nodata is None and attrs.get(key) is not None:
            nodata = attrs[key]
    if nodata is None and attrs.get("nodatavals"):
        nodata = tuple(attrs["nodatavals"])[0]
    if nodata is not None and isinstance(nodata, float) and math.isnan(nodata):
        nodata = None  # NaN already is nodata
    kw["nodata"] = nodata
    scale = attrs.get("scale_factor", None)
    offset = attrs.get("add_offset", None)
    if scale is None and attrs.get("scales"):
        scale = tuple(attrs["scales"])[0]
    if offset is None and attrs.get("offsets"):
        offset = tuple(attrs["offsets"])[0]
    kw["scale"] = None if scale in (None, 1, 1.0) else scale
    kw["offset"] = None if offset in (None, 0, 0.0) else offset
    kw["units"] = attrs.get("units")
    values = da.values
    if flip:
        values = values[::-1]
    return values, kw


# --- rasterio ---------------------------------------------------------------------------------

def _from_rasterio(src, band, what, has_units):
    if not 1 <= band <= src.count:
        raise ValueError("%s: band=%d, the dataset has %d band%s" % (what, band, src.count, "" if src.count == 1 else "s"))
    arr = src.read(band, masked=True)  # masked by nodata and the dataset's mask band
    if not src.crs and not has_units:
        raise ValueError("%s: %s has no CRS, so the units of its transform are unknown; give crs= or cell_size= "
                         "in metres" % (what, getattr(src, "name", "the dataset")))
    scale, offset = src.scales[band - 1], src.offsets[band - 1]
    kw = dict(transform=src.transform, crs=src.crs if src.crs else None, nodata=None,
              scale=None if scale == 1.0 else scale, offset=None if offset == 0.0 else offset,
              units=src.units[band - 1] or None)
    return arr, kw, src.nodatavals[band - 1]


# --- the one entry point ----------------------------------------------------------------------

def as_heightfield(value, *, georef=None, cell_size=None, transform=None, crs=None, nodata=None, band=1,
                   what="Heightfield", into=None):
    """`value` (an ndarray, a masked array, an xarray DataArray, a rasterio dataset) as a terracl.Heightfield
    with its georeferencing; arguments given override what the source says. `into`: a Heightfield
    being constructed (its __init__)."""
    scale = offset = units = None
    geotransform = None
    source_nodata = nodata
    any_numeric = False
    if _is_xarray(value) or _is_rasterio_dataset(value):
        if _is_xarray(value):
            values, kw = _from_xarray(value, what)
            found_nodata = kw["nodata"]
        else:
            values, kw, found_nodata = _from_rasterio(value, band, what, crs is not None or cell_size is not None
                                                      or georef is not None)
            any_numeric = True
        if georef is None:
            if transform is None:
                transform, geotransform = kw.get("transform"), kw.get("geotransform")
            if crs is None:
                crs = kw.get("crs")
            if cell_size is None and crs is None:
                cell_size = kw.get("cell_size")
        if nodata is None:
            nodata = kw["nodata"]
            source_nodata = found_nodata
        scale, offset, units = kw["scale"], kw["offset"], kw["units"]
    else:
        values = value
    factor, vunits = _vertical_factor(units, what + ": units")
    z = float32_with_nan(values, nodata, scale, offset, factor, any_numeric)
    if georef is not None:
        if transform is not None or crs is not None:
            raise ValueError("%s: give georef= or transform=/crs=, not both" % what)
        g = georef
    elif transform is not None or geotransform is not None or crs is not None or cell_size is not None:
        g = make_georef(transform=transform, geotransform=geotransform, crs=crs, cell_size=cell_size,
                        nodata=source_nodata, vertical_units=vunits, what=what)
        cell_size = None  # in the georef
    else:
        g = None
    h = into if into is not None else _terracl.Heightfield.__new__(_terracl.Heightfield)
    _CPP_HEIGHTFIELD_INIT(h, z, g, cell_size)  # checks the array (dtype, dimensions, size, memory)
    if g is None and cell_size is None:
        raise ValueError(_NO_CELL.format(what=what))
    if g is not None and cell_size is None and g.geotransform is not None and not g.geographic and g.crs_wkt:
        # The library measures projected cells in map units; a CRS in feet needs its factor.
        info = crs_info(g.crs_wkt, "crs")
        if info.metres_per_unit not in (None, 1.0):
            h.cell_size = _metric_cell(g.geotransform, info)
    if nodata is not None and h.georef.nodata is None:
        h.georef.nodata = float(nodata)
    return h


_CPP_HEIGHTFIELD_INIT = None  # set by terracl/__init__.py: the C++ constructors
_CPP_GEOREF_INIT = None


# --- results ----------------------------------------------------------------------------------

def profile_of(h):
    """rasterio's profile for writing h.z: rasterio.open(path, "w", **h.profile).write(h.z, 1)."""
    gt = h.georef.geotransform
    return {"driver": "GTiff", "dtype": "float32", "count": 1, "width": h.width, "height": h.height,
            "transform": transform_of(gt if gt is not None else (0.0, h.cell_size[0], 0.0, 0.0, 0.0, -h.cell_size[1])),
            "crs": crs_of(h.georef.crs_wkt), "nodata": float("nan")}


def to_xarray(h, name=None):
    """h as an xarray.DataArray (dims y, x; coordinates at cell centres in map units; attrs crs as WKT,
    transform in Affine's order as rioxarray stores it, units). Without a geotransform the
    coordinates are metres from the top-left corner, y negative downwards (north up)."""
    import xarray as xr
    gt = h.georef.geotransform
    if gt is None:
        cx, cy = h.cell_size
        gt = (0.0, cx, 0.0, 0.0, 0.0, -cy)
        coord_attrs = {"units": "m"}
    else:
        coord_attrs = {}
        if gt[2] != 0 or gt[4] != 0:
            raise ValueError("to_xarray: a rotated transform %s has no 1-D x/y coordinates" % (tuple(gt),))
    x = gt[0] + gt[1] * (np.arange(h.width) + 0.5)
    y = gt[3] + gt[5] * (np.arange(h.height) + 0.5)
    attrs = {"units": h.georef.vertical_units or "m",
             "transform": (gt[1], gt[2], gt[0], gt[4], gt[5], gt[3]),
             "cell_size": tuple(h.cell_size)}
    if h.georef.crs_wkt:
        attrs["crs"] = h.georef.crs_wkt
    return xr.DataArray(np.array(h.z, copy=True), dims=("y", "x"),
                        coords={"y": ("y", y, dict(coord_attrs)), "x": ("x", x, dict(coord_attrs))},
                        name=name, attrs=attrs)


def from_rasterio(source, band=1):
    """A Heightfield from a rasterio dataset or a file name rasterio opens."""
    if isinstance(source, (str, os.PathLike)):
        import rasterio
        path = os.fspath(source)
        if "://" not in path and not path.startswith("/vsi") and not os.path.exists(path):
            raise FileNotFoundError(errno.ENOENT, "from_rasterio: no such file", path)
        with rasterio.open(source) as src:
            return as_heightfield(src, band=band, what="from_rasterio")
    if not _is_rasterio_dataset(source):
        raise TypeError("from_rasterio: expected a rasterio dataset or a file name, got %s" % _type_name(source))
    return as_heightfield(source, band=band, what="from_rasterio")
