// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Gradient extraction (h -> g), divergence (g -> f) and the paper's central-difference format.
///
/// The internal gradient is the staggered forward difference documented on GradientField; its
/// backward-difference divergence equals the solver's 5-point Neumann Laplacian exactly, so
/// `reconstruct(extract(h))` returns h to solver tolerance. All values are in metres per metre
/// (divergence in 1/m), using the metric cell size `georef.cell_x/cell_y`.
#include <terracl/device.hpp>
#include <terracl/heightfield.hpp>

namespace terracl {

/// Which finite differences a GradientField holds (recorded in metadata "terracl:gradient").
enum class GradientFormat { Staggered, Central };

/// Extracts the gradient of `h` on the device. Staggered (default): forward differences on faces,
/// the internal representation. Central: the paper's (h[i+1]-h[i-1])/2d, one-sided at the borders,
/// an export format only. Keeps georef and metadata, stores the mean elevation of `h`.
/// Throws when `h` has NaN/Inf cells.
GradientField extract_gradient(Device& d, const Heightfield& h, GradientFormat format = GradientFormat::Staggered);

/// The format a gradient carries in its metadata (Staggered when unmarked).
GradientFormat gradient_format(const GradientField& g);

/// Converts a central-difference gradient to the staggered representation (face value = mean of
/// the two cell values beside it). Approximate: central differences cannot represent the
/// checkerboard mode. A staggered input is returned unchanged.
GradientField to_staggered(Device& d, const GradientField& g);

/// Discrete divergence f = d(gx)/dx + d(gy)/dy (1/m) by backward differences of a staggered
/// gradient, faces outside the grid carrying no flux. Georef copied from `g`.
Heightfield divergence(Device& d, const GradientField& g);

/// Enqueues `out = scale * div(g)` on device buffers of W*H floats (no finish). For launchers
/// that keep the divergence on the device (the multigrid solver).
void enqueue_divergence(Device& d, const cl::Buffer& gx, const cl::Buffer& gy, const cl::Buffer& out, int width,
                        int height, double cell_x, double cell_y, float scale);

}  // namespace terracl
