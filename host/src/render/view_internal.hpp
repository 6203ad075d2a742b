// SPDX-License-Identifier: Apache-2.0
#pragma once
// The perspective picture's camera, sun and look, computed once on the host (double) and shared by
// the host reference (view.cpp) and the kernel launcher (view_cl.cpp, as float slots).
#include <cstdint>
#include <terracl/render.hpp>
#include <vector>

namespace terracl::render::detail {

/// World frame: x east from column 0 (metres), y south from row 0 (metres), z up in displayed metres
/// (elevation * z_factor). Camera ray of pixel (px, py): fwd + sx * right + sy * up with
/// sx, sy in [-1, 1] across the picture (right and up are scaled by the half-fov tangents).
struct ViewSetup {
  double eye[3], fwd[3], right[3], up[3];
  double sun[3];          ///< unit vector toward the sun
  double cell_x, cell_y;  ///< metres
  double z_factor;
  double zlo, zhi;        ///< displayed height range of the valid cells (the march's box)
  double zmin, zmax;      ///< data range in metres (percentage ramps)
  double ambient = 0.3, diffuse = 0.8;
  double haze, haze_near, haze_scale;  ///< haze = 1 - exp(-haze * max(0, d - near) / scale)
  bool shadows;
  // The look (view_look.cpp): the material, and the water plane when `water` (level in metres and
  // displayed), its clarity (red extinction length, metres) and deep colour.
  Material material = Material::Ramp;
  bool water = false;
  double water_level = 0, water_z = 0, water_clarity = 20;
  double deep[3] = {22, 74, 100};
  double base = 0, top = 1;  ///< natural material: elevation fraction (zm - base) / (top - base)
  double snow_line = 0;      ///< metres: snow from here up (on gentle slopes)
  double noise_lambda = 1;   ///< metres: the material noise's finest wavelength
};

/// Natural material's snow line above `base` (metres): 60 % of the way to the top, at least 1500 m up.
constexpr double kSnowFraction = 0.6, kSnowMinRise = 1500;
/// Water: Fresnel reflectance at normal incidence (Schlick), glint exponent and strength, and the
/// green and blue extinction lengths as multiples of the red one (water_clarity).
constexpr double kWaterF0 = 0.02, kGlintPower = 120, kGlintGain = 0.9, kClarityG = 2.5, kClarityB = 5;

/// Noise of the natural material: three rotated value-noise octaves, in about [-1, 1].
double material_noise(double x, double y, double lam, uint32_t seed);
/// Natural albedo (0..255 per channel, kernels/render_material.clh's natural_albedo).
void natural_albedo(double x, double y, double e, double es, double nz, double lam, bool shore, double c[3]);

/// Sky colours: toward the horizon (also the haze colour) and the zenith.
constexpr double kSkyHorizon[3] = {214, 226, 236};
constexpr double kSkyZenith[3] = {112, 152, 204};
/// Bisection steps refining a hit between two march samples (half a cell apart): 2^-20 of a step.
constexpr int kBisect = 20;

/// Checks `opt` for a perspective picture of `h` and sets up the camera (framing the terrain
/// unless opt.view.has_eye).
ViewSetup view_setup(const Heightfield& h, const Options& opt);

/// The float slots of `s` in the order kernels/render_view.cl reads them (V_* there).
std::vector<float> view_slots(const ViewSetup& s);

/// The picture both backends fill: v.width x v.height RGB, black.
inline Image blank_view(const View& v) {
  Image img;
  img.width = v.width;
  img.height = v.height;
  img.channels = 3;
  img.pixels.assign(size_t(3) * v.width * v.height, 0);
  return img;
}

}  // namespace terracl::render::detail
