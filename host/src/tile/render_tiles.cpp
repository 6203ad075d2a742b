// SPDX-License-Identifier: Apache-2.0
// The tiled `render` stage. Every product of render is a function of gdaldem's 3x3 window (halo 1)
// except two things that depend on the whole raster: whether a picture has an alpha band (any
// nodata cell in the raster, or gdaldem's nodata border) and a colour ramp given in percentages of
// the data range. The first is settled at the end (the picture is built with an alpha band and
// copied without it when the raster had no nodata); the second is refused (render_tiling_limit).
#include <fmt/format.h>
#include <gdal_utils.h>

#include <cmath>
#include <cstring>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/render.hpp>

#include "io/gdal_common.hpp"
#include "io/gdal_window.hpp"
#include "pipeline/builtin.hpp"
#include "render/render_internal.hpp"
#include "tile/tile_sinks.hpp"

namespace terracl::tile {
namespace {

render::Options options_of(const PipelineStage& st) {
  StageData none;
  const StageContext c{none, st.options, nullptr, Progress{}, st.tag, {}};
  return render_stage_options(c);
}

bool grey_picture(render::Mode m) { return m == render::Mode::Hillshade || m == render::Mode::Slope; }

// Value rasters (slope, aspect, tri, tpi, roughness): gdaldem's float32 products.
class RenderValuesSink : public TileSink {
 public:
  RenderValuesSink(const PipelineStage& st, int w, int h, const Georef& level, const Metadata& md,
                   std::function<Device&()> device, bool open)
      : m_opt(options_of(st)),
        m_host(st.options.at("backend").get<std::string>() == "host"),
        m_device(device),
        m_w(w),
        m_h(h) {
    Georef g = level;
    g.nodata = -9999.0;  // as render::values
    g.vertical_units = render::value_raster_like(Heightfield(1, 1), m_opt).georef.vertical_units;
    m_metres_per_unit = io::written_metres_per_unit(g, md);  // TRI in feet from a DEM in feet, as untiled
    if (open)
      m_writer = std::make_unique<io::GeoTiffWindowWriter>(st.options.at("file").get<std::string>(), w, h, g, md,
                                                           std::string(), 1, m_opt.compress);
  }
  std::vector<uint8_t> draw(const Heightfield& win, int wx, int wy, int cx, int cy, int cw, int ch) override {
    const Heightfield v = m_host ? render::values(win, m_opt) : render::values(win, m_opt, m_device());
    // Compressed by the rank that drew it: rank 0 only appends the blocks.
    return io::GeoTiffWindowWriter::encode(m_w, m_h, -9999.0, cx, cy, v, cx - wx, cy - wy, cw, ch, m_opt.compress,
                                           m_metres_per_unit);
  }
  void put(const std::vector<uint8_t>& drawn, int, int, int, int) override { m_writer->put(drawn); }
  void commit() override { m_writer->commit(); }

 private:
  render::Options m_opt;
  bool m_host;
  std::function<Device&()> m_device;
  int m_w, m_h;
  std::unique_ptr<io::GeoTiffWindowWriter> m_writer;
  double m_metres_per_unit = 1.0;
};

// Pictures: 8-bit grey or RGB, always built with an alpha band; commit() drops it when the untiled
// render would have none.
class RenderPictureSink : public TileSink {
 public:
  RenderPictureSink(const PipelineStage& st, int w, int h, const Georef& level, const Metadata& provenance,
                    std::function<Device&()> device, bool open)
      : m_opt(options_of(st)),
        m_host(st.options.at("backend").get<std::string>() == "host"),
        m_device(device),
        m_path(st.options.at("file").get<std::string>()),
        m_tmp(temporary_path_for(m_path)),
        m_base(grey_picture(m_opt.mode) ? 1 : 3) {
    // As render's picture_layout: gdaldem's 3x3 products leave the border nodata without -compute_edges.
    m_alpha = grey_picture(m_opt.mode) && (!m_opt.compute_edges || w < 2 || h < 2);
    if (!open) return;
    io::init_gdal();
    CPLErrorReset();
    GDALDriver* drv = GetGDALDriverManager()->GetDriverByName("GTiff");
    if (!drv) fail("render", "cannot write {}: GDAL has no GTiff driver", m_path);
    char** opts = nullptr;
    opts = CSLSetNameValue(opts, "INTERLEAVE", "PIXEL");
    opts = CSLSetNameValue(opts, "TILED", "YES");
    // Uncompressed, as the untiled render and gdaldem write pictures: DEFLATE (level 1, every core)
    // made an 8193^2 tiled hillshade 1.4x the untiled run.
    opts = CSLSetNameValue(opts, "COMPRESS", "NONE");
    opts = CSLSetNameValue(opts, "BIGTIFF", double(w) * h * (m_base + 1) > 3.5e9 ? "YES" : "IF_SAFER");
    opts = CSLSetNameValue(opts, "PHOTOMETRIC", m_base == 3 ? "RGB" : "MINISBLACK");
    opts = CSLSetNameValue(opts, "ALPHA", "YES");
    m_ds = drv->Create(m_tmp.c_str(), w, h, m_base + 1, GDT_Byte, opts);
    CSLDestroy(opts);
    if (!m_ds) {
      discard_temporary(m_tmp);
      fail("render", "cannot create {} ({})", m_path, io::last_gdal_error());
    }
    if (level.has_geotransform) {
      double gt[6];
      std::copy(level.geotransform.begin(), level.geotransform.end(), gt);
      m_ds->SetGeoTransform(gt);
    }
    if (!level.crs_wkt.empty()) m_ds->SetProjection(level.crs_wkt.c_str());
    m_ds->GetRasterBand(m_base + 1)->SetColorInterpretation(GCI_AlphaBand);
    for (const auto& [k, v] : provenance) {
      std::string key = k;
      for (char& c : key)
        if (c == ':') c = '_';  // as render::write_image
      m_ds->SetMetadataItem(key.c_str(), v.c_str());
    }
    m_ds->SetMetadataItem("TIFFTAG_SOFTWARE", "terracl");
  }
  ~RenderPictureSink() override {
    if (m_ds) {
      GDALClose(m_ds);
      discard_temporary(m_tmp);
    }
  }

