// SPDX-License-Identifier: Apache-2.0
#include "alloc_scope.hpp"

#include <algorithm>

namespace terracl {

namespace {
thread_local std::vector<std::shared_ptr<std::atomic<int64_t>>> t_scopes;
}

AllocationScope::AllocationScope() : m_live(std::make_shared<std::atomic<int64_t>>(0)) { t_scopes.push_back(m_live); }

AllocationScope::~AllocationScope() {
  auto it = std::find(t_scopes.begin(), t_scopes.end(), m_live);
  if (it != t_scopes.end()) t_scopes.erase(it);
}

uint64_t AllocationScope::live() const { return uint64_t(std::max<int64_t>(0, m_live->load())); }

std::vector<std::shared_ptr<std::atomic<int64_t>>> open_allocation_scopes() { return t_scopes; }

}  // namespace terracl
