// SPDX-License-Identifier: Apache-2.0
// A minimal fork-join over index ranges. std::thread rather than OpenMP: OMP_PROC_BIND-style
// pinning halves PoCL's speed on the same machine, and the work here is coarse-grained anyway.
#include <terracl/amplify.hpp>

#include <algorithm>
#include <exception>
#include <thread>

namespace terracl {

void parallel_for(size_t n, int threads, const std::function<void(size_t, size_t)>& body) {
  if (n == 0) return;
  size_t t = threads > 0 ? size_t(threads) : std::max(1u, std::thread::hardware_concurrency());
  t = std::min(t, n);
  if (t == 1) {
    body(0, n);
    return;
  }
  std::vector<std::thread> pool;
  std::vector<std::exception_ptr> errors(t);
  for (size_t k = 0; k < t; ++k) {
    const size_t b = n * k / t, e = n * (k + 1) / t;
    pool.emplace_back([&, k, b, e] {
      try {
        body(b, e);
      } catch (...) {
        errors[k] = std::current_exception();
      }
    });
  }
  for (auto& th : pool) th.join();
  for (auto& e : errors)
    if (e) std::rethrow_exception(e);
}

size_t row_parts(size_t cells, int rows) {
  if (cells < (size_t(1) << 16) || rows < 1) return 1;
  return std::clamp<size_t>(std::thread::hardware_concurrency(), 1, size_t(rows));
}

void for_row_ranges(int rows, size_t parts, const std::function<void(size_t, int, int)>& body) {
  parallel_for(parts, int(parts), [&](size_t b, size_t e) {
    for (size_t k = b; k < e; ++k) body(k, int(size_t(rows) * k / parts), int(size_t(rows) * (k + 1) / parts));
  });
}

}  // namespace terracl
