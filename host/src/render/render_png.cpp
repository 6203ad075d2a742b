// SPDX-License-Identifier: Apache-2.0
// Picture output: PNG through libpng, GeoTIFF through GDAL. The only part of rendering that
// needs an image library, kept apart so the core build (TERRACL_CORE_ONLY) renders to arrays
// without them.
#include <gdal_priv.h>

#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/render.hpp>

#include "io/checked_output.hpp"
#include "io/gdal_common.hpp"
#include "io/image_file.hpp"
#include "io/png_codec.hpp"
#include "render/picture_writer.hpp"

namespace terracl::render {

namespace {

std::string gdal_error() {
  const char* m = CPLGetLastErrorMsg();
  return m && *m ? m : "no GDAL message";
}

}  // namespace

struct PictureWriter::Impl {
  std::string path, tmp;
  int width = 0, height = 0, channels = 0, next_row = 0;
  std::unique_ptr<io::CheckedImageFile> png_file;  // declared first: outlives the writer using it
  std::unique_ptr<io::png::Writer> png;
  GDALDataset* tif = nullptr;
  ~Impl() {
    if (tif) GDALClose(tif);
  }
};

PictureWriter::PictureWriter(const std::string& path, const std::string& tmp, int width, int height, int channels,
                             const Georef& g, const Metadata& meta)
    : m(std::make_unique<Impl>()) {
  m->path = path;
  m->tmp = tmp;
  m->width = width;
  m->height = height;
  m->channels = channels;
  if (format_from_extension(path) == FileFormat::PNG) {
    // Our alpha only marks nodata (0 or 255): the colours are stored as they are (unassociated).
    io::png::TextChunks text{{"Software", "terracl"}};
    for (const auto& [k, v] : meta) text.emplace_back(k, v);
    m->png_file = std::make_unique<io::CheckedImageFile>(tmp);
    m->png = std::make_unique<io::png::Writer>(*m->png_file, width, height, channels, 8, text, false, "render");
    return;
  }
  // Like gdaldem's output: uncompressed, striped, the input's geotransform and CRS; bands
  // interleaved by pixel, alpha declared as unassociated ExtraSamples.
  GDALAllRegister();
  CPLErrorReset();
  GDALDriver* drv = GetGDALDriverManager()->GetDriverByName("GTiff");
  if (!drv) fail("render", "cannot write {}: GDAL has no GTiff driver", path);
  const bool alpha = channels == 2 || channels == 4;
  char** opts = nullptr;
  opts = CSLSetNameValue(opts, "INTERLEAVE", "PIXEL");
  opts = CSLSetNameValue(opts, "BIGTIFF", "IF_SAFER");
  opts = CSLSetNameValue(opts, "PHOTOMETRIC", channels >= 3 ? "RGB" : "MINISBLACK");
  if (alpha) opts = CSLSetNameValue(opts, "ALPHA", "YES");  // unassociated (ExtraSamples = 2)
  m->tif = drv->Create(tmp.c_str(), width, height, channels, GDT_Byte, opts);
  CSLDestroy(opts);
  if (!m->tif) fail("render", "cannot create {} ({})", path, io::name_output(gdal_error(), tmp));
  if (g.has_geotransform) {
    double gt[6];
    std::copy(g.geotransform.begin(), g.geotransform.end(), gt);
    m->tif->SetGeoTransform(gt);
  }
  if (!g.crs_wkt.empty()) m->tif->SetProjection(g.crs_wkt.c_str());
  if (alpha) m->tif->GetRasterBand(channels)->SetColorInterpretation(GCI_AlphaBand);
  for (const auto& [k, v] : meta) {
    std::string key = k;
    for (char& c : key)
      if (c == ':') c = '_';  // GDAL would split "terracl:x" at the colon
    m->tif->SetMetadataItem(key.c_str(), v.c_str());
  }
  m->tif->SetMetadataItem("TIFFTAG_SOFTWARE", "terracl");
}

PictureWriter::~PictureWriter() = default;

void PictureWriter::write_rows(int y0, int rows, const uint8_t* px) {
  if (y0 != m->next_row || rows < 0 || y0 + rows > m->height)
    fail("render", "{}: rows {}..{} written out of order", m->path, y0, y0 + rows);
  if (rows == 0) return;
  m->next_row += rows;
  if (m->png) {
    m->png->write_rows(px, rows);
    return;
  }
  const int n = m->channels;
  io::GdalFirstError first;
  CPLErrorReset();
  if (m->tif->RasterIO(GF_Write, 0, y0, m->width, rows, const_cast<uint8_t*>(px), m->width, rows, GDT_Byte, n,
                       nullptr, n, GSpacing(n) * m->width, 1, nullptr) != CE_None)
    fail("render", "writing {} failed ({})", m->path, io::name_output(first.message(), m->tmp));
  // Written strips leave GDAL's block cache now: a streamed render holds one strip, not the picture.
  m->tif->FlushCache();
  if (CPLGetLastErrorType() >= CE_Failure)  // a full disk shows here, not at close
    fail("render", "writing {} failed ({})", m->path, io::name_output(first.message(), m->tmp));
}

void PictureWriter::close() {
  if (m->next_row != m->height) fail("render", "{}: only {} of {} rows written", m->path, m->next_row, m->height);
  if (m->png) {
    m->png->finish();
    m->png.reset();
    m->png_file->finish("render");
    m->png_file.reset();
    return;
  }
  GDALDataset* raw = m->tif;
  m->tif = nullptr;
  io::GdalFirstError first;
  CPLErrorReset();
  GDALClose(raw);
  if (CPLGetLastErrorType() >= CE_Failure)
    fail("render", "writing {} failed ({})", m->path, io::name_output(first.message(), m->tmp));
}

void write_image(const Image& img, const std::string& path, const Metadata& meta) {
  if (img.channels < 1 || img.channels > 4 || img.pixels.size() != size_t(img.width) * img.height * img.channels)
    fail("render", "inconsistent image buffer");
  const FileFormat f = format_from_extension(path);
  if (f != FileFormat::PNG && f != FileFormat::GeoTIFF)  // no JPEG for x.jpg
    fail("render", "{}: pictures are written as PNG or GeoTIFF; use a .png or .tif name", path);
  write_atomically(path, [&](const std::string& tmp) {
    PictureWriter w(path, tmp, img.width, img.height, img.channels, img.georef, meta);
    w.write_rows(0, img.height, img.pixels.data());
    w.close();
  });
}

}  // namespace terracl::render
