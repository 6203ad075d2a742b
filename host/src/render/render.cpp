// SPDX-License-Identifier: Apache-2.0
// Preview rendering on the host. Hillshade follows gdaldem's Horn algorithm term by term (same
// constants, same 1 + 254 * cos mapping, same rounding) so that `gdaldem hillshade` and
// `terracl render --mode hillshade` agree within one grey level (gdaldem uses an approximate
// inverse square root).

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/render.hpp>

#include "render/render_internal.hpp"
#include "render/render_window.hpp"

namespace terracl::render {

namespace {

using detail::to_byte;

}  // namespace

Mode mode_from_name(const std::string& name) {
  std::string n = name;
  std::transform(n.begin(), n.end(), n.begin(), [](unsigned char ch) { return char(std::tolower(ch)); });
  if (n == "hillshade") return Mode::Hillshade;
  if (n == "relief") return Mode::Relief;
  if (n == "slope") return Mode::Slope;
  if (n == "shaded-relief" || n == "shaded_relief") return Mode::ShadedRelief;
  if (n == "aspect") return Mode::Aspect;
  if (n == "tri") return Mode::TRI;
  if (n == "tpi") return Mode::TPI;
  if (n == "roughness") return Mode::Roughness;
  if (n == "perspective") return Mode::Perspective;
  if (n == "profile-curvature" || n == "profile_curvature" || n == "pcurvature") return Mode::ProfileCurvature;
  if (n == "tangential-curvature" || n == "tangential_curvature" || n == "tcurvature") return Mode::TangentialCurvature;
  fail("render",
       "unknown mode '{}' (expected hillshade|relief|slope|shaded-relief|aspect|tri|tpi|roughness|profile-curvature|"
       "tangential-curvature|perspective)",
       name);
}

Material material_from_name(const std::string& name) {
  if (name == "ramp") return Material::Ramp;
  if (name == "natural") return Material::Natural;
  fail("render", "unknown material '{}' (--material: expected natural|ramp)", name);
}

bool is_value_mode(Mode m) {
  return m == Mode::Slope || m == Mode::Aspect || m == Mode::TRI || m == Mode::TPI || m == Mode::Roughness ||
         m == Mode::ProfileCurvature || m == Mode::TangentialCurvature;
}

Shading shading_from_name(const std::string& name) {
  if (name == "standard") return Shading::Standard;
  if (name == "multidirectional") return Shading::Multidirectional;
  if (name == "combined") return Shading::Combined;
  if (name == "igor") return Shading::Igor;
  fail("render", "unknown shading '{}' (expected standard|multidirectional|combined|igor)", name);
}

std::vector<uint8_t> hillshade(const Heightfield& h, double azimuth_deg, double altitude_deg, double z_factor) {
  Options o;
  o.azimuth_deg = azimuth_deg;
  o.altitude_deg = altitude_deg;
  o.z_factor = z_factor;
  const detail::ShadeParams p(h, o);
  std::vector<uint8_t> out(h.size(), 0);
  double w[9];
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x)
      if (detail::window(h, x, y, true, w))
        out[size_t(y) * h.width + x] = to_byte(detail::shade(w, Shading::Standard, p));
  return out;
}

namespace {
// The colour names gdaldem color-relief knows, with the values it gives them (GDAL 3.6, read
// back from its output; its own table, not CSS's: grey is 191, brown 191 127 63).
bool named_colour(std::string name, uint8_t rgb[3]) {
  std::transform(name.begin(), name.end(), name.begin(), [](unsigned char ch) { return char(std::tolower(ch)); });
  static const struct {
    const char* name;
    uint8_t r, g, b;
  } table[] = {{"white", 255, 255, 255}, {"black", 0, 0, 0},       {"red", 255, 0, 0},      {"green", 0, 255, 0},
               {"blue", 0, 0, 255},      {"yellow", 255, 255, 0},  {"magenta", 255, 0, 255}, {"cyan", 0, 255, 255},
               {"aqua", 0, 191, 191},    {"grey", 191, 191, 191},  {"gray", 191, 191, 191}, {"orange", 255, 127, 0},
               {"brown", 191, 127, 63},  {"purple", 127, 0, 255},  {"violet", 127, 0, 255}, {"indigo", 0, 127, 255}};
  for (const auto& c : table)
    if (name == c.name) {
      rgb[0] = c.r;
      rgb[1] = c.g;
      rgb[2] = c.b;
      return true;
    }
  return false;
}
}  // namespace

