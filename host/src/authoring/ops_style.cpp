// SPDX-License-Identifier: Apache-2.0
// Styles of real detail (landform_detail.hpp): the `detail` keys every landform stroke reads, and
// the `style` operation that paints a style on a region, as the spatialised-style paper paints
// exemplars: strokes drawn there later take its detail, and with `retexture` (the default) the
// terrain already there is re-detailed now.
#include "authoring/landform_detail.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <limits>

namespace terracl::edit {

const std::vector<std::string>& bundled_styles() {
  static const std::vector<std::string> names{"alpine", "eroded_hills", "dissected_plateau"};
  return names;
}

bool is_style_name(const std::string& name) {
  const auto& b = bundled_styles();
  return name == "local" || std::find(b.begin(), b.end(), name) != b.end();
}

namespace {
std::string style_choices() {
  std::string s;
  for (const auto& n : bundled_styles()) s += n + ", ";
  return s + "local";
}
}  // namespace

DetailSpec parse_detail(Params& p, const std::string& fallback) {
  DetailSpec d;
  d.fallback = fallback;
  if (p.has("detail")) {
    d.style = p.string("detail");
    if (d.style != "auto" && d.style != "procedural" && !is_style_name(d.style))
      param_error(p.where("detail"), fmt::format("expected auto, procedural or a style ({}), got '{}'", style_choices(), d.style));
  }
  d.strength = p.number("detail_strength", 1.0, 0.0, 3.0);
  return d;
}

namespace {

Operation parse_style(Params& p) {
  const std::string style = p.string("style");
  if (!is_style_name(style)) param_error(p.where("style"), fmt::format("expected a style ({}), got '{}'", style_choices(), style));
  const Region r = parse_region(p, false);
  const Grid& g = p.grid();
  const double falloff = p.hlength("falloff", 8 * std::max(g.cell_x, g.cell_y));
  p.note_reach(falloff);
  const bool retexture = p.boolean("retexture", true);
  const double strength = p.number("strength", 1.0, 0.0, 3.0);
  const uint32_t seed = uint32_t(p.integer("seed", int(g.seed & 0x7fffffffu), 0, std::numeric_limits<int>::max()));
  return [=](EditState& s) {
    const HostRegion w = region_on_host(s, r, falloff);
    ShapeRaster c = paint_style(s, style, w, retexture, strength, seed);
    auto& e = s.log().back();
    e["style"] = style;
    if (c.box.empty()) return;
    add_change(s, c, 0);
    float peak = 0;
    for (float v : c.v) peak = std::max(peak, std::abs(v));
    e["max_change_m"] = peak;
  };
}

}  // namespace

void add_style_ops(std::vector<OpSpec>& ops) {
  ops.push_back({"style",
                 "paint a style of real detail on a region (alpine, eroded_hills, dissected_plateau, local): later "
                 "strokes there take it, and the terrain there is re-detailed (retexture)",
                 parse_style});
}

}  // namespace terracl::edit
