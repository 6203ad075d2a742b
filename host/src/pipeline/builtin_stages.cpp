// SPDX-License-Identifier: Apache-2.0
#include "pipeline/builtin.hpp"

namespace terracl {

StageRegistry& StageRegistry::instance() {
  static StageRegistry r = [] {
    StageRegistry reg;
    register_io_stages(reg);
    register_core_stages(reg);
    register_reconstruct_stages(reg);
    register_edit_stages(reg);
    register_amplify_stages(reg);
    register_analysis_stages(reg);
    register_erosion_stages(reg);
    return reg;
  }();
  return r;
}

BenchRegistry& BenchRegistry::instance() {
  static BenchRegistry r = [] {
    BenchRegistry reg;
    register_core_benches(reg);
    register_reconstruct_benches(reg);
    register_edit_benches(reg);
    register_amplify_benches(reg);
    register_analysis_benches(reg);
    register_render_benches(reg);
    register_erosion_benches(reg);
    return reg;
  }();
  return r;
}

}  // namespace terracl
