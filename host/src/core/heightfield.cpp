// SPDX-License-Identifier: Apache-2.0
#include <terracl/error.hpp>
#include <terracl/heightfield.hpp>

#include <Eigen/Sparse>
#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCholesky>

#include <algorithm>
#include <cmath>
#include <limits>

namespace terracl {

void Georef::update_metric_cell_size(int width, int height) {
  if (!has_geotransform) {
    cell_x = cell_y = 1.0;
    return;
  }
  const double dx = std::hypot(geotransform[1], geotransform[4]);
  const double dy = std::hypot(geotransform[2], geotransform[5]);
  if (!geographic) {
    cell_x = dx;
    cell_y = dy;
    return;
  }
  // WGS84 radii of curvature at the centre latitude: meridional M for north-south, prime
  // vertical N cos(phi) for east-west. Good to ~0.1 % across an SRTM tile.
  const double a = 6378137.0, f = 1.0 / 298.257223563, e2 = f * (2 - f);
  const double lat_c = geotransform[3] + geotransform[5] * height * 0.5 + geotransform[4] * width * 0.5;
  const double phi = lat_c * M_PI / 180.0;
  const double s2 = std::sin(phi) * std::sin(phi);
  const double M = a * (1 - e2) / std::pow(1 - e2 * s2, 1.5);
  const double N = a / std::sqrt(1 - e2 * s2);
  cell_x = dx * M_PI / 180.0 * N * std::cos(phi);
  cell_y = dy * M_PI / 180.0 * M;
}

Georef Georef::resampled(double factor) const {
  Georef g = *this;
  for (int i : {1, 2, 4, 5}) g.geotransform[i] /= factor;
  g.cell_x /= factor;
  g.cell_y /= factor;
  return g;
}

size_t Heightfield::count_nodata() const {
  return size_t(std::count_if(z.begin(), z.end(), [](float v) { return !std::isfinite(v); }));
}

HeightStats compute_stats(const Heightfield& h) {
  HeightStats s;
  double sum = 0;
  s.min = INFINITY;
  s.max = -INFINITY;
  for (float v : h.z) {
    if (!std::isfinite(v)) {
      ++s.nodata;
      continue;
    }
    ++s.valid;
    sum += v;
    s.min = std::min<double>(s.min, v);
    s.max = std::max<double>(s.max, v);
  }
  if (s.valid == 0) {
    s.min = s.max = s.mean = NAN;
    return s;
  }
  s.mean = sum / double(s.valid);
  // Slope by central differences in the interior (one-sided at borders), in metric units.
  double slope_sum = 0, slope_max = 0;
  size_t n = 0;
  const double cx = h.georef.cell_x, cy = h.georef.cell_y;
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x) {
      if (h.width < 2 || h.height < 2) break;
      const int x0 = std::max(0, x - 1), x1 = std::min(h.width - 1, x + 1);
      const int y0 = std::max(0, y - 1), y1 = std::min(h.height - 1, y + 1);
      const double a = h.at(x1, y), b = h.at(x0, y), c = h.at(x, y1), d = h.at(x, y0);
      if (!std::isfinite(a + b + c + d)) continue;
      const double gx = (a - b) / ((x1 - x0) * cx), gy = (c - d) / ((y1 - y0) * cy);
      const double deg = std::atan(std::hypot(gx, gy)) * 180.0 / M_PI;
      slope_sum += deg;
      slope_max = std::max(slope_max, deg);
      ++n;
    }
  s.mean_slope_deg = n ? slope_sum / double(n) : 0.0;
  s.max_slope_deg = slope_max;
  return s;
}

void require_finite(const Heightfield& h, const std::string& stage, const std::string& what) {
  const size_t bad = h.count_nodata();
  if (bad)
    fail(stage, "{} has {} nodata/NaN cell{} of {}; this stage needs a complete grid (use --fill-nodata)", what, bad,
         bad == 1 ? "" : "s", h.size());
}

// Above this many unknowns the fill uses conjugate gradients (incomplete Cholesky preconditioner)
// instead of a sparse Cholesky factorisation, whose memory grows faster than the void. Measured on
// a 724k-cell void in N44W072: Cholesky 7.5 s, 0.66 GB; conjugate gradients 80 s, 0.40 GB.
constexpr size_t kDirectFillCells = 2000000;

