// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Skeleton primitives and tensor fields for gradient-domain authoring (kernels/tensor.cl).
///
/// The composite tensor field A(p) = I + sum_i mu_i alpha(d_i(p)/r_i) T_i(p, u(p)) acts on a gradient
/// by matrix multiplication, g' = A g. alpha(t) = (1 - t^2)^3 on [0, 1], 0 beyond: C2, alpha(0) = 1,
/// alpha(1) = 0. d_i is the (optionally anisotropic) distance to primitive i, r_i its radius of
/// influence, u(p) the unit direction from p to the closest point of the primitive.
/// Positions are metres in the grid frame: cell (x, y) is at (x * cell_x, y * cell_y), x east,
/// y south. Gradients live on the staggered grid of GradientField.
#include <terracl/device.hpp>
#include <terracl/heightfield.hpp>

#include <array>
#include <memory>
#include <vector>

namespace terracl {

/// A position or direction in metres.
struct Vec2 {
  double x = 0, y = 0;
};

/// Geometry of a tensor primitive.
enum class PrimitiveShape { Point, Polyline, Disc, Polygon };

/// What T_i is. Directional: the constant R(2 theta) = [[cos 2t, sin 2t], [sin 2t, -cos 2t]], so a
/// full-weight region gives D(theta, mu) = I + mu R(2 theta). Scale: T = I (mu = factor - 1 scales
/// slopes). Tangent / Closest: R(2 theta) with theta the angle of the stroke's tangent or of u(p),
/// rotated by `angle`.
enum class TensorKind { Directional, Scale, Tangent, Closest };

/// Cross-section profile P(d) for profile gradients (landform curves); a = amplitude (metres),
/// u = clamp((d - f) / (r - f), 0, 1) with f = floor_half_width (a flat floor or top).
/// Round: a alpha(u). Sharp: a (1 - u)^3. V: a (1 - u)^3 (1 + 3u) (rounded thalweg). U: a (1 - u^4)^2.
/// Step: a smootherstep((s/r + 1)/2) across the signed distance s (a fault of throw a).
/// Drop: for s >= 0 a cliff face of width c r (c = face_fraction) dropping (1 - k) a, then a concave
/// scree apron over [c r, r] dropping k a (k = scree): steepest at the foot, where it meets the face
/// with the same slope, flat at the toe.
/// Near a bend, the values of the two nearest segments are blended (C1 across the medial axis).
enum class Profile { Round, Sharp, Step, Drop, V, U };

/// Sharp profiles: the distance is rounded over this fraction of r on the crest line (no slope kink).
constexpr double kSharpCrestRound = 0.08;

/// Profile value at distance d (signed distance s for Step/Drop), host copy of the kernel's formula.
double profile_value(Profile p, double d, double s, double r, double a, double floor_half_width = 0,
                     double face_fraction = 1, double scree = 0, double crest_round = kSharpCrestRound);

/// One tensor primitive: a shape with a radius of influence, strength and tensor kind.
struct Primitive {
  PrimitiveShape shape = PrimitiveShape::Point;
  std::vector<Vec2> points;         ///< metres; 1 for point/disc (centre), >= 2 polyline, >= 3 polygon
  std::vector<double> amplitude;    ///< per-vertex profile amplitude factor (empty: all 1)
  double disc_radius = 0;           ///< metres (disc)
  double radius = 0;                ///< radius of influence r (metres) beyond the shape
  double strength = 1;              ///< mu
  TensorKind tensor = TensorKind::Directional;
  double angle = 0;                 ///< radians (directional theta, or rotation of aligned tensors)
  /// Anisotropic distance: offsets along the direction `aniso_angle` count 1x, across it `aniso_ratio`x.
  double aniso_ratio = 1, aniso_angle = 0;
  Profile profile = Profile::Round;
  double profile_amplitude = 0;     ///< metres
  double floor_half_width = 0;      ///< metres: the profile is flat (= a) within this distance
  /// Open polylines: the profile's amplitude tapers to 0 over these arc lengths (metres) at the first
  /// and the last vertex (0: no taper).
  double taper_start = 0, taper_end = 0;
  double face_fraction = 1;         ///< Drop: width of the steep face as a fraction of the radius
  double scree = 0;                 ///< Drop: share of the drop taken by the scree apron (0..1)
  /// Sharp: the distance rounded over this fraction of r on the crest line (0: the plain (1 - u)^3).
  /// An operation that pins its crest line (crest) uses 0: a rounded top beside the pinned cells
  /// rose above them (1.4 m on a 150 m studio crest at a bend).
  double crest_round = kSharpCrestRound;
  /// Open polylines sampled from a smooth curve (CurveShape's Catmull-Rom, >= 3 points): distances
  /// are taken to the C1 chain of cubic Hermite pieces through the points with their vertex
  /// tangents instead of to the chords, whose creases inside each vertex made slope jumps.
  bool smooth = false;
};

/// Centripetal Catmull-Rom spline through the points (alpha = 1/2, end points mirrored), sampled so
/// that no piece is longer than `step` metres nor turns by more than about 4 degrees; per-point values `z` (if not empty) are interpolated
/// with the same parameter and returned in `z_out`. Passes through every input point.
std::vector<Vec2> catmull_rom(const std::vector<Vec2>& pts, double step, const std::vector<double>& z = {},
                              std::vector<double>* z_out = nullptr);

/// alpha(t) = (1 - t^2)^3 for 0 <= t < 1, else 0 (host copy of the kernel's function).
double alpha(double t);
/// D(theta, mu) = I + mu [[cos 2t, sin 2t], [sin 2t, -cos 2t]] as {a00, a01, a10, a11}.
std::array<double, 4> directional_tensor(double theta, double mu);

/// Cells [x0, x0+w) x [y0, y0+h) of a grid.
struct Box {
  int x0 = 0, y0 = 0, w = 0, h = 0;
  bool empty() const { return w <= 0 || h <= 0; }
};
/// Cells that the primitives can influence (plus a margin of one cell), clipped to the grid.
Box primitives_box(const std::vector<Primitive>& prims, int width, int height, double cell_x, double cell_y);
/// The whole grid.
Box full_box(int width, int height);

/// A gradient field resident on the device, with scratch buffers for the authoring kernels.
struct SkeletonParams;  // tensor.cpp

struct GradientBuffers {
  int width = 0, height = 0;
  double cell_x = 1, cell_y = 1;
  cl::Buffer gx, gy;      ///< the field
  cl::Buffer tx, ty;      ///< scratch of the same size (zero outside what an operation uses)
  cl::Buffer mask;        ///< scratch weight field (cells)
  cl::Buffer nv, nx, ny;  ///< noise values and derivatives at the cells (allocated by noise_gradient)
  /// The tensor kernels' parameter buffer, kept between operations (tensor.cpp; shared by copies).
  std::shared_ptr<SkeletonParams> skeleton;
  size_t cells() const { return size_t(width) * size_t(height); }

