// SPDX-License-Identifier: Apache-2.0
// Stages that only need the data model: nodata filling.
#include "pipeline/builtin.hpp"

#include <terracl/error.hpp>

namespace terracl {

void register_core_stages(StageRegistry& r) {
  r.add({"fill_nodata",
         "Replace nodata cells by the harmonic (Laplace, metric cells) interpolation of their valid neighbours, solved exactly.",
         DataKind::Heightfield,
         DataKind::Heightfield,
         {},
         [](StageContext& c) { fill_nodata_harmonic(c.height()); }});
}

void register_core_benches(BenchRegistry&) {}

}  // namespace terracl
