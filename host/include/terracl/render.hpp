#pragma once
/// Preview pictures of a heightfield: hillshade (Horn's method, as `gdaldem hillshade`), colour
/// relief from a gdaldem-format ramp, slope, and colour relief shaded by the hillshade. Pictures
/// are 8-bit RGB, one pixel per cell; lengths use the metric cell size (georef.cell_x/cell_y).
#include <cstdint>
#include <string>
#include <terracl/device.hpp>
#include <terracl/heightfield.hpp>
#include <vector>

namespace terracl::render {

enum class Mode { Hillshade, Relief, Slope, ShadedRelief };
Mode mode_from_name(const std::string& name);  ///< hillshade|relief|slope|shaded-relief

struct Image {
  int width = 0, height = 0, channels = 3;
  std::vector<uint8_t> pixels;  ///< row-major, interleaved channels
};

/// Colour ramp in gdaldem color-relief's text format: one entry per line, "elevation r g b [a]",
/// where elevation is a number, a percentage of the data range ("25%") or "nv" (nodata colour);
/// separators may be spaces, tabs, commas or colons; '#' starts a comment. Colours between entries
/// are interpolated linearly; values beyond the ends take the end colours.
struct ColorRamp {
  struct Entry {
    double value = 0;
    bool percent = false;
    uint8_t rgb[3] = {0, 0, 0};
  };
  std::vector<Entry> entries;  ///< sorted by value after resolving percentages
  uint8_t nodata_rgb[3] = {0, 0, 0};

  /// Parses ramp text; errors name `where` (the file) and the line.
  static ColorRamp parse(const std::string& text, const std::string& where);
  static ColorRamp load(const std::string& path);
  /// Hypsometric tints in metres: sea below 0 m in blues, lowland green at 0 m, through tan and
  /// brown to rock and snow above 4000 m (the "hypsometric" named ramp).
  static ColorRamp default_ramp();
  /// Named ramps: hypsometric (metres, the default), relative (tints over the data range, in
  /// percent), grey (black to white over the data range).
  static std::vector<std::string> names();
  /// A named ramp, else a gdaldem colour file (errors name the spec).
  static ColorRamp from_spec(const std::string& spec);
  /// Colour of elevation z for data range [zmin, zmax] (percentages resolve against it).
  void color(double z, double zmin, double zmax, uint8_t out[3]) const;
};

struct Options {
  Mode mode = Mode::Hillshade;
  double azimuth_deg = 315;   ///< light from the north-west, clockwise from north
  double altitude_deg = 45;   ///< sun height above the horizon
  double z_factor = 1;        ///< vertical exaggeration
  double slope_max_deg = 60;  ///< slope mode: this slope and steeper are black, flat is white
  ColorRamp ramp = ColorRamp::default_ramp();
};

/// Hillshade grey levels exactly as gdaldem's default (Horn) algorithm: 1 + 254 * cos(angle to the
/// sun), clamped to 1 when facing away, 0 for nodata. Border cells use the centre value for the
/// neighbours outside the grid (gdaldem leaves them nodata unless -compute_edges).
std::vector<uint8_t> hillshade(const Heightfield& h, double azimuth_deg = 315, double altitude_deg = 45,
                               double z_factor = 1);

/// Host reference implementation (double precision).
Image render(const Heightfield& h, const Options& opt);
/// The same picture computed by kernels/render.cl on `device` (single precision; agrees with the
/// host version within one level per channel).
Image render(const Heightfield& h, const Options& opt, Device& device);

/// Writes an 8-bit PNG (any other extension OIIO knows works too), atomically, with `meta`
/// (provenance) as text attributes.
void write_image(const Image& img, const std::string& path, const Metadata& meta = {});

}  // namespace terracl::render
