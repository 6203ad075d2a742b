// SPDX-License-Identifier: Apache-2.0
// Heightfield, GradientField and Georef <-> numpy.
//
// Direction of copies: library -> numpy is zero-copy (`Heightfield.z`, `GradientField.gx/gy` are
// float32 views of the library's own vectors that keep the object alive); numpy -> library copies
// once (the library owns its rasters as std::vector<float>), honouring any strides, so a
// non-contiguous or Fortran-ordered array is accepted and copied row by row.
#include "common.hpp"

#include <terracl/memory.hpp>

#include <fmt/format.h>

#include <cstdlib>
#include <cstring>

namespace terracl::python {

void copy_from_array(py::handle obj, const std::string& what, int& width, int& height, std::vector<float>& out) {
  if (!py::isinstance<py::array>(obj))
    throw py::type_error(fmt::format("{}: expected a 2-D numpy float32 array, got {}", what,
                                     py::str(obj.get_type().attr("__name__")).cast<std::string>()));
  py::array a = py::reinterpret_borrow<py::array>(obj);
  if (!a.dtype().is(py::dtype::of<float>()))
    throw py::type_error(fmt::format("{}: expected dtype float32, got {} (convert with a.astype(numpy.float32))", what,
                                     py::str(a.dtype()).cast<std::string>()));
  if (a.ndim() != 2)
    throw py::value_error(fmt::format("{}: expected a 2-D array (rows, columns), got {} dimension{}", what, a.ndim(),
                                      a.ndim() == 1 ? "" : "s"));
  const py::ssize_t h = a.shape(0), w = a.shape(1);
  if (w < 1 || h < 1) throw py::value_error(fmt::format("{}: the array is empty ({} x {})", what, h, w));
  if (w > 65536 || h > 65536)
    throw py::value_error(fmt::format("{}: {} x {} is larger than 65536 cells a side", what, h, w));
  // The CLI's memory rule (terracl/memory.hpp) before the copy: a 65536^2 array wanted 16 GiB unasked.
  const double bytes = double(w) * double(h) * sizeof(float), limit = double(host_memory_limit());
  if (bytes > limit) {
    PyErr_SetString(PyExc_MemoryError,
                    fmt::format("{}: copying the {} x {} array needs {}, and {} is available{}; use a smaller array",
                                what, h, w, human_bytes(bytes), human_bytes(limit),
                                std::getenv("TERRACL_MAX_MEMORY") ? " (TERRACL_MAX_MEMORY)" : "")
                        .c_str());
    throw py::error_already_set();
  }
  width = int(w);
  height = int(h);
  out.resize(size_t(w) * size_t(h));
  const auto* base = static_cast<const char*>(a.data());
  const py::ssize_t sy = a.strides(0), sx = a.strides(1);
  for (py::ssize_t y = 0; y < h; ++y) {
    const char* row = base + y * sy;
    float* dst = out.data() + size_t(y) * size_t(w);
    if (sx == py::ssize_t(sizeof(float))) {
      std::memcpy(dst, row, size_t(w) * sizeof(float));
    } else {
      for (py::ssize_t x = 0; x < w; ++x) std::memcpy(dst + x, row + x * sx, sizeof(float));
    }
  }
}

py::array_t<float> view_of(std::vector<float>& data, int width, int height, py::handle owner) {
  return py::array_t<float>({py::ssize_t(height), py::ssize_t(width)},
                            {py::ssize_t(width) * py::ssize_t(sizeof(float)), py::ssize_t(sizeof(float))}, data.data(),
                            owner);
}

Heightfield to_heightfield(py::handle v, const std::string& what) {
  if (py::isinstance<Heightfield>(v)) return v.cast<const Heightfield&>();
  Heightfield h;
  copy_from_array(v, what, h.width, h.height, h.z);
  return h;
}

namespace {

// Assigning a whole raster (h.z = array) copies into the existing vector, so views already handed
// out stay valid; a different shape is refused rather than reallocating under them.
void assign(std::vector<float>& dst, int width, int height, py::handle src, const std::string& what) {
  int w = 0, h = 0;
  std::vector<float> tmp;
  copy_from_array(src, what, w, h, tmp);
  if (w != width || h != height)
    throw py::value_error(fmt::format("{}: shape ({}, {}) differs from the raster's ({}, {})", what, h, w, height, width));
  std::memcpy(dst.data(), tmp.data(), tmp.size() * sizeof(float));
}

void apply_cell_size(Georef& g, py::handle cell_size, int width, int height) {
  if (!cell_size.is_none()) {
    if (py::isinstance<py::tuple>(cell_size) || py::isinstance<py::list>(cell_size)) {
      auto t = cell_size.cast<std::vector<double>>();
      if (t.size() != 2) throw py::value_error("cell_size: expected a number or (cell_x, cell_y)");
      g.cell_x = t[0], g.cell_y = t[1];
    } else {
      g.cell_x = g.cell_y = cell_size.cast<double>();
    }
    if (!(g.cell_x > 0) || !(g.cell_y > 0) || !std::isfinite(g.cell_x) || !std::isfinite(g.cell_y))
      throw py::value_error(fmt::format("cell_size: expected positive finite metres, got ({}, {})", g.cell_x, g.cell_y));
  } else if (g.has_geotransform) {
    g.update_metric_cell_size(width, height);
  }
}

}  // namespace

void init_arrays(py::module_& m) {
  py::class_<Georef>(m, "Georef",
                     "Georeferencing (GDAL conventions): geotransform, CRS as WKT, metric cell size in metres, "
                     "the source file's nodata value (nodata cells are NaN in memory).")
      .def(py::init([](py::object geotransform, std::string crs_wkt, bool geographic, py::object nodata,
                       std::string vertical_units, py::object cell_size) {
             Georef g;
             if (!geotransform.is_none()) {
               auto gt = geotransform.cast<std::vector<double>>();
               if (gt.size() != 6) throw py::value_error("geotransform: expected 6 numbers (GDAL's order)");
               std::copy(gt.begin(), gt.end(), g.geotransform.begin());
               g.has_geotransform = true;
               g.cell_x = std::hypot(gt[1], gt[4]);
               g.cell_y = std::hypot(gt[2], gt[5]);
             }
             g.crs_wkt = std::move(crs_wkt);
             g.geographic = geographic;
             if (!nodata.is_none()) g.nodata = nodata.cast<double>();
             g.vertical_units = std::move(vertical_units);
             apply_cell_size(g, cell_size, 1, 1);
             return g;
           }),
           py::kw_only(), py::arg("geotransform") = py::none(), py::arg("crs_wkt") = "", py::arg("geographic") = false,
           py::arg("nodata") = py::none(), py::arg("vertical_units") = "m", py::arg("cell_size") = py::none())
      .def_property(
          "geotransform",
          [](const Georef& g) {
            return g.has_geotransform ? py::object(py::cast(std::vector<double>(g.geotransform.begin(), g.geotransform.end())))
                                      : py::object(py::none());
          },
          [](Georef& g, py::object v) {
            if (v.is_none()) {
              g.has_geotransform = false;
              return;
            }
            auto gt = v.cast<std::vector<double>>();
            if (gt.size() != 6) throw py::value_error("geotransform: expected 6 numbers (GDAL's order)");
            std::copy(gt.begin(), gt.end(), g.geotransform.begin());
            g.has_geotransform = true;
          },
          "GDAL geotransform (6 numbers) or None")
      .def_readwrite("crs_wkt", &Georef::crs_wkt, "CRS as WKT ('' when unknown)")
      .def_readwrite("geographic", &Georef::geographic, "CRS units are degrees")
      .def_readwrite("nodata", &Georef::nodata, "nodata value of the source file (cells are NaN in memory)")
      .def_readwrite("vertical_units", &Georef::vertical_units)
      .def_readwrite("cell_x", &Georef::cell_x, "metric cell size along a row (m)")
      .def_readwrite("cell_y", &Georef::cell_y, "metric cell size along a column (m)")
      .def_property(
          "cell_size", [](const Georef& g) { return py::make_tuple(g.cell_x, g.cell_y); },
          [](Georef& g, py::object v) { apply_cell_size(g, v, 1, 1); }, "(cell_x, cell_y) in metres")
      .def("__repr__", [](const Georef& g) {
        return fmt::format("terracl.Georef(cell_size=({}, {}), geotransform={}, crs={}, nodata={})", g.cell_x, g.cell_y,
                           g.has_geotransform ? fmt::format("({})", fmt::join(g.geotransform, ", ")) : "None",
                           g.crs_wkt.empty() ? "None" : "'" + g.crs_wkt.substr(0, 40) + (g.crs_wkt.size() > 40 ? "...'" : "'"),
                           g.nodata ? fmt::format("{}", *g.nodata) : "None");
      });

  py::class_<Heightfield>(m, "Heightfield",
                          "Float32 elevations in metres, row 0 at the top (north), NaN for nodata, with georeferencing.\n"
                          "Heightfield(array, georef=None, cell_size=None) copies a 2-D float32 array; .z is a "
                          "zero-copy view (writes go to the heightfield).")
      .def(py::init([](py::handle array, std::optional<Georef> georef, py::object cell_size) {
             Heightfield h;
             copy_from_array(array, "Heightfield", h.width, h.height, h.z);
             if (georef) h.georef = *georef;
             apply_cell_size(h.georef, cell_size, h.width, h.height);
             return h;
           }),
           py::arg("array"), py::arg("georef") = py::none(), py::arg("cell_size") = py::none())
      .def_readonly("width", &Heightfield::width)
      .def_readonly("height", &Heightfield::height)
      .def_property_readonly("shape", [](const Heightfield& h) { return py::make_tuple(h.height, h.width); })
      .def_property(
          "z", [](py::object self) {
            Heightfield& h = self.cast<Heightfield&>();
            return view_of(h.z, h.width, h.height, self);
          },
          [](Heightfield& h, py::handle a) { assign(h.z, h.width, h.height, a, "Heightfield.z"); },
          "elevations as a (height, width) float32 numpy view (zero copy)")
      .def("__array__",
           [](py::object self, py::object dtype) {
             Heightfield& h = self.cast<Heightfield&>();
             py::array v = view_of(h.z, h.width, h.height, self);
             return dtype.is_none() ? v : py::array(v.attr("astype")(dtype));
           },
           py::arg("dtype") = py::none())
      .def_property(
          "georef", [](Heightfield& h) -> Georef& { return h.georef; },
          [](Heightfield& h, const Georef& g) { h.georef = g; }, py::return_value_policy::reference_internal)
      .def_readwrite("metadata", &Heightfield::metadata, "key/value provenance carried to outputs (a copy)")
      .def_property(
          "cell_size", [](const Heightfield& h) { return py::make_tuple(h.georef.cell_x, h.georef.cell_y); },
          [](Heightfield& h, py::object v) { apply_cell_size(h.georef, v, h.width, h.height); })
      .def("count_nodata", &Heightfield::count_nodata)
      .def("copy", [](const Heightfield& h) { return Heightfield(h); })
      .def("__repr__", [](const Heightfield& h) {
        return fmt::format("terracl.Heightfield({} x {}, cell {} x {} m)", h.width, h.height, h.georef.cell_x, h.georef.cell_y);
      });

  py::class_<GradientField>(m, "GradientField",
                            "Gradient in m/m on the staggered grid (gx: forward difference along rows, 0 in the last "
                            "column; gy: along columns, 0 in the last row). GradientField(gx, gy, georef=None, "
                            "cell_size=None, mean_elevation=nan) copies; .gx/.gy are zero-copy views.")
      .def(py::init([](py::handle gx, py::handle gy, std::optional<Georef> georef, py::object cell_size,
                       double mean_elevation) {
             GradientField g;
             int w2 = 0, h2 = 0;
             copy_from_array(gx, "GradientField gx", g.width, g.height, g.gx);
             copy_from_array(gy, "GradientField gy", w2, h2, g.gy);
             if (w2 != g.width || h2 != g.height)
               throw py::value_error(fmt::format("GradientField: gx is ({}, {}) but gy is ({}, {})", g.height, g.width, h2, w2));
             if (georef) g.georef = *georef;
             apply_cell_size(g.georef, cell_size, g.width, g.height);
             g.mean_elevation = mean_elevation;
             return g;
           }),
           py::arg("gx"), py::arg("gy"), py::arg("georef") = py::none(), py::arg("cell_size") = py::none(),
           py::arg("mean_elevation") = std::numeric_limits<double>::quiet_NaN())
      .def_readonly("width", &GradientField::width)
      .def_readonly("height", &GradientField::height)
      .def_property_readonly("shape", [](const GradientField& g) { return py::make_tuple(g.height, g.width); })
      .def_property(
          "gx", [](py::object self) {
            GradientField& g = self.cast<GradientField&>();
            return view_of(g.gx, g.width, g.height, self);
          },
          [](GradientField& g, py::handle a) { assign(g.gx, g.width, g.height, a, "GradientField.gx"); })
      .def_property(
          "gy", [](py::object self) {
            GradientField& g = self.cast<GradientField&>();
            return view_of(g.gy, g.width, g.height, self);
          },
          [](GradientField& g, py::handle a) { assign(g.gy, g.width, g.height, a, "GradientField.gy"); })
      .def_property(
          "georef", [](GradientField& g) -> Georef& { return g.georef; },
          [](GradientField& g, const Georef& r) { g.georef = r; }, py::return_value_policy::reference_internal)
      .def_readwrite("metadata", &GradientField::metadata)
      .def_readwrite("mean_elevation", &GradientField::mean_elevation, "mean elevation of the source (NaN: unknown)")
      .def_property(
          "cell_size", [](const GradientField& g) { return py::make_tuple(g.georef.cell_x, g.georef.cell_y); },
          [](GradientField& g, py::object v) { apply_cell_size(g.georef, v, g.width, g.height); })
      .def("copy", [](const GradientField& g) { return GradientField(g); })
      .def("__repr__", [](const GradientField& g) {
        return fmt::format("terracl.GradientField({} x {}, cell {} x {} m)", g.width, g.height, g.georef.cell_x, g.georef.cell_y);
      });
}

}  // namespace terracl::python
