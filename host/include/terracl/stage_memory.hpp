// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The stage table's memory column: what each stage needs, in host RAM and device
/// memory, estimated from its resolved options and the size of its input, and the one checker
/// that refuses a run before any work starts (`terracl run`, `run --validate`, every stage
/// subcommand, `terracl edit`). Sizes flow from the readers' headers (read without the pixels)
/// through the stages that change them (crop, downsample, amplify, resize, warp --ts).
/// Beside the tiling column (terracl/tile.hpp); the figures are in docs/reliability.md.
#include <cstdint>
#include <string>
#include <terracl/stage.hpp>

namespace terracl {

class Device;
struct DeviceInfo;

/// A raster size between stages; 0 x 0 when it is not known before running.
struct RasterShape {
  int64_t width = 0, height = 0;
  bool known() const { return width > 0 && height > 0; }
  double cells() const { return double(width) * double(height); }
};

/// One stage's estimate for one input size.
struct MemoryNeed {
  double host = 0;           ///< bytes of host RAM at the stage's peak (its input and output included)
  double device = 0;         ///< bytes of device memory
  double largest_buffer = 0; ///< the largest single device allocation
  RasterShape output;        ///< what it hands on (unknown when it depends on the data)
  std::string what;          ///< "fill_depressions of a 30000 x 30000 raster"
  std::string hint;          ///< what to change ("crop or downsample the input first")
};

/// The memory column: what stage `type` with resolved `options` needs for an input of `in`
/// (known or not; the output size is filled in either way when the options give it).
MemoryNeed memory_of(const std::string& type, const json& options, RasterShape in);

/// Width and height from a raster file's header (GDAL opens it without reading pixels; PNG/EXR
/// through the same drivers); unknown when the file cannot be opened or is not a raster.
RasterShape raster_shape(const std::string& path);

/// Throws Error(stage, "<where>: <what> needs about X of memory, and Y is available; <hint>")
/// when `need` does not fit the host (host_memory_limit(): MemAvailable, ulimit -v,
/// TERRACL_MAX_MEMORY) or, with a device, its global memory or largest allocation.
void require_stage_memory(const std::string& stage, const std::string& where, const MemoryNeed& need,
                          const Device* device);
/// The same with the device's figures only (choose_device(): `--validate` opens no context).
void require_stage_memory_info(const std::string& stage, const std::string& where, const MemoryNeed& need,
                               const DeviceInfo* device);

/// require_memory() (terracl/memory.hpp) with the device's figures only.
void require_memory_info(const std::string& stage, const std::string& what, double host_bytes, double device_bytes,
                         double largest_buffer, const DeviceInfo* device, const std::string& hint);

/// The device Device::open(spec) would open, from the platform list alone: no context, queue or
/// kernel is created, so `--validate` checks device memory cheaply (host/src/cl/device.cpp).
/// Throws as open() does when there is none.
DeviceInfo choose_device(const std::string& spec = "");

}  // namespace terracl
