// SPDX-License-Identifier: Apache-2.0
#pragma once
/// One place that checks sizes and memory before allocating. A stage (or a reader) states what it
/// will need, in bytes of host RAM and of device memory, before it allocates anything; a request
/// that cannot fit is refused with a message saying how much is needed, how much there is and
/// what to change, instead of a std::bad_alloc, a driver assertion or a swap storm half-way.
#include <cstdint>
#include <string>

namespace terracl {

class Device;

/// Largest raster side accepted anywhere (cells): indices stay well inside int32.
constexpr int64_t max_raster_side = 65536;

/// Host memory a run may use: the smaller of MemAvailable (/proc/meminfo), the address-space
/// limit (ulimit -v) and TERRACL_MAX_MEMORY (bytes, or with a K/M/G/T suffix).
uint64_t host_memory_limit();

/// "1.5 GiB".
std::string human_bytes(double bytes);

/// Throws Error(stage, ...) when `host_bytes` exceed host_memory_limit(), or (with a device)
/// `device_bytes` exceed its global memory or `largest_buffer` its largest allocation. `what`
/// names the request ("a 20000 x 20000 edit"), `hint` says what to change ("use a smaller base").
void require_memory(const std::string& stage, const std::string& what, double host_bytes, double device_bytes,
                    double largest_buffer, const Device* device, const std::string& hint);

/// Memory an edit session needs per cell of its grid: the base, gradient, constraint and result
/// rasters on the host, and an operation's own host rasters (noise fields, a change raster); the
/// multigrid hierarchy (4/3 of the finest level) on the device. Measured 111 B/cell in all on
/// PoCL for a noise script (StageMemory.EstimatesHoldTheMeasuredPeakPerCell), rounded up.
constexpr double edit_host_bytes_per_cell = 92;
constexpr double edit_device_bytes_per_cell = 48;

/// Throws Error(stage, ...) naming `what` when a raster of width x height is empty or has a side
/// over max_raster_side, or its `bytes_per_cell` of host memory do not fit (a header claiming
/// 10^6 x 10^6 cells).
void require_raster_size(const std::string& stage, const std::string& what, int64_t width, int64_t height,
                         double bytes_per_cell);

}  // namespace terracl
