// SPDX-License-Identifier: Apache-2.0
#pragma once
// GDAL helpers shared by the GeoTIFF reader/writer (gdal_io.cpp) and warp/resize (warp.cpp).
// Private to host/src/io; like them, left out of the core build.
#include <terracl/heightfield.hpp>
#include <terracl/io.hpp>

#include <gdal_priv.h>

#include <memory>
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

/// A one-band in-memory (MEM driver) copy of `h` with its geotransform, CRS and metadata. NaN
/// cells keep NaN and the band's nodata is NaN (`nodata_value` when given: cells are written with
/// it), so GDAL's warper and writers see which cells are missing. `type` is a GDAL band type.
DatasetPtr to_mem_dataset(const Heightfield& h, GDALDataType type = GDT_Float32);
/// Band 1 of `ds` as a heightfield (nodata cells NaN, georef and terracl_* metadata kept);
/// `path` names the source in error messages.
Heightfield from_dataset(GDALDataset& ds, const std::string& path);

}  // namespace terracl::io
