// SPDX-License-Identifier: Apache-2.0
// Launch shapes: see host/include/terracl/launch.hpp and kernels/launch.clh.
#include <terracl/launch.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <mutex>
#include <vector>

namespace terracl {
namespace {

// Rows shape: today's local size of one-work-item-per-row launches (PoCL compiles once per local
// size, so it is fixed rather than derived from each grid).
constexpr size_t kRowsLocal = 4;
// At most this many work-items per group in the wide shape: 8 warps of 32 on an NVIDIA GPU, enough
// to hide latency while leaving several groups per multiprocessor.
constexpr size_t kMaxGroup = 256;

std::mutex g_mutex;
std::map<cl_device_id, std::map<std::string, GroupShape>> g_shapes;

std::string kernel_name(const cl::Kernel& k) {
  std::string n = k.getInfo<CL_KERNEL_FUNCTION_NAME>();
  return n.c_str();  // some drivers count the terminating NUL in the size
}

}  // namespace

GroupShape group_shape(Device& d, const cl::Kernel& k) {
  if (d.info().launch != "wide") return GroupShape{1, kRowsLocal};
  const std::string name = kernel_name(k);
  std::lock_guard<std::mutex> lock(g_mutex);
  auto& shapes = g_shapes[d.device()()];
  auto it = shapes.find(name);
  if (it != shapes.end()) return it->second;
  // The preferred multiple is the warp / SIMD width: a full one along x makes each warp read one
  // contiguous run of a row; the rest of the group goes along y.
  const size_t max = std::max<size_t>(1, k.getWorkGroupInfo<CL_KERNEL_WORK_GROUP_SIZE>(d.device()));
  const size_t pref =
      std::clamp<size_t>(k.getWorkGroupInfo<CL_KERNEL_PREFERRED_WORK_GROUP_SIZE_MULTIPLE>(d.device()), 1, max);
  GroupShape s;
  s.x = std::min(pref, kMaxGroup);
  s.y = std::max<size_t>(1, std::min(max, kMaxGroup) / s.x);
  shapes.emplace(name, s);
  return s;
}

std::map<std::string, GroupShape> group_shapes(Device& d) {
  std::lock_guard<std::mutex> lock(g_mutex);
  auto it = g_shapes.find(d.device()());
  return it == g_shapes.end() ? std::map<std::string, GroupShape>{} : it->second;
}

void launch_grid(Device& d, cl::Kernel& k, size_t w, size_t h) {
  if (w == 0 || h == 0) return;
  const GroupShape s = group_shape(d, k);
  const size_t gx = d.info().launch == "wide" ? round_up(w, s.x) : 1;
  d.queue().enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(gx, round_up(h, s.y)), cl::NDRange(s.x, s.y));
}

std::map<std::string, GroupShape> cell_kernel_groups(Device& d) {
  // Every kernel written with kernels/launch.clh's FOR_X, by file.
  static const std::pair<const char*, std::vector<const char*>> kCellKernels[] = {
      {"multigrid",
       {"smooth_rb0", "jacobi0", "residual_restrict0", "prolong_correct0", "smooth9", "jacobi9", "residual_restrict9",
        "prolong_correct9", "galerkin0", "galerkin9", "fuse_restrict", "prolong_assign"}},
      {"gradient", {"extract_staggered", "divergence", "extract_central", "central_to_staggered"}},
      {"tensor", {"apply_tensor_field", "primitive_field", "add_potential_gradient"}},
      {"render", {"render_rows"}},
      {"render_terrain", {"terrain_rows"}}};
  std::map<std::string, GroupShape> out;
  for (const auto& [file, names] : kCellKernels)
    for (const char* n : names) out[n] = group_shape(d, d.kernel(file, n));
  return out;
}

std::string describe_launch(Device& d) {
  if (d.info().launch != "wide") return fmt::format("rows (one work-item per row, groups of {} rows)", kRowsLocal);
  std::string out = "wide (one work-item per cell, x fastest)";
  const auto shapes = group_shapes(d);
  if (shapes.empty()) return out;
  // Kernels grouped by shape: "groups 32x8: smooth_rb0, jacobi0; 16x16: ...".
  std::map<std::pair<size_t, size_t>, std::string> by;
  for (const auto& [n, s] : shapes) {
    auto& l = by[{s.x, s.y}];
    l += (l.empty() ? "" : ", ") + n;
  }
  out += ", groups";
  for (const auto& [s, names] : by) out += fmt::format(" {}x{}: {};", s.first, s.second, names);
  out.pop_back();
  return out;
}

}  // namespace terracl
