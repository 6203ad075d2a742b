// SPDX-License-Identifier: Apache-2.0
// `downsample`: block-mean reduction by an integer factor. It makes the low-resolution inputs of
// the amplification demo and evaluation (the same block mean that amplify's bias correction
// matches), so amplify(downsample(h)) can be compared with h.
#include <terracl/amplify.hpp>
#include <terracl/error.hpp>

#include <algorithm>

#include "pipeline/builtin.hpp"

namespace terracl {

void register_downsample_stage(StageRegistry& r) {
  r.add({"downsample",
         "Reduce a heightfield by an integer factor with block means, keeping its georeferencing (cells factor "
         "times larger); incomplete blocks at the east/south edges are dropped.",
         DataKind::Heightfield,
         DataKind::Heightfield,
         {OptionSpec{"factor", OptionType::Int, 4, "", "Block size: each output cell is the mean of factor x factor cells"}
              .range(1, 4096)},
         [](StageContext& c) {
           const int f = c.get<int>("factor");
           if (f < 1 || f > 4096) fail(c.tag, "factor must be in 1..4096, got {}", f);
           Heightfield& h = c.height();
           if (h.width < f || h.height < f)
             fail(c.tag, "a {} x {} raster has no complete {} x {} block; use a factor <= {}", h.width, h.height, f, f,
                  std::min(h.width, h.height));
           require_finite(h, c.tag, "the input");
           h = block_mean(h, f);
         }});
}

}  // namespace terracl
