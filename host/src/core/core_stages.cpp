// Stages that only need the data model: nodata filling.
#include "pipeline/builtin.hpp"

#include <terracl/error.hpp>

namespace terracl {

void register_core_stages(StageRegistry& r) {
  r.add({"fill_nodata",
         "Replace nodata cells by a harmonic (Laplace) interpolation of their valid neighbours.",
         DataKind::Heightfield,
         DataKind::Heightfield,
         {},
         [](StageContext& c) { fill_nodata_harmonic(c.height()); }});
}

void register_core_benches(BenchRegistry&) {}

}  // namespace terracl
