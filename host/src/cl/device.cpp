// SPDX-License-Identifier: Apache-2.0
// Device enumeration and choice. Follows VexCL's environment conventions so that users of other
// OpenCL tools can pick devices the same way.
#include <terracl/device.hpp>
#include <terracl/error.hpp>
#include <terracl/stage_memory.hpp>

#include "alloc_scope.hpp"
#include "workspace.hpp"

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cstdlib>

namespace terracl {
namespace {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return s;
}

bool contains_ci(const std::string& hay, const std::string& needle) {
  return lower(hay).find(lower(needle)) != std::string::npos;
}

std::string trim(std::string s) {
  while (!s.empty() && (std::isspace((unsigned char)s.back()) || s.back() == '\0')) s.pop_back();
  size_t i = 0;
  while (i < s.size() && std::isspace((unsigned char)s[i])) ++i;
  return s.substr(i);
}

std::string type_name(cl_device_type t) {
  if (t & CL_DEVICE_TYPE_GPU) return "GPU";
  if (t & CL_DEVICE_TYPE_CPU) return "CPU";
  if (t & CL_DEVICE_TYPE_ACCELERATOR) return "ACCELERATOR";
  return "OTHER";
}

struct Entry {
  DeviceInfo info;
  cl::Device device;
};

std::vector<Entry> enumerate() {
  std::vector<Entry> out;
  std::vector<cl::Platform> platforms;
  try {
    cl::Platform::get(&platforms);
  } catch (const cl::Error& e) {
    // CL_PLATFORM_NOT_FOUND_KHR: no ICD installed; that is an empty list, not an error.
    if (e.err() == -1001) return out;
    throw Error("device", describe(e));
  }
  for (auto& p : platforms) {
    std::vector<cl::Device> devices;
    try {
      p.getDevices(CL_DEVICE_TYPE_ALL, &devices);
    } catch (const cl::Error&) {
      continue;  // a platform without devices
    }
    for (auto& d : devices) {
      Entry e;
      e.device = d;
      e.info.index = int(out.size());
      e.info.platform = trim(p.getInfo<CL_PLATFORM_NAME>());
      e.info.name = trim(d.getInfo<CL_DEVICE_NAME>());
      e.info.type = type_name(d.getInfo<CL_DEVICE_TYPE>());
      e.info.compute_units = d.getInfo<CL_DEVICE_MAX_COMPUTE_UNITS>();
      e.info.global_mem = d.getInfo<CL_DEVICE_GLOBAL_MEM_SIZE>();
      e.info.max_alloc = d.getInfo<CL_DEVICE_MAX_MEM_ALLOC_SIZE>();
      e.info.local_mem = d.getInfo<CL_DEVICE_LOCAL_MEM_SIZE>();
      e.info.max_work_group = d.getInfo<CL_DEVICE_MAX_WORK_GROUP_SIZE>();
      e.info.opencl_c_version = trim(d.getInfo<CL_DEVICE_OPENCL_C_VERSION>());
      e.info.driver_version = trim(d.getInfo<CL_DRIVER_VERSION>());
      e.info.device_version = trim(d.getInfo<CL_DEVICE_VERSION>());
      e.info.launch = (d.getInfo<CL_DEVICE_TYPE>() & CL_DEVICE_TYPE_CPU) ? "rows" : "wide";
      if (const char* forced = std::getenv("TERRACL_LAUNCH")) {
        const std::string f = lower(forced);
        if (f != "rows" && f != "wide") throw Error("device", "TERRACL_LAUNCH must be rows or wide, got '" + f + "'");
        e.info.launch = f;
      }
      out.push_back(std::move(e));
    }
  }
  return out;
}

const char* env(const char* name) {
  const char* v = std::getenv(name);
  return (v && *v) ? v : nullptr;
}

Entry choose(const std::string& spec) {
  std::vector<Entry> all = enumerate();
  if (all.empty())
    fail("device", "no OpenCL device found (is an ICD such as pocl-opencl-icd installed? try `clinfo -l`)");
  if (!spec.empty()) {
    bool numeric = std::all_of(spec.begin(), spec.end(), [](unsigned char c) { return std::isdigit(c); });
    if (numeric) {
      size_t idx = std::stoul(spec);
      if (idx >= all.size())
        fail("device", "device index {} does not exist ({} device{} found; see `terracl devices`)", spec, all.size(),
             all.size() == 1 ? "" : "s");
      return all[idx];
    }
    for (auto& e : all)
      if (contains_ci(e.info.name, spec) || contains_ci(e.info.platform, spec)) return e;
    fail("device", "no device matches '{}' (see `terracl devices`)", spec);
  }
  std::vector<Entry> filtered;
  const char* plat = env("OCL_PLATFORM");
  const char* dev = env("OCL_DEVICE");
  const char* type = env("OCL_TYPE");
  for (auto& e : all) {
    if (plat && !contains_ci(e.info.platform, plat)) continue;
    if (dev && !contains_ci(e.info.name, dev)) continue;
    if (type && lower(e.info.type) != lower(type)) continue;
    filtered.push_back(e);
  }
  if (filtered.empty())
    fail("device", "no device matches OCL_PLATFORM={} OCL_DEVICE={} OCL_TYPE={} (see `terracl devices`)",
         plat ? plat : "", dev ? dev : "", type ? type : "");
  for (auto& e : filtered)
    if (e.info.type == "GPU") return e;
  return filtered.front();
}

// Live device-buffer bytes, decremented by OpenCL's destructor callback when a buffer is freed.
// `scopes`: the AllocationScopes open on the allocating thread.
struct AllocRecord {
  std::shared_ptr<std::atomic<int64_t>> counter;
  int64_t bytes;
  std::vector<std::shared_ptr<std::atomic<int64_t>>> scopes;
};
// One counter per physical device: devices have their own memory, and Device objects opened on
// the same device share it.
std::shared_ptr<std::atomic<int64_t>> allocation_counter(cl_device_id id) {
  static std::mutex mutex;
  static std::map<cl_device_id, std::shared_ptr<std::atomic<int64_t>>> counters;
  std::lock_guard<std::mutex> lock(mutex);
  auto& c = counters[id];
  if (!c) c = std::make_shared<std::atomic<int64_t>>(0);
  return c;
}

void CL_CALLBACK on_release(cl_mem, void* user) {
  auto* r = static_cast<AllocRecord*>(user);
  r->counter->fetch_sub(r->bytes);
  for (auto& s : r->scopes) s->fetch_sub(r->bytes);
  delete r;
}

}  // namespace