  static GradientBuffers upload(Device& d, const GradientField& g);
  /// Copies the field back into `g` (which keeps its georef/metadata; size must match).
  void download(Device& d, GradientField& g) const;
  /// Zeroes rows [box.y0 - 1, box.y0 + box.h] of the scratch buffers tx, ty.
  void clear_scratch(Device& d, const Box& box);
};

/// g = A g for the composite tensor field of `prims` (A = I outside every support).
void apply_tensor_field(Device& d, GradientBuffers& g, const std::vector<Primitive>& prims);
/// g += A t where t is the scratch field (tx, ty), over `box` (noise layers oriented by tensors).
void add_tensor_field_of_scratch(Device& d, GradientBuffers& g, const std::vector<Primitive>& prims, const Box& box);
/// mask = max_i alpha(d_i/r_i) over `box` (1 - that when `invert`); cells outside `box` untouched.
void primitive_weight(Device& d, GradientBuffers& g, const std::vector<Primitive>& prims, const Box& box, bool invert);
/// g += the staggered (discrete) gradient of P = sum_i P_i(d_i), evaluated at the cell centres of the
/// primitives' box: exactly curl-free, so reconstruction reproduces P; profiles superpose additively.
/// Uses the mask scratch buffer.
void add_profile_gradient(Device& d, GradientBuffers& g, const std::vector<Primitive>& prims);

}  // namespace terracl
