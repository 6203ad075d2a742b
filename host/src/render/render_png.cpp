// Picture output: PNG through OpenImageIO, GeoTIFF through GDAL. The only part of rendering that
// needs an image library, kept apart so the core build (TERRACL_CORE_ONLY) renders to arrays
// without them.
#include <OpenImageIO/imageio.h>
#include <gdal_priv.h>

#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/render.hpp>

namespace terracl::render {

namespace {

void write_png(const Image& img, const std::string& path, const std::string& tmp, const Metadata& meta) {
  auto out = OIIO::ImageOutput::create(tmp);
  if (!out) fail("render", "cannot write {}: {}", path, OIIO::geterror());
  OIIO::ImageSpec spec(img.width, img.height, img.channels, OIIO::TypeDesc::UINT8);
  if (img.channels == 2) {
    spec.channelnames = {"Y", "A"};
    spec.alpha_channel = 1;
  }
  // Our alpha only marks nodata (0 or 255): keep the colours as they are (no un-premultiply).
  spec.attribute("oiio:UnassociatedAlpha", 1);
  spec.attribute("Software", "terracl");
  for (const auto& [k, v] : meta) spec.attribute(k, v);  // PNG text chunks
  if (!out->open(tmp, spec)) fail("render", "cannot write {}: {}", path, out->geterror());
  if (!out->write_image(OIIO::TypeDesc::UINT8, img.pixels.data()))
    fail("render", "cannot write {}: {}", path, out->geterror());
  if (!out->close()) fail("render", "cannot write {}: {}", path, out->geterror());
}

std::string gdal_error() {
  const char* m = CPLGetLastErrorMsg();
  return m && *m ? m : "no GDAL message";
}

// Like gdaldem's output: uncompressed, striped, the input's geotransform and CRS; bands
// interleaved by pixel (one write), alpha declared as unassociated ExtraSamples.
void write_geotiff_picture(const Image& img, const std::string& path, const std::string& tmp, const Metadata& meta) {
  GDALAllRegister();
  CPLErrorReset();
  GDALDriver* drv = GetGDALDriverManager()->GetDriverByName("GTiff");
  if (!drv) fail("render", "cannot write {}: GDAL has no GTiff driver", path);
  const bool alpha = img.channels == 2 || img.channels == 4;
  char** opts = nullptr;
  opts = CSLSetNameValue(opts, "INTERLEAVE", "PIXEL");
  opts = CSLSetNameValue(opts, "BIGTIFF", "IF_SAFER");
  opts = CSLSetNameValue(opts, "PHOTOMETRIC", img.channels >= 3 ? "RGB" : "MINISBLACK");
  if (alpha) opts = CSLSetNameValue(opts, "ALPHA", "YES");  // unassociated (ExtraSamples = 2)
  std::unique_ptr<GDALDataset> ds(drv->Create(tmp.c_str(), img.width, img.height, img.channels, GDT_Byte, opts));
  CSLDestroy(opts);
  if (!ds) fail("render", "cannot create {} ({})", path, gdal_error());
  const Georef& g = img.georef;
  if (g.has_geotransform) {
    double gt[6];
    std::copy(g.geotransform.begin(), g.geotransform.end(), gt);
    ds->SetGeoTransform(gt);
  }
  if (!g.crs_wkt.empty()) ds->SetProjection(g.crs_wkt.c_str());
  if (alpha) ds->GetRasterBand(img.channels)->SetColorInterpretation(GCI_AlphaBand);
  for (const auto& [k, v] : meta) {
    std::string key = k;
    for (char& c : key)
      if (c == ':') c = '_';  // GDAL would split "terracl:x" at the colon
    ds->SetMetadataItem(key.c_str(), v.c_str());
  }
  ds->SetMetadataItem("TIFFTAG_SOFTWARE", "terracl");
  const int n = img.channels;
  if (ds->RasterIO(GF_Write, 0, 0, img.width, img.height, const_cast<uint8_t*>(img.pixels.data()), img.width,
                   img.height, GDT_Byte, n, nullptr, n, GSpacing(n) * img.width, 1, nullptr) != CE_None)
    fail("render", "writing {} failed ({})", path, gdal_error());
  GDALDataset* raw = ds.release();
  CPLErrorReset();
  GDALClose(raw);
  if (CPLGetLastErrorType() >= CE_Failure) fail("render", "finishing {} failed ({})", path, gdal_error());
}

}  // namespace

void write_image(const Image& img, const std::string& path, const Metadata& meta) {
  if (img.channels < 1 || img.channels > 4 || img.pixels.size() != size_t(img.width) * img.height * img.channels)
    fail("render", "inconsistent image buffer");
  const FileFormat f = format_from_extension(path);
  if (f != FileFormat::PNG && f != FileFormat::GeoTIFF)  // OIIO would write a JPEG for x.jpg
    fail("render", "{}: pictures are written as PNG or GeoTIFF; use a .png or .tif name", path);
  write_atomically(path, [&](const std::string& tmp) {
    if (f == FileFormat::PNG)
      write_png(img, path, tmp, meta);
    else
      write_geotiff_picture(img, path, tmp, meta);
  });
}

}  // namespace terracl::render