std::vector<DeviceInfo> list_devices() {
  std::vector<DeviceInfo> out;
  for (auto& e : enumerate()) out.push_back(e.info);
  return out;
}

DeviceInfo choose_device(const std::string& spec) { return choose(spec).info; }

std::shared_ptr<Device> Device::open(const std::string& spec) {
  Entry e = choose(spec);
  std::shared_ptr<Device> d(new Device());
  d->m_info = e.info;
  d->m_device = e.device;
  d->m_allocated = allocation_counter(e.device());
  try {
    d->m_context = cl::Context(e.device);
    d->m_queue = cl::CommandQueue(d->m_context, e.device);
  } catch (const cl::Error& err) {
    throw Error("device", fmt::format("cannot open '{}': {}", e.info.name, describe(err)));
  }
  return d;
}

cl::Kernel Device::kernel(const std::string& file, const std::string& name, const std::string& options) {
  cl::Program& p = program(file, options);
  try {
    return cl::Kernel(p, name.c_str());
  } catch (const cl::Error& err) {
    throw Error("device", fmt::format("kernel '{}' in kernels/{}.cl: {}", name, file, describe(err)));
  }
}

cl::Buffer Device::buffer(size_t bytes, cl_mem_flags flags, const std::string& what) {
  if (bytes == 0) bytes = 4;  // zero-size buffers are invalid in OpenCL
  if (bytes > m_info.max_alloc)
    fail("device", "{} needs {:.1f} MiB, more than the largest allocation {} allows ({:.1f} MiB)", what,
         bytes / 1048576.0, m_info.name, m_info.max_alloc / 1048576.0);
  if (uint64_t(m_allocated->load()) + bytes > m_info.global_mem && workspace_cached_bytes() > 0) {
    // The idle reconstruction cache gives way first (drivers may run the release callback only
    // once the queue is idle).
    release_workspace();
    m_queue.finish();
  }
  if (uint64_t(m_allocated->load()) + bytes > m_info.global_mem)
    fail("device", "{} needs {:.1f} MiB, but {} has {:.1f} MiB of global memory and {:.1f} MiB are in use", what,
         bytes / 1048576.0, m_info.name, m_info.global_mem / 1048576.0, m_allocated->load() / 1048576.0);
  try {
    cl::Buffer b(m_context, flags, bytes);
    m_allocated->fetch_add(int64_t(bytes));
    auto* rec = new AllocRecord{m_allocated, int64_t(bytes), open_allocation_scopes()};
    if (clSetMemObjectDestructorCallback(b(), on_release, rec) != CL_SUCCESS) {
      m_allocated->fetch_sub(int64_t(bytes));
      delete rec;
    } else {
      for (auto& s : rec->scopes) s->fetch_add(int64_t(bytes));
    }
    return b;
  } catch (const cl::Error& err) {
    throw Error("device", fmt::format("allocating {} ({:.1f} MiB): {}", what, bytes / 1048576.0, describe(err)));
  }
}

void Device::fill(const cl::Buffer& buf, float value, size_t offset, size_t count) {
  if (count == 0) return;
  cl::Kernel k = kernel("raster", "fill_value");
  k.setArg(0, buf);
  k.setArg(1, value);
  k.setArg(2, cl_ulong(offset));
  k.setArg(3, cl_ulong(count));
  const size_t ls = 64;
  m_queue.enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(round_up(count, ls)), cl::NDRange(ls));
}

uint64_t Device::allocated_bytes() const { return uint64_t(std::max<int64_t>(0, m_allocated->load())); }

}  // namespace terracl