ColorRamp ColorRamp::parse(const std::string& text, const std::string& where) {
  ColorRamp r;
  std::istringstream in(text);
  std::string line;
  int lineno = 0;
  bool have_nv = false;
  while (std::getline(in, line)) {
    ++lineno;
    if (auto p = line.find('#'); p != std::string::npos) line.erase(p);
    for (char& ch : line)
      if (ch == ',' || ch == ':' || ch == '\t' || ch == '\r') ch = ' ';
    std::istringstream ls(line);
    std::vector<std::string> tok;
    for (std::string t; ls >> t;) tok.push_back(t);
    if (tok.empty()) continue;
    Entry e;
    uint8_t rgb[3];
    auto component = [&](const std::string& t) {
      char* end = nullptr;
      const long v = std::strtol(t.c_str(), &end, 10);
      if (*end != '\0' || v < 0 || v > 255)
        fail("render", "{}:{}: colour component '{}' is not an integer 0..255", where, lineno, t);
      return uint8_t(v);
    };
    if ((tok.size() == 2 || tok.size() == 3) && named_colour(tok[1], rgb)) {
      if (tok.size() == 3) (void)component(tok[2]);  // gdaldem's alpha after a name: checked, unused
    } else if (tok.size() < 4 || tok.size() > 5) {
      fail("render", "{}:{}: expected 'elevation r g b [a]' or 'elevation colour-name [a]' (gdaldem's names: white, "
           "black, red, green, blue, yellow, magenta, cyan, aqua, grey, gray, orange, brown, purple, violet, indigo), got '{}'",
           where, lineno, line);
    } else {
      for (int k = 0; k < 3; ++k) rgb[k] = component(tok[k + 1]);
    }
    std::string v = tok[0];
    std::transform(v.begin(), v.end(), v.begin(), [](unsigned char ch) { return char(std::tolower(ch)); });
    if (v == "nv") {
      std::copy(rgb, rgb + 3, r.nodata_rgb);
      have_nv = true;
      continue;
    }
    if (!v.empty() && v.back() == '%') {
      e.percent = true;
      v.pop_back();
    }
    char* end = nullptr;
    e.value = std::strtod(v.c_str(), &end);
    if (v.empty() || *end != '\0' || !std::isfinite(e.value))
      fail("render", "{}:{}: '{}' is not an elevation, a percentage or 'nv'", where, lineno, tok[0]);
    std::copy(rgb, rgb + 3, e.rgb);
    r.entries.push_back(e);
  }
  (void)have_nv;
  if (r.entries.empty()) fail("render", "{}: colour ramp has no elevation entries", where);
  const bool mixed = std::any_of(r.entries.begin(), r.entries.end(),
                                 [&](const Entry& e) { return e.percent != r.entries[0].percent; });
  if (!mixed)
    std::stable_sort(r.entries.begin(), r.entries.end(),
                     [](const Entry& a, const Entry& b) { return a.value < b.value; });
  return r;
}

ColorRamp ColorRamp::load(const std::string& path) {
  std::ifstream f(path);
  if (!f) fail("render", "cannot read colour ramp {}", path);
  std::stringstream ss;
  ss << f.rdbuf();
  return parse(ss.str(), path);
}

// Hypsometric tints in metres (the conventions of shaded relief maps): bathymetric blues below
// 0 m, lowland green at the coast, through yellow-tan uplands and brown mountains to grey rock and
// snow above 4000 m. Absolute, so a 500 m plateau is never snow and the sea is never green.
static const char* kHypsometric =
    "-6000  10  30  90\n"
    "-2000  25  70 150\n"
    "-200   60 120 190\n"
    "-0.01 130 185 225\n"
    "0      70 130  80\n"
    "150   110 160  90\n"
    "500   190 200 130\n"
    "1000  210 180 120\n"
    "1800  170 125  85\n"
    "2800  140 115 100\n"
    "3600  185 180 175\n"
    "4500  250 250 250\n"
    "nv 0 0 0\n";
