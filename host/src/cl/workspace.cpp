// SPDX-License-Identifier: Apache-2.0
// The per-device buffer cache of workspace.hpp.
#include "workspace.hpp"

#include <terracl/error.hpp>

#include <cstdlib>
#include <vector>

namespace terracl {

PinnedStaging::PinnedStaging(Device& d, size_t bytes) : m_queue(d.queue()), m_bytes(bytes) {
  try {
    m_buffer = cl::Buffer(d.context(), CL_MEM_READ_WRITE | CL_MEM_ALLOC_HOST_PTR, bytes ? bytes : 4);
    m_ptr = m_queue.enqueueMapBuffer(m_buffer, CL_TRUE, CL_MAP_READ | CL_MAP_WRITE, 0, bytes ? bytes : 4);
  } catch (const cl::Error& e) {
    throw Error("device", fmt::format("allocating {:.1f} MiB of pinned host staging: {}", bytes / 1048576.0, describe(e)));
  }
}

PinnedStaging::~PinnedStaging() {
  try {
    m_queue.enqueueUnmapMemObject(m_buffer, m_ptr);
    m_queue.finish();
  } catch (const cl::Error&) {  // a destructor must not throw; the context's release frees it anyway
  }
}

bool use_pinned_staging(Device& d) {
  if (const char* v = std::getenv("TERRACL_STAGING"); v && *v) {
    const std::string s = v;
    if (s == "pinned") return true;
    if (s == "direct") return false;
    fail("device", "TERRACL_STAGING must be pinned or direct, got '{}'", s);
  }
  try {
    return d.device().getInfo<CL_DEVICE_HOST_UNIFIED_MEMORY>() == CL_FALSE;
  } catch (const cl::Error&) {
    return false;
  }
}

std::shared_ptr<PinnedStaging> Workspace::take_pinned(Device& d, int width, int height, const std::string& slot,
                                                      size_t bytes) {
  std::shared_ptr<PinnedStaging> dropped;
  {
    std::lock_guard<std::mutex> lock(m_mutex);
    if (width == m_width && height == m_height) {
      auto it = m_pinned.find(slot);
      if (it != m_pinned.end()) {
        std::shared_ptr<PinnedStaging> p = std::move(it->second);
        m_pinned.erase(it);
        if (p->bytes() == bytes) return p;
        dropped = std::move(p);
      }
    }
  }
  dropped.reset();
  return std::make_shared<PinnedStaging>(d, bytes);
}

void Workspace::put_pinned(int width, int height, const std::string& slot, std::shared_ptr<PinnedStaging> p) {
  if (!p) return;
  std::shared_ptr<PinnedStaging> old;
  std::lock_guard<std::mutex> lock(m_mutex);
  if (width != m_width || height != m_height) return;
  old = std::move(m_pinned[slot]);
  m_pinned[slot] = std::move(p);
}

namespace {
// Never destroyed: releasing cached OpenCL objects during static destruction, after the platform
// library may have torn itself down, aborts (oclgrind: "corrupted double-linked list" at exit).
// The process's exit frees them.
std::mutex& g_mutex = *new std::mutex;
std::shared_ptr<Workspace>& g_workspace = *new std::shared_ptr<Workspace>;
std::shared_ptr<Workspace> current() {
  std::lock_guard<std::mutex> lock(g_mutex);
  return g_workspace;
}
}  // namespace

std::shared_ptr<Workspace> workspace_for(Device& d) {
  std::shared_ptr<Workspace> old;  // released after the lock (its buffers' callbacks run then)
  std::lock_guard<std::mutex> lock(g_mutex);
  if (g_workspace && g_workspace->context() == d.context()()) return g_workspace;
  old = std::move(g_workspace);
  g_workspace = std::make_shared<Workspace>(d.context()());
  if (old) old->release();
  return g_workspace;
}

uint64_t release_workspace() {
  auto w = current();
  return w ? w->release() : 0;
}

uint64_t workspace_cached_bytes() {
  auto w = current();
  return w ? w->cached_bytes() : 0;
}

bool workspace_enabled() {
  const char* v = std::getenv("TERRACL_NO_WORKSPACE");
  return !(v && *v && std::string(v) != "0");
}

cl::Buffer Workspace::take(Device& d, int width, int height, const std::string& slot, size_t bytes,
                           cl_mem_flags flags, const std::string& what, uint64_t* reused) {
  std::vector<cl::Buffer> dropped;  // released outside the lock (the destructor callback runs then)
  std::map<std::string, std::shared_ptr<PinnedStaging>> pinned_dropped;
  {
    std::lock_guard<std::mutex> lock(m_mutex);
    if (width != m_width || height != m_height) {
      for (auto& [name, s] : m_slots) dropped.push_back(std::move(s.buffer));
      m_slots.clear();
      pinned_dropped.swap(m_pinned);
      m_width = width;
      m_height = height;
    }
    auto it = m_slots.find(slot);
    if (it != m_slots.end()) {
      Slot s = std::move(it->second);
      m_slots.erase(it);
      if (s.bytes == bytes && s.flags == flags) {
        if (reused) *reused += bytes;
        return s.buffer;
      }
      dropped.push_back(std::move(s.buffer));
    }
  }
  dropped.clear();
  pinned_dropped.clear();
  return d.buffer(bytes, flags, what);
}

void Workspace::put(int width, int height, const std::string& slot, cl::Buffer b) {
  if (!b()) return;
  size_t bytes = 0;
  cl_mem_flags flags = 0;
  try {
    bytes = b.getInfo<CL_MEM_SIZE>();
    flags = b.getInfo<CL_MEM_FLAGS>();
  } catch (const cl::Error&) {
    return;
  }
  cl::Buffer old;
  std::lock_guard<std::mutex> lock(m_mutex);
  if (width != m_width || height != m_height) return;  // another size took over meanwhile
  Slot& s = m_slots[slot];
  old = std::move(s.buffer);  // a concurrent solve's copy: keep one
  s = Slot{std::move(b), bytes, flags};
}

uint64_t Workspace::release() {
  std::map<std::string, Slot> gone;
  std::map<std::string, std::shared_ptr<PinnedStaging>> pinned_gone;
  {
    std::lock_guard<std::mutex> lock(m_mutex);
    gone.swap(m_slots);
    pinned_gone.swap(m_pinned);
  }
  uint64_t n = 0;
  for (auto& [name, s] : gone) n += s.bytes;
  return n;
}

uint64_t Workspace::cached_bytes() const {
  std::lock_guard<std::mutex> lock(m_mutex);
  uint64_t n = 0;
  for (const auto& [name, s] : m_slots) n += s.bytes;
  return n;
}

WorkspaceBuffers::WorkspaceBuffers(Device& d, int width, int height) : m_d(d), m_w(width), m_h(height) {
  if (workspace_enabled()) m_ws = workspace_for(d);
}

WorkspaceBuffers::~WorkspaceBuffers() {
  if (m_ws)
    for (auto& [slot, b] : m_taken) m_ws->put(m_w, m_h, slot, std::move(b));
}

cl::Buffer WorkspaceBuffers::take(const std::string& slot, size_t bytes, cl_mem_flags flags, const std::string& what) {
  if (!m_ws) return m_d.buffer(bytes, flags, what);
  cl::Buffer b = m_ws->take(m_d, m_w, m_h, slot, bytes, flags, what, &m_reused);
  m_taken.emplace_back(slot, b);
  return b;
}

}  // namespace terracl
