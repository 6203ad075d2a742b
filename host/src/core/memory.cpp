// SPDX-License-Identifier: Apache-2.0
// Size and memory checks made before allocating (terracl/memory.hpp).
#include <terracl/device.hpp>
#include <terracl/error.hpp>
#include <terracl/memory.hpp>
#include <terracl/stage_memory.hpp>

#include <fmt/format.h>
#include <sys/resource.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <string>

namespace terracl {

std::string human_bytes(double b) {
  const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB"};
  int u = 0;
  while (b >= 1024 && u < 5) b /= 1024, ++u;
  return u == 0 ? fmt::format("{:.0f} B", b) : fmt::format("{:.1f} {}", b, units[u]);
}

namespace {

uint64_t parse_bytes(const char* text) {
  char* end = nullptr;
  const double v = std::strtod(text, &end);
  if (end == text || !(v > 0)) return 0;
  double scale = 1;
  switch (*end) {
    case 'k': case 'K': scale = 1024.0; break;
    case 'm': case 'M': scale = 1024.0 * 1024; break;
    case 'g': case 'G': scale = 1024.0 * 1024 * 1024; break;
    case 't': case 'T': scale = 1024.0 * 1024 * 1024 * 1024; break;
    default: break;
  }
  const double b = v * scale;
  return b >= 1.8e19 ? UINT64_MAX : uint64_t(b);
}

}  // namespace

uint64_t host_memory_limit() {
  uint64_t limit = UINT64_MAX;
  std::ifstream mi("/proc/meminfo");
  std::string key;
  uint64_t kb = 0;
  std::string unit;
  while (mi >> key >> kb >> unit)
    if (key == "MemAvailable:") {
      limit = std::min<uint64_t>(limit, kb * 1024);
      break;
    }
  rlimit r{};
  if (::getrlimit(RLIMIT_AS, &r) == 0 && r.rlim_cur != RLIM_INFINITY) limit = std::min<uint64_t>(limit, r.rlim_cur);
  if (const char* env = std::getenv("TERRACL_MAX_MEMORY"))
    if (const uint64_t b = parse_bytes(env)) limit = std::min(limit, b);
  return limit;
}

void require_memory(const std::string& stage, const std::string& what, double host_bytes, double device_bytes,
                    double largest_buffer, const Device* device, const std::string& hint) {
  require_memory_info(stage, what, host_bytes, device_bytes, largest_buffer, device ? &device->info() : nullptr, hint);
}

void require_memory_info(const std::string& stage, const std::string& what, double host_bytes, double device_bytes,
                         double largest_buffer, const DeviceInfo* device, const std::string& hint) {
  const double host = double(host_memory_limit());
  // A CPU device (PoCL) allocates its buffers in host memory: they add to the host's share.
  const bool shared = device && device->type == "CPU";
  const double need = host_bytes + (shared ? device_bytes : 0);
  if (need > host)
    fail(stage, "{} needs about {} of memory{}, and {} is available{}; {}", what, human_bytes(need),
         shared && device_bytes > 0 ? " (the CPU device's buffers included)" : "", human_bytes(host),
         std::getenv("TERRACL_MAX_MEMORY") ? " (TERRACL_MAX_MEMORY)" : "", hint);
  if (!device) return;
  const DeviceInfo& d = *device;
  if (d.global_mem && device_bytes > double(d.global_mem))
    fail(stage, "{} needs about {} of device memory, and {} has {}; {}", what, human_bytes(device_bytes), d.name,
         human_bytes(double(d.global_mem)), hint);
  if (d.max_alloc && largest_buffer > double(d.max_alloc))
    fail(stage, "{} needs a device buffer of {}, and {} allocates at most {} at once; {}", what,
         human_bytes(largest_buffer), d.name, human_bytes(double(d.max_alloc)), hint);
}

void require_raster_size(const std::string& stage, const std::string& what, int64_t width, int64_t height,
                         double bytes_per_cell) {
  if (width < 1 || height < 1) fail(stage, "{}: the raster is {} x {} cells; it has no cells", what, width, height);
  if (width > max_raster_side || height > max_raster_side)
    fail(stage, "{}: {} x {} cells; each side may be at most {} cells", what, width, height, max_raster_side);
  require_memory_info(stage, fmt::format("{} ({} x {} cells)", what, width, height), double(width) * double(height) * bytes_per_cell,
                 0, 0, nullptr, "cut it into smaller pieces first (e.g. gdal_translate -srcwin)");
}

}  // namespace terracl
