// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Gradient noise with analytic derivatives (kernels/noise.cl): Perlin-style lattice gradient noise,
/// fBm and a ridged multifractal sum, added to a staggered gradient as the exact gradient of
/// amplitude * w(p) * n(p), where w is a weight mask (cells, see primitive_weight).
#include <terracl/device.hpp>
#include <terracl/tensor.hpp>

#include <cstdint>
#include <string>

namespace terracl {

/// Single lattice noise, its fractal sum, or the ridged multifractal (sharp crests).
enum class NoiseType { Perlin, Fbm, Ridged };
NoiseType parse_noise_type(const std::string& s);  ///< "perlin" | "fbm" | "ridged"

/// Parameters of the `noise` edit operation, in metres.
struct NoiseParams {
  NoiseType type = NoiseType::Fbm;
  double amplitude = 10;    ///< metres (Perlin values are about +-0.7 times this)
  double wavelength = 200;  ///< metres, of the first octave
  int octaves = 4;
  double lacunarity = 2;    ///< frequency factor between octaves
  double gain = 0.5;        ///< amplitude factor between octaves
  uint32_t seed = 1;
};

/// Octaves of `p` that noise_gradient evaluates on cells of cell_x x cell_y: the ones whose wavelength
/// is at least 4 cells (finer ones alias into a grid pattern in the shaded relief), and always the first.
int band_limited_octaves(const NoiseParams& p, double cell_x, double cell_y);

/// Adds grad(amplitude * w * n) over `box` to the field (to_scratch = false) or writes it into the
/// scratch (tx, ty) to be oriented by a tensor field afterwards. use_mask = false: w = 1.
void noise_gradient(Device& d, GradientBuffers& g, const NoiseParams& p, const Box& box, bool use_mask, bool to_scratch);

/// amplitude * n at cell centres (no mask), for tests and previews.
Heightfield noise_values(Device& d, int width, int height, double cell_x, double cell_y, const NoiseParams& p);

}  // namespace terracl