// The former default: the same kind of tints stretched over the data range (percentages).
static const char* kRelative =
    "0%   46 112  74\n"
    "10%  96 150  84\n"
    "25% 166 188 112\n"
    "40% 222 214 150\n"
    "55% 196 158 104\n"
    "70% 156 112  80\n"
    "85% 170 160 152\n"
    "100% 250 250 250\n"
    "nv 0 0 0\n";
static const char* kGrey = "0% 0 0 0\n100% 255 255 255\nnv 0 0 0\n";

ColorRamp ColorRamp::default_ramp() {
  ColorRamp r = parse(kHypsometric, "hypsometric ramp");
  r.name = "hypsometric";
  return r;
}

std::vector<std::string> ColorRamp::names() { return {"hypsometric", "relative", "grey"}; }

ColorRamp ColorRamp::from_spec(const std::string& spec) {
  if (spec == "hypsometric") return default_ramp();
  if (spec == "relative" || spec == "grey" || spec == "gray") {
    ColorRamp r = spec == "relative" ? parse(kRelative, "relative ramp") : parse(kGrey, "grey ramp");
    r.name = spec == "relative" ? "relative" : "grey";
    return r;
  }
  std::ifstream f(spec);
  if (!f)
    fail("render", "ramp '{}' is neither a named ramp (hypsometric, relative, grey) nor a readable gdaldem colour file",
         spec);
  return load(spec);
}

void ColorRamp::color(double z, double zmin, double zmax, uint8_t out[3]) const {
  if (std::isnan(z)) {
    std::copy(nodata_rgb, nodata_rgb + 3, out);
    return;
  }
  auto at = [&](const Entry& e) { return e.percent ? zmin + e.value / 100.0 * (zmax - zmin) : e.value; };
  // Entries are in file order (sorted when not mixing kinds); find the bracketing pair.
  const size_t n = entries.size();
  if (z <= at(entries[0])) {
    std::copy(entries[0].rgb, entries[0].rgb + 3, out);
    return;
  }
  for (size_t k = 1; k < n; ++k) {
    const double a = at(entries[k - 1]), b = at(entries[k]);
    if (z <= b) {
      const double t = b > a ? (z - a) / (b - a) : 1.0;
      for (int c = 0; c < 3; ++c)
        out[c] = to_byte(entries[k - 1].rgb[c] + t * (double(entries[k].rgb[c]) - entries[k - 1].rgb[c]));
      return;
    }
  }
  std::copy(entries[n - 1].rgb, entries[n - 1].rgb + 3, out);
}

void check_options(const Heightfield& h, const Options& opt) {
  if (h.width <= 0 || h.height <= 0) fail("render", "empty heightfield");
  if (!(opt.altitude_deg >= 0 && opt.altitude_deg <= 90))
    fail("render", "altitude must be in 0..90 deg, got {}", opt.altitude_deg);
  if (!(opt.slope_max_deg > 0 && opt.slope_max_deg <= 90))
    fail("render", "slope_max must be in (0, 90] deg, got {}", opt.slope_max_deg);
  if (!std::isfinite(opt.azimuth_deg) || !std::isfinite(opt.z_factor))
    fail("render", "azimuth and z factor must be finite numbers");
  if (!(opt.scale > 0) || !std::isfinite(opt.scale))
    fail("render", "scale (gdaldem -s) must be a positive number of horizontal units per vertical unit, got {}",
         opt.scale);
  if (!(h.georef.cell_x > 0 && h.georef.cell_y > 0))
    fail("render", "cell size must be positive, got {} x {} m", h.georef.cell_x, h.georef.cell_y);
}

static void refuse_value_picture(const Options& opt) {
  if (is_value_mode(opt.mode) && opt.mode != Mode::Slope)
    fail("render", "mode {} gives values, not a picture: write it as a GeoTIFF (.tif)",
         opt.mode == Mode::Aspect                ? "aspect"
         : opt.mode == Mode::TRI                 ? "tri"
         : opt.mode == Mode::TPI                 ? "tpi"
         : opt.mode == Mode::ProfileCurvature    ? "profile-curvature"
         : opt.mode == Mode::TangentialCurvature ? "tangential-curvature"
                                                 : "roughness");
}

static bool grey_mode(const Options& opt) { return opt.mode == Mode::Hillshade || opt.mode == Mode::Slope; }

