// Landform curves (paper section 4.2, figure 4): a sketched polyline with a radius of influence.
// crest, cliff and river put elevation constraints on the curve plus a profile gradient on the
// side(s); free_crest, fault and ravine are gradient-only. Profile gradients are added to the field,
// so they superpose additively (crossing faults add up); elevation constraints replace each other.
#include "edit/state.hpp"

#include <terracl/error.hpp>

#include <fmt/format.h>

namespace terracl::edit {
namespace {

// Vertices with an elevation each: from [x, y, z] points, else from "elevation".
std::vector<Vec3> with_elevation(Params& p, std::vector<Vec3> pts) {
  size_t with_z = 0;
  for (const auto& v : pts) with_z += std::isnan(v.z) ? 0 : 1;
  if (with_z != 0 && with_z != pts.size()) param_error(p.where("points"), "give z for every point or for none");
  if (with_z == 0) {
    const double z = p.vlength("elevation");
    for (auto& v : pts) v.z = z;
  } else if (p.has("elevation")) {
    param_error(p.where("elevation"), "the points already carry elevations [x, y, z]");
  }
  return pts;
}

Primitive curve_primitive(const std::vector<Vec3>& pts, double radius, Profile profile, double amplitude) {
  Primitive pr;
  pr.shape = PrimitiveShape::Polyline;
  pr.points = xy(pts);
  pr.radius = radius;
  pr.profile = profile;
  pr.profile_amplitude = amplitude;
  return pr;
}

Profile parse_profile(Params& p, const std::string& def) {
  return p.choice("profile", def, {"sharp", "round"}) == "sharp" ? Profile::Sharp : Profile::Round;
}

// Elevation-constrained curves: crest, cliff, river.
Operation constrained(std::vector<Vec3> pts, double width, Primitive profile) {
  return [=](EditState& s) {
    add_profile_gradient(s.device(), s.buffers(), {profile});
    rasterize_polyline(s, pts, width);
    s.changed();
  };
}

Operation parse_crest(Params& p) {
  const auto pts = with_elevation(p, p.points("points", 2));
  const double radius = p.hlength("radius", {}, 0, true);
  const double height = p.vlength("height", 0.3 * radius);
  const Profile prof = parse_profile(p, "sharp");
  const double width = p.hlength("width", 0.0);
  return constrained(pts, width, curve_primitive(pts, radius, prof, height));
}

Operation parse_cliff(Params& p) {
  auto pts = with_elevation(p, p.points("points", 2));
  const double radius = p.hlength("radius", {}, 0, true);
  const double height = p.vlength("height");
  if (!(height > 0)) param_error(p.where("height"), fmt::format("expected a drop > 0 m, got {}", height));
  const std::string side = p.choice("side", "right", {"right", "left"});
  const double width = p.hlength("width", 0.0);
  std::vector<Vec3> dir = pts;
  if (side == "left") std::reverse(dir.begin(), dir.end());
  return constrained(pts, width, curve_primitive(dir, radius, Profile::Drop, height));
}

Operation parse_river(Params& p) {
  const auto pts = with_elevation(p, p.points("points", 2));
  const double radius = p.hlength("radius", {}, 0, true);
  const double bank = p.vlength("bank_height", 0.1 * radius);
  if (bank < 0) param_error(p.where("bank_height"), "expected >= 0 m (banks rise away from the river)");
  const double width = p.hlength("width", 0.0);
  return constrained(pts, width, curve_primitive(pts, radius, Profile::Round, -bank));
}

// Gradient-only curves. Per-vertex z (if given) scales the amplitude along the curve.
Operation gradient_only(Params& p, const std::string& amp_key, double sign, Profile prof) {
  const auto pts = p.points("points", 2);
  const double radius = p.hlength("radius", {}, 0, true);
  size_t with_z = 0;
  for (const auto& v : pts) with_z += std::isnan(v.z) ? 0 : 1;
  if (with_z != 0 && with_z != pts.size()) param_error(p.where("points"), "give z for every point or for none");
  Primitive pr = curve_primitive(pts, radius, prof, 1.0);
  if (with_z) {
    for (const auto& v : pts) pr.amplitude.push_back(sign * v.z);
    if (p.has(amp_key)) param_error(p.where(amp_key), "the points already carry per-vertex values [x, y, z]");
  } else {
    pr.profile_amplitude = sign * p.vlength(amp_key);
  }
  return [=](EditState& s) {
    add_profile_gradient(s.device(), s.buffers(), {pr});
    s.changed();
  };
}

Operation parse_free_crest(Params& p) { return gradient_only(p, "height", 1.0, parse_profile(p, "round")); }
Operation parse_ravine(Params& p) { return gradient_only(p, "depth", -1.0, parse_profile(p, "sharp")); }
Operation parse_fault(Params& p) { return gradient_only(p, "throw", 1.0, Profile::Step); }

}  // namespace

void add_curve_ops(std::vector<OpSpec>& ops) {
  ops.push_back({"crest", "elevation constraints on a curve plus steep flanks on both sides", parse_crest});
  ops.push_back({"cliff", "elevation constraints on the cliff top plus a steep drop on one side", parse_cliff});
  ops.push_back({"river", "elevation constraints along a river plus gently rising banks", parse_river});
  ops.push_back({"free_crest", "a ridge made of gradients only (no elevation constraint)", parse_free_crest});
  ops.push_back({"fault", "a step of a given throw across a curve, gradients only (faults add up)", parse_fault});
  ops.push_back({"ravine", "a V-shaped valley made of gradients only", parse_ravine});
}

}  // namespace terracl::edit
