// SPDX-License-Identifier: Apache-2.0
// Landform strokes placed relative to the ground: mountain_range, peak, volcano, canyon, and the
// relative forms of crest, river and cliff (no `elevation`). Each computes its change on the host
// (landform_shapes.cpp) and adds it with the sign it promises (landform.hpp): raising landforms
// never lower land, lowering ones never raise it. Sizes default from the relief around the stroke,
// its length and the cell size, so the default stroke makes a sensible landform on any DEM.
#include "authoring/ops_landforms.hpp"

#include "authoring/curve_shape.hpp"
#include "authoring/landform_detail.hpp"
#include "authoring/landform_shapes.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

namespace terracl::edit {
namespace {

double cell_of(const Grid& g) { return std::max(g.cell_x, g.cell_y); }

LandformLook parse_look(Params& p, double def_roughness, double def_age) {
  LandformLook l;
  l.seed = uint32_t(p.integer("seed", int(p.grid().seed & 0x7fffffffu), 0, std::numeric_limits<int>::max()));
  l.roughness = p.number("roughness", def_roughness, 0.0, 1.0);
  l.age = p.number("age", def_age, 0.0, 1.0);
  return l;
}

std::vector<Vec2> stroke_of(Params& p, const std::string& key, size_t min) {
  std::vector<Vec3> pts = p.points(key, min);
  for (const auto& v : pts)
    if (!std::isnan(v.z)) param_error(p.where(key), "give [x, y] points: the landform is placed relative to the ground");
  return xy(pts);
}

// The default scale of a landform from the ground around the stroke. On a level base its length
// is the only cue (0.06 x the length, at most 1.5 km); where the ground has relief, the landform
// matches it (0.4 x the relief, p95 - p05) and the length's share fades as the relief grows, so a
// long stroke across hills does not raise a wall above them. `flank` is the steepest slope a new
// flank should have there: the ground's p90 slope, at least 20 degrees (a level base: none).
struct DefaultScale {
  double size = 0, flank_tan = 0;
};
// `fade`: how fast the length's share fades with the relief (gone at a relief of 1 / fade of it).
// A valley's bed runs below the lowest ground it has passed, so the relief adds to its depth below
// the ground beside it: its length's share fades 4 times faster (a 25 km river across 400 m hills
// was 150 m below its lowest ground, 500 m below the ridges it crossed).
DefaultScale default_scale(EditState& s, const std::vector<Vec2>& pts, double fade = 1.0) {
  const double cell = cell_of(s.grid());
  const double L = pts.size() > 1 ? arc_lengths(pts).back() : 0.0;
  const GroundAround gnd = ground_around(s, pts, std::max(0.25 * L, 40 * cell));
  const double from_length = std::max(0.0, std::min(0.06 * L, 1500.0) - fade * gnd.relief);
  DefaultScale d;
  d.size = std::max({pts.size() > 1 ? 4 * cell : 6 * cell, 0.4 * gnd.relief, from_length});
  if (gnd.relief > 2 * cell) d.flank_tan = std::max(gnd.steep_tan, std::tan(20 * M_PI / 180));
  return d;
}
double default_size(EditState& s, const std::vector<Vec2>& pts) { return default_scale(s, pts).size; }

// A ridge's half-width: `factor` x its height, wider on gentle ground so that its mean flank (the
// profile falls over 0.8 of the half-width) is no steeper than the ground's steep slopes.
double ridge_half_width(const DefaultScale& d, double h, double factor) {
  return d.flank_tan > 0 ? std::max(factor * h, h / (0.8 * d.flank_tan)) : factor * h;
}

// Optional positive lengths, noted as the operation's reach when known at parse time.
std::optional<double> opt_v(Params& p, const std::string& key) {
  if (!p.has(key)) return std::nullopt;
  const double v = p.vlength(key);
  if (!(v > 0)) param_error(p.where(key), fmt::format("expected > 0 m, got {}", v));
  return v;
}
std::optional<double> opt_h(Params& p, const std::string& key) {
  if (!p.has(key)) return std::nullopt;
  return p.hlength(key, {}, 0, true);
}
// The full width: `width`, or twice `radius` (the half-width, as the studio's tools send it).
std::optional<double> full_width(Params& p) {
  if (p.has("width") && p.has("radius")) param_error(p.where("width"), "give either width (full) or radius (half of it), not both");
  if (p.has("radius")) return 2 * p.hlength("radius", {}, 0, true);
  return opt_h(p, "width");
}

// The landform's change with real detail (landform_detail.hpp), added with its sign and logged.
void finish(EditState& s, ShapeRaster& c, int sign, const DetailSpec& det, uint32_t seed, double size, double width,
            const std::vector<Vec2>* keep = nullptr, const ShapeRaster* to_bed = nullptr);

void log_change(EditState& s, const ShapeRaster& c, double size, double width) {
  size_t n = 0;
  float peak = 0;
  for (float v : c.v)
    if (std::abs(v) > 0.01f) ++n, peak = std::abs(v) > std::abs(peak) ? v : peak;
  auto& e = s.log().back();
  e["size_m"] = size;
  e["width_m"] = width;
  e["changed_cells"] = n;
  e["max_change_m"] = peak;
}

void finish(EditState& s, ShapeRaster& c, int sign, const DetailSpec& det, uint32_t seed, double size, double width,
            const std::vector<Vec2>* keep, const ShapeRaster* to_bed) {
  const auto t0 = std::chrono::steady_clock::now();
  const bool real = add_real_detail(s, c, det, seed, keep);
  // A valley's texture stays above its beds (a river's floor is not pitted below its bed).
  if (to_bed && to_bed->v.size() == c.v.size())
    for (size_t i = 0; i < c.v.size(); ++i)
      if (to_bed->v[i] > 0) c.v[i] = std::max(c.v[i], -to_bed->v[i]);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  log_change(s, add_change(s, c, sign), size, width);
  s.log().back()["detail"] = real ? "dictionary" : "procedural";
  if (real) s.log().back()["detail_ms"] = ms;
}

// The bed of a valley never rises downstream: the depth below the terrain at each vertex is at
// least `depth`, more where the ground ahead rises (a gorge through it).
struct MonotoneBed {
  EditState* s;
  double depth, taper;
  double bed = std::numeric_limits<double>::infinity();
  double operator()(const Vec2& p, double arc, double L) {
    if (arc == 0) bed = std::numeric_limits<double>::infinity();
    const double z = terrain_at(*s, p.x, p.y);
    const double end = taper > 0 ? std::clamp(std::min(arc, L - arc) / taper, 0.0, 1.0) : 1.0;
    bed = std::min(bed, z - depth * (0.3 + 0.7 * end));
    return std::max(0.0, z - bed) * std::min(1.0, 0.2 + 0.8 * end);
  }
};

Operation parse_range_like(Params& p, bool point, double def_spurs, double size_factor, double width_factor) {
  const DetailSpec det = parse_detail(p, "alpine");
  // A range's points may carry its crest height per vertex, [x, y, height above the ground].
  std::vector<double> per_vertex;
  std::vector<Vec2> stroke;
  if (point) {
    stroke = {p.point("center")};
  } else {
    const std::vector<Vec3> pts = p.points("points", 2);
    for (const auto& v : pts)
      if (!std::isnan(v.z)) per_vertex.push_back(v.z);
    if (!per_vertex.empty() && per_vertex.size() != pts.size()) param_error(p.where("points"), "give z for every point or for none");
    for (double z : per_vertex)
      if (!(z >= 0)) param_error(p.where("points"), fmt::format("a point's z is its height above the ground: expected >= 0 m, got {}", z));
    if (!per_vertex.empty() && p.has("height")) param_error(p.where("height"), "the points already carry heights [x, y, z]");
    stroke = xy(pts);
  }
  const auto height = opt_v(p, "height");
  const auto full = full_width(p);
  const auto width = full ? std::optional<double>(0.5 * *full) : std::nullopt;
  const double spurs = p.number("spurs", def_spurs, 0.0, 2.0);
  const LandformLook look = parse_look(p, 0.5, 0.3);
  if (width) p.note_reach(*width);
  else if (height) p.note_reach(width_factor * *height);
  else if (!per_vertex.empty()) p.note_reach(width_factor * *std::max_element(per_vertex.begin(), per_vertex.end()));
  return [=](EditState& s) {
    RidgeParams r;
    r.stroke = stroke;
    const DefaultScale d = default_scale(s, stroke);
    double h = height.value_or(size_factor * d.size);
    r.height = {h};
    if (!per_vertex.empty()) r.height = per_vertex, h = *std::max_element(per_vertex.begin(), per_vertex.end());
    r.width = std::max(min_half_width(s.grid()), width.value_or(ridge_half_width(d, h, width_factor)));
    r.spurs = spurs;
    r.look = look;
    ShapeRaster c = ridge_system(s.grid(), r);
    finish(s, c, +1, det, look.seed, h, r.width);
  };
}

Operation parse_mountain_range(Params& p) { return parse_range_like(p, false, 1.0, 1.0, 2.2); }
Operation parse_peak(Params& p) { return parse_range_like(p, true, 1.0, 1.0, 2.2); }

Operation parse_volcano(Params& p) {
  const Vec2 c = p.point("center");
  const auto height = opt_v(p, "height");
  const auto radius = opt_h(p, "radius");
  const double crater = p.number("crater", 0.15, 0.0, 0.5);
  const DetailSpec det = parse_detail(p, "eroded_hills");
  const LandformLook look = parse_look(p, 0.5, 0.3);
  if (radius) p.note_reach(*radius);
  else if (height) p.note_reach(3.5 * *height);
  return [=](EditState& s) {
    VolcanoParams v;
    v.center = c;
    // With no size given, the cone is at least 40 cells in radius (3.5 heights), so that its crater
    // spans several cells: sized from gentle ground alone it was a bump whose crater barely showed
    // (177 m high, 25 cells across, on the rolling hills of a 30 m DEM).
    const double least = radius ? 0.0 : 40 * cell_of(s.grid()) / 3.5;
    v.height = height.value_or(std::max(1.2 * default_size(s, {c}), least));
    v.radius = std::max(min_half_width(s.grid()), radius.value_or(3.5 * v.height));
    v.crater = crater;
    v.look = look;
    ShapeRaster ch = volcano(s.grid(), v);
    finish(s, ch, +1, det, look.seed, v.height, v.radius);
  };
}

Operation parse_valley_like(Params& p, double size_factor, double width_factor, int def_bands, double def_branches,
                            double floor, double meander, const std::string& style) {
  const DetailSpec det = parse_detail(p, style);
  const auto stroke = stroke_of(p, "points", 2);
  const auto depth = opt_v(p, "depth");
  const auto width = full_width(p);
  const int bands = p.integer("bands", def_bands, 0, 12);
  const double branches = p.number("branches", def_branches, 0.0, 2.0);
  const LandformLook look = parse_look(p, 0.5, 0.3);
  // The full width is given (as for the other curves); the reach is its half.
  if (width) p.note_reach(0.5 * *width);
  else if (depth) p.note_reach(width_factor * *depth);
  return [=](EditState& s) {
    ValleyParams v;
    v.stroke = stroke;
    // Water runs downhill: drawn from its low end, the valley is turned round so that its bed
    // does not have to cut a gorge through all the ground it climbs.
    if (terrain_at(s, stroke.back().x, stroke.back().y) > terrain_at(s, stroke.front().x, stroke.front().y))
      std::reverse(v.stroke.begin(), v.stroke.end());
    const DefaultScale scale = default_scale(s, stroke, 4.0);
    const double d = depth.value_or(size_factor * scale.size);
    v.width = std::max(min_half_width(s.grid()), width ? 0.5 * *width : width_factor * d);
    v.depth_at = MonotoneBed{&s, d, v.width};
    v.depth = d;
    v.wall_tan = scale.flank_tan;
    v.floor = floor;
    v.bands = bands;
    v.branches = branches;
    v.meander = meander;
    v.look = look;
    v.ground = &terrain_estimate(s);
    ShapeRaster to_bed;
    v.to_bed = &to_bed;
    ShapeRaster c = valley_system(s.grid(), v);
    for (float& x : c.v) x = -x;
    finish(s, c, -1, det, look.seed, d, v.width, nullptr, &to_bed);
  };
}

Operation parse_canyon(Params& p) { return parse_valley_like(p, 0.6, 2.2, 4, 1.0, 0.22, 0.12, "dissected_plateau"); }

}  // namespace

Operation relative_crest(Params& p) {
  const auto stroke = stroke_of(p, "points", 2);
  const auto height = opt_v(p, "height");
  const auto width = full_width(p);
  const std::string profile = p.choice("profile", "sharp", {"sharp", "round", "v", "u", "flat"});
  const double spurs = p.number("spurs", 0.5, 0.0, 2.0);
  const auto taper = p.has("taper") ? std::optional<double>(p.hlength("taper", 0.0)) : std::nullopt;
  const LandformLook look = parse_look(p, 0.4, 0.0);
  const DetailSpec det = parse_detail(p, "alpine");
  if (width) p.note_reach(0.5 * *width);
  else if (height) p.note_reach(2.2 * *height);
  const double sharpness = profile == "sharp" || profile == "v" ? 1.0 : profile == "u" ? 0.3 : 0.0;
  return [=](EditState& s) {
    RidgeParams r;
    r.stroke = stroke;
    const DefaultScale d = default_scale(s, stroke);
    const double h = height.value_or(0.6 * d.size);
    r.height = {h};
    r.width = std::max(min_half_width(s.grid()), width ? 0.5 * *width : ridge_half_width(d, h, 2.2));
    r.spurs = spurs;
    r.sharpness = sharpness;
    r.free_line = false;
    r.taper = taper.value_or(-1.0);
    r.look = look;
    ShapeRaster c = ridge_system(s.grid(), r);
    // A crest keeps the line and height it was drawn with: the detail leaves the line itself.
    finish(s, c, +1, det, look.seed, h, r.width, &stroke);
  };
}

Operation relative_river(Params& p) {
  return parse_valley_like(p, 0.15, 4.0, 0, 0.6, 0.12, 0.25, "eroded_hills");
}

Operation relative_cliff(Params& p) {
  const auto stroke = stroke_of(p, "points", 2);
  if (p.has("drop") && p.has("height")) param_error(p.where("drop"), "give the drop as `drop` or `height`, not both");
  const auto drop = p.has("drop") ? opt_v(p, "drop") : opt_v(p, "height");
  const std::string side = p.choice("side", "right", {"right", "left"});
  const auto back = opt_h(p, "back");
  const int bands = p.integer("bands", 3, 0, 12);
  const double talus = p.number("scree", 0.3, 0.0, 0.9);
  const LandformLook look = parse_look(p, 0.5, 0.25);
  const DetailSpec det = parse_detail(p, "dissected_plateau");
  if (back) p.note_reach(*back);
  else if (drop) p.note_reach(6 * *drop);
  return [=](EditState& s) {
    EscarpmentParams e;
    e.stroke = stroke;
    e.drop = drop.value_or(0.5 * default_size(s, stroke));
    e.back = std::max(min_half_width(s.grid()), back.value_or(6 * e.drop));
    e.left = side == "right";  // the low side is `side`: the plateau is on the other one
    e.bands = bands;
    e.talus = talus;
    e.look = look;
    ShapeRaster c = escarpment(s.grid(), e);
    finish(s, c, +1, det, look.seed, e.drop, e.back);
  };
}

bool is_relative(Params& p, const std::string& key) {
  if (p.has("elevation")) return false;
  for (const auto& v : p.raw(key))
    if (v.is_array() && v.size() >= 3) return false;
  return true;
}

void add_landform_ops(std::vector<OpSpec>& ops) {
  ops.push_back({"mountain_range", "one stroke: a range of summits and saddles with spurs branching down both flanks", parse_mountain_range});
  ops.push_back({"peak", "a summit at a point with spurs radiating from it", parse_peak});
  ops.push_back({"volcano", "a concave cone with a summit crater and radial ridges and gullies", parse_volcano});
  ops.push_back({"canyon", "a canyon along a stroke: walls in rock bands, a floor, side canyons", parse_canyon});
}

}  // namespace terracl::edit
