// SPDX-License-Identifier: Apache-2.0
// The stage table's memory column (terracl/stage_memory.hpp). One table, beside the tiling column
// (host/src/tile/tiling.cpp), so that every stage's figure is read and kept up to date together;
// a stage missing here gets a conservative default (its input and output plus one copy) rather
// than no check. Bytes per cell are peak-RSS slopes measured on this machine (PoCL keeps device
// buffers in host memory, so device figures are the stages' own buffer sums): docs/reliability.md
// has the table and the command that measured it.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <terracl/device.hpp>
#include <terracl/error.hpp>
#include <terracl/distributed.hpp>
#include <terracl/hypre.hpp>
#include <terracl/memory.hpp>
#include <terracl/stage_memory.hpp>
#include <terracl/warp.hpp>

#include "io/io_common.hpp"

namespace terracl {
namespace {

// Per cell of the input (in) and of the output (out), host and device.
struct PerCell {
  double host_in = 0, host_out = 0, device_in = 0, largest_in = 0;
};

const char* kTiledHint = "run it tiled (terracl run P.json --tile 2048, docs/scale.md) or crop or downsample the input first";
const char* kCropHint = "crop or downsample the input first (this stage needs the whole raster at once)";

int64_t option_int(const json& o, const char* name, int64_t fallback) {
  return o.contains(name) && o.at(name).is_number_integer() ? o.at(name).get<int64_t>() : fallback;
}

// What the stage hands on, from its options (crop, downsample, amplify, resize, warp --ts change
// the size; the others keep it).
RasterShape output_shape(const std::string& type, const json& o, RasterShape in) {
  if (type == "crop") {
    const int64_t x = option_int(o, "x", 0), y = option_int(o, "y", 0);
    RasterShape out{option_int(o, "width", in.known() ? in.width - x : 0),
                    option_int(o, "height", in.known() ? in.height - y : 0)};
    return out.width > 0 && out.height > 0 ? out : RasterShape{};
  }
  if (type == "downsample" || type == "amplify") {
    if (!in.known()) return {};
    const int64_t f = std::max<int64_t>(1, option_int(o, "factor", 1));
    return type == "amplify" ? RasterShape{in.width * f, in.height * f} : RasterShape{in.width / f, in.height / f};
  }
  if (type == "resize") {
    if (o.contains("preset") && o.at("preset").is_string()) {
      try {
        const int n = engine_preset_size(o.at("preset").get<std::string>(), type);
        return {n, n};
      } catch (const Error&) {
        return {};
      }
    }
    return {option_int(o, "width", 0), option_int(o, "height", 0)};
  }
  if (type == "warp") {
    const json& ts = o.contains("ts") ? o.at("ts") : json();
    if (ts.is_array() && ts.size() == 2 && ts[0].is_number_integer() && ts[1].is_number_integer())
      return {ts[0].get<int64_t>(), ts[1].get<int64_t>()};
    return {};  // from tr / projwin / t_srs: known after GDAL has computed it
  }
  return in;
}

PerCell per_cell(const std::string& type, const json& o) {
  // Host figures include the input raster the pipeline holds while the stage runs. They are the
  // peak-RSS slopes of the stage's subcommand (read + stage + write) between a 384^2 and a
  // 1536^2 raster (StageMemory.EstimatesHoldTheMeasuredPeakPerCell prints them), rounded up by
  // about a quarter; for device stages the device figure (their buffer sums) is taken out, since
  // PoCL keeps device buffers in host memory (require_memory adds it back on a CPU device).
  if (type == "read") return {0, 9};                   // measured 8.7 (terracl info)
  if (type == "write") return {16};                    // raster + the encoder's copy: 13.3 with the read (convert)
  if (type == "crop" || type == "downsample") return {8, 8};  // 13.1 (crop), 8.0 (downsample by 2)
  if (type == "warp" || type == "resize") return {8, 8};  // GDAL MEM copies in and out
  if (type == "amplify") return {4, 8};                // the output grid and its accumulator (not measured)
  if (type == "extract") return {30, 0, 12, 4};        // measured 33.4 in all
  if (type == "reconstruct" && o.value("solver", std::string("multigrid")) == "hypre")
    // double matrix, vectors and PFMG levels on the host: each MPI rank its band's share (the
    // subcommand reads a gradient file by bands), rank 0 the float result besides.
    return {kHypreHostBytesPerCell / distributed::size() + 4};
  // The refinement (the default) keeps U and R in double, its right-hand side and three search
  // directions in float: measured 86 in all with it, 43 with --refine off.
  if (type == "reconstruct")
    return {24, 0, o.value("refine", std::string("auto")) == "off" ? 40.0 : 80.0, 4};
  if (type == "fill_nodata") return {24};              // a host solve over the nodata cells (13 without any)
  if (type == "erode") return {112, 0, 56, 16};        // measured 135 in all
  if (type == "edit") return {edit_host_bytes_per_cell, 0, edit_device_bytes_per_cell, 8};  // 111 in all (noise)
  if (type == "fill_depressions") return {20};         // measured 15.3
  if (type == "breach") return {21};                   // 16.4
  if (type == "drainage") return {o.value("method", std::string("d8")) == "dinf" ? 30.0 : 25.0};  // 24.1, 17.0-20.1
  if (type == "watershed") return {35};                // drainage's D8 and a label per cell (not measured)
  if (type == "metrics") return {52};                  // 42.2
  if (type == "sketch") return {40};                   // 31.5
  // 16.3 (hillshade PNG); its device buffers are small and --backend cpu uses none, so no device
  // figure (declaring one would open the device for a CPU render).
  if (type == "render") return {21};
  // 214 for the full grid; with --max-error far less on smooth terrain (8 at 5 m), up to the
  // full grid's for a tiny error.
  if (type == "mesh") return {o.contains("max_error") && !o.at("max_error").is_null() ? 100.0 : 270.0};
  return {12};  // a stage not listed here: its input, its output and one copy
}

std::string hint_of(const std::string& type, const json& o) {
  if (type == "amplify") return "use a smaller --factor, or amplify a crop of the input";
  if (type == "edit") return "use a smaller base (flat:WxH, or crop the DEM)";
  if (type == "read" || type == "write" || type == "crop" || type == "downsample" ||
      (type == "fill_depressions" && !o.value("epsilon", false)))
    return kTiledHint;
  return kCropHint;
}

}  // namespace

MemoryNeed memory_of(const std::string& type, const json& options, RasterShape in) {
  MemoryNeed n;
  n.output = output_shape(type, options, in);
  const RasterShape& size = type == "read" ? n.output : in;
  n.what = size.known() ? fmt::format("{} of a {} x {} raster", type, size.width, size.height) : type;
  if (type == "amplify" && n.output.known())
    n.what = fmt::format("the x{} output of a {} x {} input", option_int(options, "factor", 1), in.width, in.height);
  n.hint = hint_of(type, options);
  const PerCell p = per_cell(type, options);
  const double cin = in.known() ? in.cells() : 0, cout = n.output.known() ? n.output.cells() : 0;
  n.host = p.host_in * cin + p.host_out * cout;
  n.device = p.device_in * cin;
  n.largest_buffer = p.largest_in * cin;
  return n;
}

RasterShape raster_shape(const std::string& path) {
  if (path.rfind("flat:", 0) == 0) return {};
  const auto wh = io::raster_header_size(path);
  return wh ? RasterShape{wh->first, wh->second} : RasterShape{};
}

void require_stage_memory(const std::string& stage, const std::string& where, const MemoryNeed& need,
                          const Device* device) {
  require_stage_memory_info(stage, where, need, device ? &device->info() : nullptr);
}

void require_stage_memory_info(const std::string& stage, const std::string& where, const MemoryNeed& need,
                               const DeviceInfo* device) {
  const std::string label = where.empty() ? need.what : fmt::format("{} ({})", where, need.what);
  // A side past the limit first: its memory figure would be astronomical and less helpful.
  const RasterShape& s = need.output;
  if (s.known() && (s.width > max_raster_side || s.height > max_raster_side))
    fail(stage, "{}: an output of {} x {} cells; each side may be at most {} cells; {}", label, s.width, s.height,
         max_raster_side, need.hint);
  if (need.host <= 0 && need.device <= 0) return;
  require_memory_info(stage, label, need.host, need.device, need.largest_buffer, device, need.hint);
}

}  // namespace terracl