static bool needs_range(const Options& opt) {
  return !grey_mode(opt) && std::any_of(opt.ramp.entries.begin(), opt.ramp.entries.end(),
                                        [](const ColorRamp::Entry& e) { return e.percent; });
}

// gdaldem's 3x3 products leave the border nodata without -compute_edges.
static bool border_nodata(int width, int height, const Options& opt) {
  return grey_mode(opt) && (!opt.compute_edges || width < 2 || height < 2);
}

bool layout_needs_scan(int width, int height, const Options& opt) {
  refuse_value_picture(opt);
  return needs_range(opt) || !border_nodata(width, height, opt);
}

void scan_heights(const float* z, size_t n, const Options& opt, LayoutScan& s) {
  const bool range = needs_range(opt);
  for (size_t i = 0; i < n; ++i) {
    const float v = z[i];
    if (std::isnan(v)) {
      s.has_nan = true;
      continue;
    }
    if (!range) {
      if (s.has_nan) break;
      continue;
    }
    s.lo = std::min(s.lo, v);
    s.hi = std::max(s.hi, v);
  }
}

PictureLayout picture_layout(int width, int height, const Options& opt, const LayoutScan& s) {
  refuse_value_picture(opt);
  if (opt.mode == Mode::Perspective) fail("render", "a perspective picture is drawn whole (render_view), not in strips");
  PictureLayout l;
  l.grey = grey_mode(opt);
  l.alpha = s.has_nan || border_nodata(width, height, opt);
  l.channels = (l.grey ? 1 : 3) + (l.alpha ? 1 : 0);
  l.zmin = s.lo <= s.hi ? s.lo : 0.0;
  l.zmax = s.lo <= s.hi ? s.hi : 0.0;
  return l;
}

PictureLayout picture_layout(const Heightfield& h, const Options& opt) {
  LayoutScan s;
  if (layout_needs_scan(h.width, h.height, opt)) scan_heights(h.z.data(), h.z.size(), opt, s);
  return picture_layout(h.width, h.height, opt, s);
}

Image render(const Heightfield& h, const Options& opt) {
  if (opt.mode == Mode::Perspective) return render_view(h, opt);
  check_options(h, opt);
  return render(h, opt, picture_layout(h, opt));
}

Image render(const Heightfield& h, const Options& opt, const PictureLayout& l) {
  check_options(h, opt);
  Image img;
  img.width = h.width;
  img.height = h.height;
  img.channels = l.channels;
  img.georef = h.georef;
  img.pixels.assign(size_t(l.channels) * h.size(), 0);
  const detail::ShadeParams p(h, opt);
  double w[9];
  for (int y = 0; y < h.height; ++y) {
    for (int x = 0; x < h.width; ++x) {
      const size_t i = size_t(y) * h.width + x;
      uint8_t* px = &img.pixels[l.channels * i];
      const float z = h.z[i];
      if (l.grey) {
        const bool ok = detail::window(h, x, y, opt.compute_edges, w);
        if (ok && opt.mode == Mode::Hillshade) px[0] = to_byte(detail::shade(w, opt.shading, p));
        if (ok && opt.mode == Mode::Slope) {
          const double s = detail::slope(w, p, false);
          px[0] = to_byte(255.0 * (1.0 - std::min(s, opt.slope_max_deg) / opt.slope_max_deg));
        }
        if (l.alpha) px[1] = ok ? 255 : 0;
        continue;
      }
      opt.ramp.color(z, l.zmin, l.zmax, px);
      // Shaded relief is not a gdaldem product: its shade always computes the edges.
      if (opt.mode == Mode::ShadedRelief && detail::window(h, x, y, true, w)) {
        const double f = (0.3 + 0.7 * to_byte(detail::shade(w, opt.shading, p)) / 255.0) / (0.3 + 0.7 * p.flat / 255.0);
        for (int c = 0; c < 3; ++c) px[c] = to_byte(px[c] * f);
      }
      if (l.alpha) px[3] = std::isnan(z) ? 0 : 255;
    }
    if ((y & 255) == 255) report_progress(opt.progress, "render", double(y + 1) / h.height, "shading");
  }
  return img;
}

}  // namespace terracl::render
