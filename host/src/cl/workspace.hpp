// SPDX-License-Identifier: Apache-2.0
#pragma once
// Per-device cache of the reconstruction's level-0 buffers: the studio, the
// edit state and `terracl bench` solve the same grid again and again, and on a GPU the creation
// and first touch of two or four fresh N-float buffers cost more than the whole V-cycle work.
//
// Bounded: one workspace per process, bound to one device (context) and one grid size. A solve of
// another size, or on another Device, releases every cached buffer before it allocates its own;
// Device::buffer() also drops the idle cache before it refuses an allocation for lack of memory,
// so the cache never turns a solve that fitted into a failure. (One per process rather than a
// Device member: a Device destroyed while caching would otherwise keep its buffers and context
// alive with nobody to release them; here the next solve anywhere, or release_workspace(), does.)
// Buffers are taken out while in use (two solves at once on one Device get separate buffers) and
// put back afterwards; their contents are never relied upon (every solve writes them first).
#include <terracl/device.hpp>

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

namespace terracl {

/// Host memory a discrete device reads and writes by DMA at full speed (pinned): a
/// CL_MEM_ALLOC_HOST_PTR buffer mapped once for its whole life. Used as the host pointer of
/// clEnqueueWrite/ReadBuffer on device buffers (NVIDIA's recommended path: pageable memory goes
/// through the driver's own bounce buffer at about a third of the speed). Host memory only: not
/// counted in Device::allocated_bytes().
class PinnedStaging {
 public:
  PinnedStaging(Device& d, size_t bytes);
  ~PinnedStaging();
  PinnedStaging(const PinnedStaging&) = delete;
  PinnedStaging& operator=(const PinnedStaging&) = delete;
  float* data() { return static_cast<float*>(m_ptr); }
  size_t bytes() const { return m_bytes; }

 private:
  cl::CommandQueue m_queue;
  cl::Buffer m_buffer;
  void* m_ptr = nullptr;
  size_t m_bytes = 0;
};

/// Whether large transfers of `d` go through PinnedStaging: TERRACL_STAGING=pinned|direct forces
/// it; by default pinned where the device does not share the host's memory
/// (CL_DEVICE_HOST_UNIFIED_MEMORY false: discrete GPUs), direct on CPU devices such as PoCL
/// (where staging is one more copy for nothing).
bool use_pinned_staging(Device& d);

class Workspace {
 public:
  explicit Workspace(cl_context context) : m_context(context) {}
  /// The context the cached buffers belong to (identity only; the buffers retain it).
  cl_context context() const { return m_context; }
  /// A buffer of exactly `bytes` for `slot` of a `width` x `height` solve: the cached one when
  /// there is one, else a new one from d.buffer() (`what` names it in errors). A different grid
  /// size than the cached one releases the whole cache first. `reused` (optional) gets the bytes
  /// taken from the cache (already counted in d.allocated_bytes() before the call).
  cl::Buffer take(Device& d, int width, int height, const std::string& slot, size_t bytes, cl_mem_flags flags,
                  const std::string& what, uint64_t* reused = nullptr);
  /// Returns a buffer taken for `slot` of a `width` x `height` solve to the cache (kept only while
  /// that grid size is the cached one).
  void put(int width, int height, const std::string& slot, cl::Buffer b);
  /// Same for pinned host staging of `bytes` (never counted as device memory).
  std::shared_ptr<PinnedStaging> take_pinned(Device& d, int width, int height, const std::string& slot, size_t bytes);
  void put_pinned(int width, int height, const std::string& slot, std::shared_ptr<PinnedStaging> p);
  /// Releases every idle cached buffer; returns the bytes released.
  uint64_t release();
  /// Bytes of the idle cached buffers.
  uint64_t cached_bytes() const;

 private:
  struct Slot {
    cl::Buffer buffer;
    size_t bytes = 0;
    cl_mem_flags flags = 0;
  };
  cl_context m_context;
  mutable std::mutex m_mutex;
  int m_width = 0, m_height = 0;
  std::map<std::string, Slot> m_slots;
  std::map<std::string, std::shared_ptr<PinnedStaging>> m_pinned;
};

/// The buffers of one solve stage (the multigrid hierarchy, the refinement's vectors) taken from
/// the workspace of `d` for a `width` x `height` solve and put back when this goes out of scope;
/// plain buffers from d.buffer() when the cache is off (TERRACL_NO_WORKSPACE=1). Their contents
/// are never relied upon: the caller writes (or fills) every buffer it takes before reading it.
class WorkspaceBuffers {
 public:
  WorkspaceBuffers(Device& d, int width, int height);
  ~WorkspaceBuffers();
  WorkspaceBuffers(const WorkspaceBuffers&) = delete;
  WorkspaceBuffers& operator=(const WorkspaceBuffers&) = delete;
  cl::Buffer take(const std::string& slot, size_t bytes, cl_mem_flags flags, const std::string& what);
  /// Bytes taken from the cache: already counted in d.allocated_bytes() before the solve, so a
  /// peak-memory figure adds them back.
  uint64_t reused() const { return m_reused; }

 private:
  Device& m_d;
  int m_w, m_h;
  std::shared_ptr<Workspace> m_ws;  // null: cache off
  uint64_t m_reused = 0;
  std::vector<std::pair<std::string, cl::Buffer>> m_taken;
};

/// The process's workspace for `d`: the current one when it is bound to d's context, else a new
/// one (the previous one is released once its last solve puts its buffers back).
std::shared_ptr<Workspace> workspace_for(Device& d);
/// Releases the idle cached buffers; returns their bytes.
uint64_t release_workspace();
/// Bytes of the idle cached buffers.
uint64_t workspace_cached_bytes();

/// TERRACL_NO_WORKSPACE=1 turns the cache off (every solve allocates afresh, as before).
bool workspace_enabled();

}  // namespace terracl