std::vector<size_t> nodata_cells(const Heightfield& h) {
  std::vector<size_t> cells;
  for (size_t i = 0; i < h.z.size(); ++i)
    if (std::isnan(h.z[i])) cells.push_back(i);
  return cells;
}

void restore_nodata(Heightfield& h, const std::vector<size_t>& cells) {
  for (size_t i : cells)
    if (i < h.z.size()) h.z[i] = std::numeric_limits<float>::quiet_NaN();
}

void fill_nodata_harmonic(Heightfield& h) {
  const size_t bad = h.count_nodata();
  if (bad == 0) return;
  if (bad == h.size()) fail("fill-nodata", "every cell is nodata; nothing to interpolate from");
  // The discrete Laplace equation of the metric grid on the hole cells, sum over in-grid
  // neighbours n of w_n (z_n - z) = 0 with w = 1/cx^2 along rows and 1/cy^2 along columns (so
  // anisotropic geographic cells interpolate in metres), valid neighbours as Dirichlet values and
  // a natural (Neumann) border. Every hole component touches a valid cell, so the system is SPD:
  // a sparse Cholesky factorisation solves it exactly whatever the size of the voids (sweeps over
  // the hole cells needed ~n^2 iterations for an n-cell-wide void).
  const int W = h.width, H = h.height;
  const double cx = h.georef.cell_x > 0 && std::isfinite(h.georef.cell_x) ? h.georef.cell_x : 1.0;
  const double cy = h.georef.cell_y > 0 && std::isfinite(h.georef.cell_y) ? h.georef.cell_y : 1.0;
  // Relative weights (the larger one is 1) keep the matrix well scaled.
  const double wx = std::min(1.0, (cy * cy) / (cx * cx)), wy = std::min(1.0, (cx * cx) / (cy * cy));
  std::vector<int> id(h.size(), -1);
  std::vector<size_t> holes;
  holes.reserve(bad);
  for (size_t i = 0; i < h.size(); ++i)
    if (!std::isfinite(h.z[i])) {
      id[i] = int(holes.size());
      holes.push_back(i);
    }
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(5 * holes.size());
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(Eigen::Index(holes.size()));
  for (size_t k = 0; k < holes.size(); ++k) {
    const size_t i = holes[k];
    const int x = int(i % size_t(W)), y = int(i / size_t(W));
    double diag = 0;
    auto link = [&](bool inside, size_t n, double w) {
      if (!inside) return;
      diag += w;
      if (id[n] >= 0) t.emplace_back(int(k), id[n], -w);
      else rhs[Eigen::Index(k)] += w * double(h.z[n]);
    };
    link(x > 0, i - 1, wx);
    link(x + 1 < W, i + 1, wx);
    link(y > 0, i - size_t(W), wy);
    link(y + 1 < H, i + size_t(W), wy);
    t.emplace_back(int(k), int(k), diag);
  }
  Eigen::SparseMatrix<double> A(Eigen::Index(holes.size()), Eigen::Index(holes.size()));
  A.setFromTriplets(t.begin(), t.end());
  Eigen::VectorXd z;
  if (holes.size() <= kDirectFillCells) {
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(A);
    if (ldlt.info() != Eigen::Success)
      fail("fill-nodata", "the interpolation of {} nodata cells failed (out of memory?)", holes.size());
    z = ldlt.solve(rhs);
  } else {
    Eigen::ConjugateGradient<Eigen::SparseMatrix<double>, Eigen::Lower | Eigen::Upper, Eigen::IncompleteCholesky<double>> cg;
    cg.setTolerance(1e-10);
    cg.setMaxIterations(20000);
    cg.compute(A);
    z = cg.solve(rhs);
    if (cg.info() != Eigen::Success)
      fail("fill-nodata", "the interpolation of {} nodata cells did not converge ({} iterations, error {:.1e})",
           holes.size(), cg.iterations(), cg.error());
  }
  for (size_t k = 0; k < holes.size(); ++k) h.z[holes[k]] = float(z[Eigen::Index(k)]);
}

}  // namespace terracl
