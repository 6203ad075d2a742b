// SPDX-License-Identifier: Apache-2.0
#pragma once
// Device bytes allocated by one piece of work, however other work's buffers come and go.
#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

namespace terracl {

/// Counts the device buffers that this thread allocates through Device::buffer() while the scope
/// is open, for as long as each lives (its release callback subtracts it, even after the scope
/// closed). A solve's peak figure reads live() instead of a difference of the device's total: that
/// total also drops when the workspace releases another grid's cache mid-solve, or when an earlier
/// stage's release lands late, and a difference then under-counts (it wrapped around before).
/// Scopes nest; a buffer counts in every scope open on its thread.
class AllocationScope {
 public:
  AllocationScope();
  ~AllocationScope();
  AllocationScope(const AllocationScope&) = delete;
  AllocationScope& operator=(const AllocationScope&) = delete;
  uint64_t live() const;

 private:
  std::shared_ptr<std::atomic<int64_t>> m_live;
};

/// The counters of this thread's open scopes (Device::buffer adds a new buffer's bytes to each).
std::vector<std::shared_ptr<std::atomic<int64_t>>> open_allocation_scopes();

}  // namespace terracl
