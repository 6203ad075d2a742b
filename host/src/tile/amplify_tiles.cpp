// SPDX-License-Identifier: Apache-2.0
// How `amplify` tiles (docs/scale.md, "Tiled amplify"). Every per-patch choice follows global output
// coordinates (amplify.cpp), so a tile needs only (1) its window with a halo of amplify_halo input
// cells, (2) the window's place in the whole input, and (3) the detail blend's correlations, which
// a prepass measures once on the whole input (the central cells of each step's input) and every
// tile receives: then its core equals the untiled output bit for bit.
#include "tile/amplify_tiles.hpp"

#include <fmt/format.h>

#include <terracl/amplify.hpp>

namespace terracl {

AmplifyOptions amplify_options(const json& options);  // amplify/amplify_stage.cpp

namespace tile {

StageTiling amplify_tiling(const json& o) {
  StageTiling t;
  auto given = [&o](const char* k) { return o.contains(k) && !o.at(k).is_null(); };
  if (given("exemplar"))
    t.limit = "with exemplars it learns its dictionaries in the run (and calibrates them on the whole raster); learn "
              "one first (`terracl dictionary learn EXEMPLAR -o D.tdic`) and give it as \"dictionary\"";
  else if (given("style_mask"))
    t.limit = "a style mask is read whole and blended over the whole raster; amplify with one dictionary, or untiled";
  else if (!given("dictionary"))
    t.limit = "it needs a \"dictionary\" (.tdic) to run tiled";
  else if (o.at("mode").get<std::string>() == "faithful")
    t.limit = "faithful mode has no tiled form yet (its regression and block correction are local, but untested "
              "tiled); use mode detail, or run it untiled";
  if (!t.limit.empty()) return t;
  const std::string file = o.at("dictionary").get<std::string>();
  const AmplifyOptions ao = amplify_options(o);
  const Dictionary d = load_dictionary(file);
  t.kind = TileKind::Local;
  t.up = ao.factor;
  t.halo = amplify_halo(d, ao);
  t.prepass = [file, ao](const std::function<Heightfield(int, int, int, int)>& read, int w, int h) {
    const Dictionary dict = load_dictionary(file);
    std::string s;
    for (float r : amplify_correlations(read, w, h, dict, ao)) s += fmt::format("{}{}", s.empty() ? "" : " ", r);
    return s;
  };
  return t;
}

}  // namespace tile
}  // namespace terracl
