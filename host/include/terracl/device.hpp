// SPDX-License-Identifier: Apache-2.0
#pragma once
/// OpenCL device layer: device choice, context and queue, embedded kernels and program cache.
#include <terracl/cl.hpp>

#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace terracl {

/// One OpenCL device as `terracl devices` lists it.
struct DeviceInfo {
  int index = 0;          ///< position in the flat list over all platforms
  std::string platform;
  std::string name;
  std::string type;       ///< "CPU", "GPU", "ACCELERATOR" or "OTHER"
  unsigned compute_units = 0;
  uint64_t global_mem = 0;
  uint64_t max_alloc = 0;
  uint64_t local_mem = 0;
  size_t max_work_group = 0;
  std::string opencl_c_version;
  std::string driver_version;
  std::string device_version;
  /// Launch shape the launchers use: "rows" (one work-item per row with the x-loop
  /// inside: PoCL's fastest form for stencils) on CPU devices, "wide" (many work-items per row,
  /// larger groups) on GPUs, accelerators and anything else. Chosen from CL_DEVICE_TYPE's CPU
  /// bit, not from the type string; TERRACL_LAUNCH=rows|wide forces one (tests run both on PoCL).
  std::string launch = "rows";
};

/// All devices of all platforms, in a stable order. Empty when no ICD/platform is installed.
std::vector<DeviceInfo> list_devices();

/// Name of an OpenCL error code, e.g. "CL_OUT_OF_RESOURCES".
const char* cl_error_name(int code);

/// "clEnqueueNDRangeKernel: CL_OUT_OF_RESOURCES (-5)" for an exception of the C++ bindings.
std::string describe(const cl::Error& e);

/// A chosen device with its context, in-order queue and program cache.
///
/// Choice (VexCL's convention): an explicit spec (`--device`: index or name substring) wins;
/// else env OCL_PLATFORM (platform name substring), OCL_DEVICE (device name substring) and
/// OCL_TYPE (CPU|GPU|ACCELERATOR) filter the list; default: the first GPU, else the first device.
class Device {
 public:
  static std::shared_ptr<Device> open(const std::string& spec = "");

  const DeviceInfo& info() const { return m_info; }
  cl::Context& context() { return m_context; }
  cl::CommandQueue& queue() { return m_queue; }
  cl::Device& device() { return m_device; }

  /// Built program of kernels/<file>.cl with extra build options; cached in memory and on disk
  /// ($XDG_CACHE_HOME/terracl or ~/.cache/terracl; TERRACL_NO_CACHE=1 disables the disk cache;
  /// on PoCL binaries are read but written only with TERRACL_PROGRAM_CACHE=1, as `terracl devices
  /// --warm` does: asking PoCL for a binary compiles every kernel of the program once more).
  /// A build failure throws with the file, the options and the full build log.
  cl::Program& program(const std::string& file, const std::string& options = "");
  /// Same as program() for source that is not embedded (user kernels, tests); `name` labels errors
  /// and cache entries.
  cl::Program& program_from_source(const std::string& name, const std::string& source, const std::string& options = "");
  /// A new kernel object (kernels are not thread-safe to share across argument sets).
  cl::Kernel kernel(const std::string& file, const std::string& name, const std::string& options = "");

  /// Device buffer with a clear error when `bytes` exceeds the device's max allocation or global
  /// memory; `what` names the buffer in that error.
  cl::Buffer buffer(size_t bytes, cl_mem_flags flags, const std::string& what);
  /// Bytes currently allocated through buffer() on this physical device (by every Device object
  /// opened on it) and not yet released (approximate accounting).
  uint64_t allocated_bytes() const;
  /// Enqueues `count` floats of `value` into `buf` from float offset `offset` (no wait). A kernel
  /// writes them, not clEnqueueFillBuffer: strict devices (oclgrind) do not count a fill as an
  /// initialisation, and then flag every later read of the buffer.
  void fill(const cl::Buffer& buf, float value, size_t offset, size_t count);

 private:
  Device() = default;
  DeviceInfo m_info;
  cl::Device m_device;
  cl::Context m_context;
  cl::CommandQueue m_queue;
  std::mutex m_mutex;
  std::map<std::string, cl::Program> m_programs;
  std::shared_ptr<std::atomic<int64_t>> m_allocated;  ///< shared by the Devices of one cl_device_id
};

/// Source of an embedded kernel file by stem ("gradient" for kernels/gradient.cl); throws if unknown.
const std::string& kernel_source(const std::string& file);
/// Stems of all embedded kernel files.
std::vector<std::string> kernel_files();

/// Rounds `n` up to a multiple of `m` (global sizes must be multiples of local sizes in CL 1.2).
inline size_t round_up(size_t n, size_t m) { return (n + m - 1) / m * m; }

}  // namespace terracl