  // The core's pixels (band-interleaved), then one byte: 1 when the core has a nodata cell.
  std::vector<uint8_t> draw(const Heightfield& win, int wx, int wy, int cx, int cy, int cw, int ch) override {
    const render::Image img = m_host ? render::render(win, m_opt) : render::render(win, m_opt, m_device());
    const int n = m_base + 1, ic = img.channels;
    const bool has_alpha = ic > m_base;
    std::vector<uint8_t> buffer(size_t(cw) * ch * n + 1, 0);
    bool any_nan = false;
    for (int y = 0; y < ch; ++y)
      for (int x = 0; x < cw; ++x) {
        const size_t i = size_t(cy - wy + y) * win.width + size_t(cx - wx + x);
        const uint8_t* src = &img.pixels[i * ic];
        uint8_t* dst = &buffer[(size_t(y) * cw + x) * n];
        for (int c = 0; c < m_base; ++c) dst[c] = src[c];
        // Without an alpha band every cell of this window was drawn: 255, as the untiled alpha would be.
        dst[m_base] = has_alpha ? src[m_base] : 255;
        any_nan |= std::isnan(win.z[i]);
      }
    buffer.back() = any_nan ? 1 : 0;
    return buffer;
  }

  void put(const std::vector<uint8_t>& drawn, int cx, int cy, int cw, int ch) override {
    const int n = m_base + 1;
    if (drawn.size() != size_t(cw) * ch * n + 1) fail("render", "internal: drawn tile of {} bytes", drawn.size());
    m_any_nan |= drawn.back() != 0;
    CPLErrorReset();
    if (m_ds->RasterIO(GF_Write, cx, cy, cw, ch, const_cast<uint8_t*>(drawn.data()), cw, ch, GDT_Byte, n, nullptr, n,
                       GSpacing(n) * cw, 1, nullptr) != CE_None)
      fail("render", "writing {} failed at window {},{} ({})", m_path, cx, cy, io::last_gdal_error());
  }

  void commit() override {
    GDALDataset* raw = m_ds;
    m_ds = nullptr;
    CPLErrorReset();
    GDALClose(raw);
    if (CPLGetLastErrorType() >= CE_Failure) {
      discard_temporary(m_tmp);
      fail("render", "finishing {} failed ({})", m_path, io::last_gdal_error());
    }
    if (m_alpha || m_any_nan) {
      commit_temporary(m_tmp, m_path);
      return;
    }
    // No nodata anywhere: the untiled picture has no alpha band. GDALTranslate streams block by block.
    const std::string out = temporary_path_for(m_path);
    std::vector<std::string> args{"-of", "GTiff",
                                  "-co", "TILED=YES",
                                  "-co", "COMPRESS=NONE",
                                  "-co", "BIGTIFF=IF_SAFER",
                                  "-co", m_base == 3 ? "PHOTOMETRIC=RGB" : "PHOTOMETRIC=MINISBLACK"};
    for (int b = 1; b <= m_base; ++b) args.insert(args.end(), {"-b", std::to_string(b)});
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    GDALTranslateOptions* to = GDALTranslateOptionsNew(argv.data(), nullptr);
    GDALDatasetH src = GDALOpen(m_tmp.c_str(), GA_ReadOnly);
    int usage_error = 0;
    GDALDatasetH dst = src && to ? GDALTranslate(out.c_str(), src, to, &usage_error) : nullptr;
    GDALTranslateOptionsFree(to);
    bool ok = dst != nullptr;
    if (dst) {
      CPLErrorReset();
      GDALClose(dst);
      ok = CPLGetLastErrorType() < CE_Failure;
    }
    if (src) GDALClose(src);
    discard_temporary(m_tmp);
    if (!ok) {
      discard_temporary(out);
      fail("render", "finishing {} failed ({})", m_path, io::last_gdal_error());
    }
    commit_temporary(out, m_path);
  }

 private:
  render::Options m_opt;
  bool m_host;
  std::function<Device&()> m_device;
  std::string m_path, m_tmp;
  int m_base;
  bool m_alpha = false, m_any_nan = false;
  GDALDataset* m_ds = nullptr;
};

}  // namespace

std::unique_ptr<TileSink> make_render_sink(const PipelineStage& st, int w, int h, const Georef& level,
                                           const Metadata& metadata, const Metadata& provenance,
                                           std::function<Device&()> device, bool open) {
  const render::Mode m = render::mode_from_name(st.options.at("mode").get<std::string>());
  if (render::is_value_mode(m) &&
      (m != render::Mode::Slope ||
       format_from_extension(st.options.at("file").get<std::string>()) == FileFormat::GeoTIFF)) {
    // Slope to a GeoTIFF is gdaldem's float raster (as run_render).
    Metadata md = metadata;
    for (const auto& [k, v] : provenance) md[k] = v;
    return std::make_unique<RenderValuesSink>(st, w, h, level, md, device, open);
  }
  return std::make_unique<RenderPictureSink>(st, w, h, level, provenance, device, open);
}

}  // namespace terracl::tile
