// SPDX-License-Identifier: Apache-2.0
// The streamed `render`: a GDAL raster read strip by strip (a one-row halo each side),
// each strip rendered on the device or the host and written before the next one is needed, so the
// memory held is a few strips, not the raster and its picture. The picture's layout depends on the
// whole raster (alpha when any cell is nodata, a percentage ramp's data range): when it does, a
// first pass reads the strips only to scan them. The next strip is read while the current one
// renders. The picture is the same file as the untiled in-memory render writes (test_render_stream).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <future>
#include <thread>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/render.hpp>

#include "io/gdal_window.hpp"
#include "io/io_common.hpp"
#include "render/picture_writer.hpp"
#include "render/render_internal.hpp"

namespace terracl::render {

namespace {

// Cells per strip when none is asked: 4 Mi cells (16 MB of heights, 8 MB of grey picture) keeps
// launches and GDAL calls few while the memory stays far below the 8k raster's 144 MB.
constexpr size_t kStripCells = size_t(4) << 20;

// A window of rows [y, y + rows) checked as read_heightfield checks a whole raster.
Heightfield read_rows(const io::GdalWindowReader& r, const std::string& path, int y, int rows) {
  Heightfield h = r.read(0, y, r.width(), rows);
  for (size_t i = 0; i < h.z.size(); ++i)
    if (std::isinf(h.z[i]))
      fail("io", "{}: cell ({}, {}) holds an infinite elevation ({}); a DEM must hold finite numbers or nodata", path,
           i % size_t(h.width), y + i / size_t(h.width), h.z[i]);
  return h;
}

// The raster in strips of S rows; strip k is read as rows [a, b) = span(k): its own rows and one
// more each side where the raster has them (the 3x3 window's halo).
struct Strips {
  const io::GdalWindowReader& reader;
  const std::string& path;
  int H, S;
  int count() const { return (H + S - 1) / S; }
  std::pair<int, int> span(int k) const { return {std::max(0, k * S - 1), std::min(H, (k + 1) * S + 1)}; }
  Heightfield read(int k) const {
    const auto [a, b] = span(k);
    Heightfield h = read_rows(reader, path, a, b - a);
    reader.release_cache();
    return h;
  }
};

}  // namespace

bool can_stream_render(const std::string& input, const std::string& output, const Options& opt) {
  const FileFormat in = format_from_extension(input), out = format_from_extension(output);
  const bool gdal_in = in == FileFormat::GeoTIFF || in == FileFormat::HGT || in == FileFormat::GDALOther;
  const bool picture = !is_value_mode(opt.mode) || (opt.mode == Mode::Slope && out == FileFormat::PNG);
  const bool values = is_value_mode(opt.mode) && out == FileFormat::GeoTIFF;
  // A perspective ray may cross the whole raster: drawn from memory (render_view).
  return gdal_in && opt.mode != Mode::Perspective &&
         ((picture && (out == FileFormat::PNG || out == FileFormat::GeoTIFF)) || values);
}

namespace {

// The value rasters (slope, aspect, TRI, TPI, roughness) of `input` into the float32 GeoTIFF
// `output`, strip by strip: strips of whole 256-row block rows, so every block is complete when
// its strip is written and none waits in memory. The cells are those of values() on the whole
// raster (a cell's window lies inside its strip and halo), stored as write_heightfield stores them.
void values_file(const std::string& input, const std::string& output, const Options& opt,
                 const std::function<Device*()>& open_device, const Metadata& meta, int strip_rows) {
  io::require_readable(input);
  const io::GdalWindowReader reader(input);
  const int W = reader.width(), H = reader.height();
  check_options(reader.header(), opt);
  constexpr int kBlock = 256;  // GeoTiffWindowWriter's block width and height
  const int want = strip_rows > 0 ? strip_rows : int(kStripCells / size_t(W));
  const int S = std::clamp(std::max(1, want / kBlock) * kBlock, 1, std::max(H, 1));
  const Strips strips{reader, input, H, S};
  const int n = strips.count();
  auto span = [&](int k) { return strips.span(k); };
  auto read_strip = [&](int k) { return strips.read(k); };
  Options o = opt;
  o.progress = {};  // the strips report here
  o.strip_rows = S + 2;
  // The header as values() gives it for the whole raster: nodata, units, quantity, metadata.
  const Heightfield& like = reader.header();
  const Heightfield head = value_raster_like(Heightfield(1, 1), o);
  Georef georef = like.georef;
  georef.nodata = head.georef.nodata;
  georef.vertical_units = head.georef.vertical_units;
  Metadata metadata = like.metadata;
  for (const auto& [k, v] : head.metadata) metadata[k] = v;
  for (const auto& [k, v] : meta) metadata[k] = v;

  io::GeoTiffWindowWriter out(output, W, H, georef, metadata, {}, 1, opt.compress);
  const int blocks_x = (W + kBlock - 1) / kBlock;
  const int parts = std::clamp(int(std::thread::hardware_concurrency()), 1, blocks_x);
  std::future<Heightfield> next = std::async(std::launch::async, read_strip, 0);
  Device* device = open_device();
  for (int k = 0; k < n; ++k) {
    Heightfield h = next.get();
    if (k + 1 < n) next = std::async(std::launch::async, read_strip, k + 1);
    const Heightfield v = device ? values(h, o, *device) : values(h, o);
    const int y0 = k * S, rows = std::min(S, H - y0);
    // DEFLATE is most of a value raster's time: the strip's block columns are compressed in
    // `parts` threads (each part whole blocks), then appended in order.
    if (!opt.compress) {  // uncompressed: GDAL writes the strip's blocks, then lets go of them
      out.write(0, y0, v, 0, y0 - span(k).first, W, rows);
      out.flush();
      report_progress(opt.progress, "render", double(k + 1) / n,
                      fmt::format("strip {}/{} (rows {}..{})", k + 1, n, y0, y0 + rows - 1));
      continue;
    }
    std::vector<std::future<std::vector<uint8_t>>> encoded;
    for (int p = 0; p < parts; ++p) {
      const int x0 = std::min(W, p * blocks_x / parts * kBlock), x1 = std::min(W, (p + 1) * blocks_x / parts * kBlock);
      if (x1 > x0)
        encoded.push_back(std::async(std::launch::async, [&, x0, x1] {
          return io::GeoTiffWindowWriter::encode(W, H, georef.nodata, x0, y0, v, x0, y0 - span(k).first, x1 - x0, rows,
                                                 true, out.metres_per_unit());
        }));
    }
    for (auto& e : encoded) out.put(e.get());
    report_progress(opt.progress, "render", double(k + 1) / n,
                    fmt::format("strip {}/{} (rows {}..{})", k + 1, n, y0, y0 + rows - 1));
  }
  out.commit();
}

}  // namespace

void render_file(const std::string& input, const std::string& output, const Options& opt, Device* device,
                 const Metadata& meta, int strip_rows) {
  render_file(input, output, opt, [device] { return device; }, meta, strip_rows);
}

void render_file(const std::string& input, const std::string& output, const Options& opt,
                 const std::function<Device*()>& open_device, const Metadata& meta, int strip_rows) {
  if (!can_stream_render(input, output, opt))
    fail("render", "{} -> {}: a streamed render reads a GDAL raster and writes a picture (.png or .tif) or values (.tif)",
         input, output);
  if (is_value_mode(opt.mode) && format_from_extension(output) == FileFormat::GeoTIFF)
    return values_file(input, output, opt, open_device, meta, strip_rows);
  io::require_readable(input);
  const io::GdalWindowReader reader(input);
  const int W = reader.width(), H = reader.height();
  check_options(reader.header(), opt);
  const int S = std::clamp(strip_rows > 0 ? strip_rows : int(kStripCells / size_t(W)), 1, H);
  const Strips strips{reader, input, H, S};
  const int n = strips.count();
  auto span = [&](int k) { return strips.span(k); };
  auto read_strip = [&](int k) { return strips.read(k); };

  LayoutScan scan;
  const bool scanning = layout_needs_scan(W, H, opt);
  if (scanning)
    for (int k = 0; k < n; ++k) {
      const int rows = std::min(S, H - k * S);
      const Heightfield h = read_rows(reader, input, k * S, rows);
      reader.release_cache();
      scan_heights(h.z.data(), h.z.size(), opt, scan);
      report_progress(opt.progress, "render", 0.25 * (k + 1) / n, "scanning for nodata and the data range");
    }
  const PictureLayout layout = picture_layout(W, H, opt, scan);
  Options o = opt;
  o.progress = {};  // the strips report here
  o.strip_rows = S + 2;
  const size_t row_bytes = size_t(W) * layout.channels;
  const double p0 = scanning ? 0.25 : 0.0;

  write_atomically(output, [&](const std::string& tmp) {
    PictureWriter out(output, tmp, W, H, layout.channels, reader.header().georef, meta);
    // The next strip is read (GDAL, one thread) while this one renders and is written.
    std::future<Heightfield> next = std::async(std::launch::async, read_strip, 0);
    Device* device = open_device();  // PoCL loads its compiler (~0.3 s of CPU) while GDAL reads
    for (int k = 0; k < n; ++k) {
      Heightfield h = next.get();
      if (k + 1 < n) next = std::async(std::launch::async, read_strip, k + 1);
      const Image img = device ? render(h, o, layout, *device) : render(h, o, layout);
      const int y0 = k * S, rows = std::min(S, H - y0);
      out.write_rows(y0, rows, img.pixels.data() + size_t(y0 - span(k).first) * row_bytes);
      report_progress(opt.progress, "render", p0 + (1.0 - p0) * (k + 1) / n,
                      fmt::format("strip {}/{} (rows {}..{})", k + 1, n, y0, y0 + rows - 1));
    }
    out.close();
  });
}

}  // namespace terracl::render
