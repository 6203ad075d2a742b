// SPDX-License-Identifier: Apache-2.0
#pragma once
// One work-item per row launches with a fixed local size: PoCL compiles a kernel once per
// (kernel, local size), so letting the runtime pick a local size from each grid size would
// recompile (28-180 ms) for every new grid size. The global size is rounded up; kernels
// return early for rows past the end.
#include <terracl/device.hpp>

namespace terracl {

inline size_t row_local_size(Device& d) { return d.info().launch == "wide" ? 64 : 4; }

/// Sets the arguments of `k` in order (the types must match the kernel's: cast doubles to float).
template <typename... A>
void set_args(cl::Kernel& k, const A&... a) {
  cl_uint i = 0;
  (k.setArg(i++, a), ...);
}

/// `local` > 0 overrides the work-group size (kernels whose rows carry more work).
inline void launch_rows(Device& d, cl::Kernel& k, size_t rows, size_t local = 0) {
  if (rows == 0) return;
  const size_t ls = local ? local : row_local_size(d);
  d.queue().enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(round_up(rows, ls)), cl::NDRange(ls));
}

}  // namespace terracl
