// SPDX-License-Identifier: Apache-2.0
#pragma once
// GDAL helpers shared by the GeoTIFF reader/writer (gdal_io.cpp) and warp/resize (warp.cpp).
// Private to host/src/io; like them, left out of the core build.
#include <terracl/heightfield.hpp>
#include <terracl/io.hpp>

#include <gdal_priv.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <optional>
#include <string>

namespace terracl::io {

/// Registers the drivers and silences GDAL's stderr printing (errors are passed on in our messages).
void init_gdal();
/// CPLGetLastErrorMsg(), or "no details from GDAL".
std::string last_gdal_error();

/// Collects GDAL's first failure message while it lives (a handler pushed on this thread). After a
/// failed write GDAL's last message is often a consequence ("not a TIFF" when it reads back what
/// it could not write, "FillEmptyTiles() failed"); the first one says what went wrong.
class GdalFirstError {
 public:
  GdalFirstError();
  ~GdalFirstError();
  GdalFirstError(const GdalFirstError&) = delete;
  GdalFirstError& operator=(const GdalFirstError&) = delete;
  /// The first failure seen, else last_gdal_error().
  std::string message() const;

 private:
  static void CPL_STDCALL handle(CPLErr e, CPLErrorNum, const char* m);
  std::string m_first;
};

struct DatasetCloser {
  void operator()(GDALDataset* d) const { GDALClose(d); }
};
using DatasetPtr = std::unique_ptr<GDALDataset, DatasetCloser>;

/// Metres per unit of a band's unit type (ft, US survey foot, cm, mm, dm; 1 for metres); nullopt
/// for units terracl does not convert.
std::optional<double> metres_per_unit(const std::string& units);

/// The vertical unit GDAL outputs of `g`/`md` are written in: a raster read from a band in feet
/// (or cm, ...) holds metres in memory (terracl:source_vertical_units names the unit it came in),
/// and its lengths (elevations, TRI, TPI, roughness, depths: vertical_units "m") go back out in
/// that unit, as gdal_translate and gdaldem would keep them. nullopt: written as they are.
struct WrittenUnit {
  double metres_per_unit;  ///< written value = metres / metres_per_unit
  std::string name;        ///< the band's unit type on write (the source's own spelling)
};
std::optional<WrittenUnit> written_vertical_unit(const Georef& g, const Metadata& md);
/// `metres` in a unit of `metres_per_unit` m, chosen among the floats the reader (float(u *
/// metres_per_unit)) maps back to `metres`: the one with the shortest mantissa, so that a value read
/// in feet (1000 ft and its float neighbours all read as 304.8 m) is written as the value it was.
inline float from_metres(float metres, double metres_per_unit) {
  const float u = float(double(metres) / metres_per_unit);
  if (!std::isfinite(u)) return u;
  auto zeros = [](float f) {  // trailing zero bits of the mantissa: more is a shorter number
    uint32_t b;
    std::memcpy(&b, &f, 4);
    b &= 0x7fffffu;
    return b == 0 ? 32 : __builtin_ctz(b);
  };
  float best = u;
  bool found = float(double(u) * metres_per_unit) == metres;
  for (const float n : {std::nextafter(u, -INFINITY), std::nextafter(u, INFINITY)})
    if (float(double(n) * metres_per_unit) == metres && (!found || zeros(n) > zeros(best))) best = n, found = true;
  return best;
}

/// A one-band in-memory (MEM driver) copy of `h` with its geotransform, CRS and metadata. NaN
/// cells keep NaN and the band's nodata is NaN (`nodata_value` when given: cells are written with
/// it), so GDAL's warper and writers see which cells are missing. `type` is a GDAL band type.
/// `source_units`: lengths in the unit they were read in (written_vertical_unit), for outputs.
DatasetPtr to_mem_dataset(const Heightfield& h, GDALDataType type = GDT_Float32, bool source_units = false);
/// Band 1 of `ds` as a heightfield (nodata cells NaN, georef and terracl_* metadata kept);
/// `path` names the source in error messages.
Heightfield from_dataset(GDALDataset& ds, const std::string& path);

}  // namespace terracl::io
