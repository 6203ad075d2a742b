// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Preview pictures and gdaldem's terrain products of a heightfield: hillshade (Horn's method as
/// `gdaldem hillshade`, with its -multidirectional, -combined and -igor shadings), colour relief
/// from a gdaldem-format ramp, slope, and colour relief shaded by the hillshade as 8-bit pictures
/// (grey or RGB, one pixel per cell, plus alpha where gdaldem writes nodata); slope, aspect, TRI,
/// TPI and roughness as float rasters equal to gdaldem's; profile and tangential curvature as GRASS
/// r.slope.aspect's pcurvature and tcurvature. Lengths use the metric cell size
/// (georef.cell_x/cell_y), so geographic rasters need no -s scale.
#include <cstdint>
#include <string>
#include <terracl/device.hpp>
#include <terracl/heightfield.hpp>
#include <terracl/progress.hpp>
#include <vector>

namespace terracl::render {

enum class Mode {
  Hillshade,
  Relief,
  Slope,
  ShadedRelief,
  Aspect,
  TRI,
  TPI,
  Roughness,
  Perspective,
  ProfileCurvature,     ///< GRASS r.slope.aspect pcurvature [1/m]
  TangentialCurvature,  ///< GRASS r.slope.aspect tcurvature [1/m]
};
/// hillshade|relief|slope|shaded-relief|aspect|tri|tpi|roughness|profile-curvature|
/// tangential-curvature|perspective (any case; GRASS's pcurvature/tcurvature too)
Mode mode_from_name(const std::string& name);
/// Aspect, TRI, TPI, roughness and the curvatures are only values (values()); slope is both a
/// picture and values.
bool is_value_mode(Mode m);

/// gdaldem hillshade's variants: default, -multidirectional, -combined, -igor.
enum class Shading { Standard, Multidirectional, Combined, Igor };
Shading shading_from_name(const std::string& name);  ///< standard|multidirectional|combined|igor
/// gdaldem TRI -alg: Riley (terrestrial, gdaldem's default) or Wilson (bathymetric).
enum class TriAlg { Riley, Wilson };
/// gdaldem -alg for slope, aspect and hillshade: Horn's 3x3 weighted differences (the default) or
/// Zevenbergen & Thorne's 4-neighbour central differences (smoother terrain, gdaldem's advice).
enum class GradientAlg { Horn, ZevenbergenThorne };

struct Image {
  int width = 0, height = 0;
  /// 1 grey, 2 grey + alpha, 3 RGB, 4 RGB + alpha (alpha 0 where nodata).
  int channels = 3;
  std::vector<uint8_t> pixels;  ///< row-major, interleaved channels
  Georef georef;                ///< the heightfield's, written into GeoTIFF pictures
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
  /// The named ramp this is ("hypsometric", "relative", "grey"), empty for a file's.
  std::string name;

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

/// Surface colouring of the perspective picture: the ramp at the hit's elevation, or the natural
/// look (rock on steep faces, scree, grass, snow on high gentle ground, sand at the shore, by slope
/// and elevation with world-space noise; docs/analysis.md).
enum class Material { Ramp, Natural };
Material material_from_name(const std::string& name);  ///< "ramp" | "natural"

/// Camera and look of the perspective picture (Mode::Perspective): a pinhole camera looking at the
/// terrain from `azimuth_deg` and `elevation_deg`, placed so that the whole terrain fills the frame.
struct View {
  int width = 1024, height = 640;  ///< picture size in pixels
  double azimuth_deg = 200;        ///< where the camera looks from, clockwise from north (200: SSW)
  double elevation_deg = 35;       ///< camera pitch: view axis below the horizon, in (0, 90)
  double fov_deg = 40;             ///< field of view across the picture's width, in (0, 180)
  /// 1 frames the whole terrain; z > 1 moves the camera toward the frame's centre, by 1 - 1/z of
  /// its distance (2: half way).
  double zoom = 1;
  /// Aim at this cell (column, row) instead of the terrain's centre: the view axis passes through
  /// the surface there, from the framing's distance divided by zoom.
  bool has_target = false;
  double target[2] = {0, 0};
  double haze = 1;       ///< strength of the distance haze toward the sky (0: none)
  bool shadows = true;   ///< cast shadows: a march toward the sun from every visible point
  /// Ramp by default in the library (the CLI and stage default to natural unless --ramp is given).
  Material material = Material::Ramp;
  /// Water surface: false draws none (--no-water). Else at water_level (metres) when
  /// has_water_level, otherwise at sea level 0 m when the look is the hypsometric ramp or the
  /// natural material and some cell lies below 0 m. Water at or below the lowest cell is not drawn.
  bool water = true;
  bool has_water_level = false;
  double water_level = 0;
  /// Beer-Lambert extinction length of the water's red channel in metres of path through it (green
  /// and blue go 2.5x and 5x as far): larger is clearer water.
  double water_clarity = 20;
  /// An explicit eye instead of the framing (tests): metres east of column 0 and south of row 0,
  /// and height in displayed metres (elevation * z_factor).
  bool has_eye = false;
  double eye[3] = {0, 0, 0};
};
/// Throws a clear error naming the option (fov, view_elevation, size, ...) for a bad camera.
void check_view(const View& v);

struct Options {
  Mode mode = Mode::Hillshade;
  double azimuth_deg = 315;   ///< light from the north-west, clockwise from north
  double altitude_deg = 45;   ///< sun height above the horizon
  double z_factor = 1;        ///< vertical exaggeration
  double slope_max_deg = 60;  ///< slope mode: this slope and steeper are black, flat is white
  ColorRamp ramp = ColorRamp::default_ramp();
  Shading shading = Shading::Standard;
  /// gdaldem -compute_edges: border cells extrapolate the missing row/column and nodata
  /// neighbours take the centre value; without it they are nodata, as in gdaldem. On by default
  /// in the library (previews without a transparent frame); `terracl render` follows gdaldem.
  bool compute_edges = true;
  bool slope_percent = false;         ///< slope values in percent (gdaldem -p), else degrees
  TriAlg tri_alg = TriAlg::Riley;     ///< TRI algorithm
  bool aspect_trigonometric = false;  ///< aspect counter-clockwise from east (gdaldem -trigonometric)
  bool zero_for_flat = false;         ///< aspect 0 on flat ground instead of nodata (-zero_for_flat)
  GradientAlg gradient_alg = GradientAlg::Horn;  ///< slope/aspect/hillshade gradient (gdaldem -alg)
  /// Horizontal units per vertical unit (gdaldem -s), e.g. 111120 for degrees over metres; slope
  /// and hillshade divide the gradient by it (with z_factor on top).
  double scale = 1;
  View view;  ///< the perspective mode's camera
  /// Rows per device launch: bounds device memory and paces progress.
  int strip_rows = 1024;
  /// Value rasters (.tif): DEFLATE with the floating-point predictor (level 1); false: uncompressed
  /// (gdaldem's default: a third larger, less CPU).
  bool compress = true;
  Progress progress;
};

/// Hillshade grey levels exactly as gdaldem's default (Horn) algorithm: 1 + 254 * cos(angle to the
/// sun), clamped to 1 when facing away, 0 for nodata. Edges computed as gdaldem -compute_edges.
std::vector<uint8_t> hillshade(const Heightfield& h, double azimuth_deg = 315, double altitude_deg = 45,
                               double z_factor = 1);

/// Host reference implementation of the pictures (double precision). Throws for value modes
/// other than slope. Mode::Perspective gives render_view's picture.
Image render(const Heightfield& h, const Options& opt);
/// The same picture computed by kernels/render.cl on `device`, strip by strip (single precision;
/// agrees with the host version within one level per channel).
Image render(const Heightfield& h, const Options& opt, Device& device);

/// Perspective picture (opt.view.width x height, RGB, no georeferencing): every pixel's ray is
/// marched against the bilinear surface (steps of half a cell), the hit refined by bisection and
/// shaded with the sun (Lambert + ambient on the interpolated vertex normals, cast shadows), the
/// colour from opt.ramp at the hit's elevation or the natural material (opt.view.material), under
/// an optional water plane (opt.view.water*), hazed toward the sky with distance. Nodata cells are
/// holes. Host reference in double precision.
Image render_view(const Heightfield& h, const Options& opt);
/// The same through kernels/render_view.cl (single precision; one work-item per pixel).
Image render_view(const Heightfield& h, const Options& opt, Device& device);

/// gdaldem's value raster for `opt.mode` (slope in degrees or percent, aspect in degrees, TRI,
/// TPI, roughness in elevation units), NaN where gdaldem writes nodata; the georef is the
/// input's with nodata -9999 (gdaldem's). Host reference (double precision).
Heightfield values(const Heightfield& h, const Options& opt);
/// The same through kernels/render_terrain.cl (within 1e-4 relative of the host version).
Heightfield values(const Heightfield& h, const Options& opt, Device& device);

/// Writes a picture atomically: .png through libpng with `meta` (provenance) as text
/// chunks; .tif/.tiff as a GeoTIFF with the image's geotransform and CRS (like gdaldem), alpha as
/// an unassociated alpha band, `meta` as TIFF metadata.
void write_image(const Image& img, const std::string& path, const Metadata& meta = {});

/// Tints a picture of a heightfield (one pixel per cell, as render() makes) with water where `depth`
/// (metres, the same width x height) is > 0: a blue over the shaded ground, paler over shallows
/// and deeper blue towards the layer's deepest cell, so the lake bed's relief shows through. Grey
/// pictures become RGB (the alpha channel is kept). For edit previews with lakes (terracl edit
/// --preview). Throws when the sizes differ.
void tint_water(Image& img, const Heightfield& depth);

/// Whether render_file can stream `input` to `output`: a GDAL raster (.tif, .hgt, .vrt, ...) to a
/// picture (.png, or .tif for the picture modes) or to a value raster (.tif: slope, aspect, TRI,
/// TPI, roughness).
bool can_stream_render(const std::string& input, const std::string& output, const Options& opt);
/// Renders the picture or the value raster of `input` into `output` strip by strip (GDAL windows
/// with a one-row halo; `strip_rows` rows a strip, 0 for about 4 Mi cells; value rasters round it
/// to whole 256-row blocks), on `device` or on the host when null, reporting progress per strip:
/// the same picture as read_heightfield + render + write_image, the same cells as values() +
/// write_heightfield, in memory bounded by a few strips instead of the raster and its output.
void render_file(const std::string& input, const std::string& output, const Options& opt, Device* device,
                 const Metadata& meta = {}, int strip_rows = 0);

}  // namespace terracl::render
