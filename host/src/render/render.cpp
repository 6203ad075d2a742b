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

namespace terracl::render {

namespace {

/// 3x3 window around (x, y); neighbours outside the grid or nodata take the centre value.
inline void window(const Heightfield& h, int x, int y, double w[9]) {
  const float c = h.at(x, y);
  for (int j = -1; j <= 1; ++j)
    for (int i = -1; i <= 1; ++i) {
      const int xx = x + i, yy = y + j;
      float v = c;
      if (xx >= 0 && yy >= 0 && xx < h.width && yy < h.height) v = h.at(xx, yy);
      w[(j + 1) * 3 + (i + 1)] = std::isnan(v) ? c : v;
    }
}

inline uint8_t to_byte(double v) { return uint8_t(std::clamp(std::floor(v + 0.5), 0.0, 255.0)); }

}  // namespace

Mode mode_from_name(const std::string& name) {
  if (name == "hillshade") return Mode::Hillshade;
  if (name == "relief") return Mode::Relief;
  if (name == "slope") return Mode::Slope;
  if (name == "shaded-relief" || name == "shaded_relief") return Mode::ShadedRelief;
  fail("render", "unknown mode '{}' (expected hillshade|relief|slope|shaded-relief)", name);
}

std::vector<uint8_t> hillshade(const Heightfield& h, double azimuth_deg, double altitude_deg, double z_factor) {
  // gdaldem: x, y are Horn's sums times 1/ewres and 1/nsres (nsres negative for north-up), the
  // z factor is folded into z / (8 * scale), and the shade is
  // 1 + 254 * (sin(alt) - y*cos(az)*cos(alt)*z' + x*sin(az)*cos(alt)*z') / sqrt(1 + z'^2 (x^2+y^2)).
  const double d2r = M_PI / 180.0;
  const double inv_ew = 1.0 / h.georef.cell_x, inv_ns = -1.0 / h.georef.cell_y;
  const double zs = z_factor / 8.0;
  const double sin_alt = std::sin(altitude_deg * d2r), cos_alt_z = std::cos(altitude_deg * d2r) * zs;
  const double az = azimuth_deg * d2r;
  const double c_az = 254.0 * std::cos(az) * cos_alt_z, s_az = 254.0 * std::sin(az) * cos_alt_z;
  std::vector<uint8_t> out(h.size(), 0);
  double w[9];
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x) {
      if (std::isnan(h.at(x, y))) continue;
      window(h, x, y, w);
      const double gx = ((w[0] + w[3] + w[3] + w[6]) - (w[2] + w[5] + w[5] + w[8])) * inv_ew;
      const double gy = ((w[6] + w[7] + w[7] + w[8]) - (w[0] + w[1] + w[1] + w[2])) * inv_ns;
      const double c = (254.0 * sin_alt - (gy * c_az - gx * s_az)) / std::sqrt(1.0 + zs * zs * (gx * gx + gy * gy));
      out[size_t(y) * h.width + x] = to_byte(c <= 0.0 ? 1.0 : 1.0 + c);
    }
  return out;
}

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
    if (tok.size() < 4 || tok.size() > 5)
      fail("render", "{}:{}: expected 'elevation r g b [a]', got '{}'", where, lineno, line);
    Entry e;
    uint8_t rgb[3];
    for (int k = 0; k < 3; ++k) {
      char* end = nullptr;
      const long v = std::strtol(tok[k + 1].c_str(), &end, 10);
      if (*end != '\0' || v < 0 || v > 255)
        fail("render", "{}:{}: colour component '{}' is not an integer 0..255", where, lineno, tok[k + 1]);
      rgb[k] = uint8_t(v);
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

ColorRamp ColorRamp::default_ramp() { return parse(kHypsometric, "hypsometric ramp"); }

std::vector<std::string> ColorRamp::names() { return {"hypsometric", "relative", "grey"}; }

ColorRamp ColorRamp::from_spec(const std::string& spec) {
  if (spec == "hypsometric") return default_ramp();
  if (spec == "relative") return parse(kRelative, "relative ramp");
  if (spec == "grey" || spec == "gray") return parse(kGrey, "grey ramp");
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

Image render(const Heightfield& h, const Options& opt) {
  if (h.width <= 0 || h.height <= 0) fail("render", "empty heightfield");
  if (!(opt.altitude_deg >= 0 && opt.altitude_deg <= 90))
    fail("render", "altitude must be in 0..90 deg, got {}", opt.altitude_deg);
  if (!(opt.slope_max_deg > 0 && opt.slope_max_deg <= 90))
    fail("render", "slope_max must be in (0, 90] deg, got {}", opt.slope_max_deg);
  Image img;
  img.width = h.width;
  img.height = h.height;
  img.channels = 3;
  img.pixels.assign(size_t(3) * h.size(), 0);
  const HeightStats st = compute_stats(h);
  std::vector<uint8_t> grey;
  if (opt.mode == Mode::Hillshade || opt.mode == Mode::ShadedRelief)
    grey = hillshade(h, opt.azimuth_deg, opt.altitude_deg, opt.z_factor);
  // Shaded relief: multiply the tint by the shade, normalised so that flat ground keeps its tint.
  const double flat = 1.0 + 254.0 * std::sin(opt.altitude_deg * M_PI / 180.0);
  for (size_t i = 0; i < h.size(); ++i) {
    uint8_t* p = &img.pixels[3 * i];
    const float z = h.z[i];
    switch (opt.mode) {
      case Mode::Hillshade:
        p[0] = p[1] = p[2] = grey[i];
        break;
      case Mode::Relief:
        opt.ramp.color(z, st.min, st.max, p);
        break;
      case Mode::ShadedRelief: {
        opt.ramp.color(z, st.min, st.max, p);
        if (std::isnan(z)) break;
        const double f = (0.3 + 0.7 * grey[i] / 255.0) / (0.3 + 0.7 * flat / 255.0);
        for (int c = 0; c < 3; ++c) p[c] = to_byte(p[c] * f);
        break;
      }
      case Mode::Slope:
        break;
    }
  }
  if (opt.mode == Mode::Slope) {
    const double cx = h.georef.cell_x, cy = h.georef.cell_y;
    double w[9];
    for (int y = 0; y < h.height; ++y)
      for (int x = 0; x < h.width; ++x) {
        if (std::isnan(h.at(x, y))) continue;
        window(h, x, y, w);
        const double gx = ((w[2] + 2 * w[5] + w[8]) - (w[0] + 2 * w[3] + w[6])) / (8 * cx) * opt.z_factor;
        const double gy = ((w[6] + 2 * w[7] + w[8]) - (w[0] + 2 * w[1] + w[2])) / (8 * cy) * opt.z_factor;
        const double s = std::atan(std::hypot(gx, gy)) * 180.0 / M_PI;
        uint8_t* p = &img.pixels[3 * (size_t(y) * h.width + x)];
        p[0] = p[1] = p[2] = to_byte(255.0 * (1.0 - std::min(s, opt.slope_max_deg) / opt.slope_max_deg));
      }
  }
  return img;
}

}  // namespace terracl::render
