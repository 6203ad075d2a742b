// SPDX-License-Identifier: Apache-2.0
// The band reader of the hypre reconstruction: each MPI rank reads only the rows of each input
// file that its band of the system needs (gradient or divergence, start heightfield, fixed
// rasters) and rasterises only its rows of the constraints, so that no rank holds a whole field
// until rank 0 gathers the result (docs/scale.md).
#include "reconstruct/hypre_solve.hpp"
#include "io/gdal_window.hpp"
#include "io/io_common.hpp"

#include <terracl/constraints.hpp>
#include <terracl/error.hpp>
#include <terracl/gradient.hpp>
#include <terracl/io.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

namespace terracl {

namespace {

// Rows of one heightfield raster: GDAL windows where GDAL reads the format as read_heightfield
// does (GeoTIFF, HGT, other GDAL rasters), else the whole file once, sliced.
class RowSource {
 public:
  explicit RowSource(const std::string& path) : m_path(path) {
    const FileFormat f = format_from_extension(path);
    if (f == FileFormat::GeoTIFF || f == FileFormat::HGT || f == FileFormat::GDALOther) {
      io::require_readable(path);
      m_window = std::make_unique<io::GdalWindowReader>(path);
      m_header = m_window->header();
    } else {
      m_whole = std::make_shared<Heightfield>(read_heightfield(path));
      m_header.width = m_whole->width;
      m_header.height = m_whole->height;
      m_header.georef = m_whole->georef;
      m_header.metadata = m_whole->metadata;
    }
  }
  int width() const { return m_header.width; }
  int height() const { return m_header.height; }
  const Heightfield& header() const { return m_header; }
  // Rows [y0, y1), every check of read_heightfield applied to them.
  Heightfield rows(int y0, int y1) const {
    Heightfield h(width(), y1 - y0);
    h.georef = m_header.georef;
    h.metadata = m_header.metadata;
    if (y1 <= y0) return h;
    if (m_window) {
      h.z = m_window->read(0, y0, width(), y1 - y0).z;
      m_window->release_cache();
    } else {
      std::copy(m_whole->z.begin() + ptrdiff_t(size_t(y0) * width()), m_whole->z.begin() + ptrdiff_t(size_t(y1) * width()),
                h.z.begin());
    }
    for (size_t i = 0; i < h.z.size(); ++i)
      if (std::isinf(h.z[i]))
        fail("io", "{}: cell ({}, {}) holds an infinite elevation ({}); a DEM must hold finite numbers or nodata",
             m_path, i % size_t(width()), y0 + i / size_t(width()), h.z[i]);
    return h;
  }
  void require_size(int W, int H, const char* what) const {
    if (width() != W || height() != H)
      fail("reconstruct", "{}: {} is {}x{}, the gradient {}x{}", m_path, what, width(), height(), W, H);
  }

 private:
  std::string m_path;
  std::unique_ptr<io::GdalWindowReader> m_window;
  std::shared_ptr<Heightfield> m_whole;
  Heightfield m_header;
};

// The same backward differences as reconstruct()'s row function (kernels/gradient.cl's
// divergence in double), on a staggered band whose first row is r0.
hypre::RowDivergence staggered_rows(std::shared_ptr<const GradientField> g, int r0, int W, int H, double icx,
                                    double icy) {
  return [g, r0, W, H, icx, icy](int y, double* f) {
    const size_t o = size_t(y - r0) * W;
    for (int x = 0; x < W; ++x) {
      const double ex = x + 1 < W ? g->gx[o + x] : 0.0, wx = x > 0 ? g->gx[o + x - 1] : 0.0;
      const double sy = y + 1 < H ? g->gy[o + x] : 0.0, ny = y > 0 ? g->gy[o - W + x] : 0.0;
      f[x] = (ex - wx) * icx + (sy - ny) * icy;
    }
  };
}

// kernels/gradient.cl's central_to_staggered on rows [r0, r1) of a central band that starts at
// row r0 and reaches row r1 where the grid has it (the same float operations: bit-identical).
void central_to_staggered_rows(GradientField& g, int r0, int r1, int H) {
  const int W = g.width;
  for (int y = r0; y < r1; ++y) {
    const size_t o = size_t(y - r0) * W;
    for (int x = 0; x < W; ++x) {
      g.gx[o + x] = x + 1 < W ? 0.5f * (g.gx[o + x] + g.gx[o + x + 1]) : 0.0f;
      g.gy[o + x] = y + 1 < H ? 0.5f * (g.gy[o + x] + g.gy[o + W + x]) : 0.0f;
    }
  }
}

}  // namespace

Heightfield read_heightfield_rows(const std::string& path, int y0, int y1, int* W, int* H) {
  const RowSource s(path);
  if (W) *W = s.width();
  if (H) *H = s.height();
  if (y0 < 0 || y1 > s.height() || y0 > y1)
    fail("io", "{}: rows [{}, {}) outside the raster's {} rows", path, y0, y1, s.height());
  return s.rows(y0, y1);
}

ReconstructResult reconstruct_hypre_files(const HypreBandFiles& f, const SolverOptions& o) {
  if (o.solver != Solver::Hypre) fail("reconstruct", "reading the inputs by bands needs --solver hypre");
  if (o.initial) fail("reconstruct", "the band reader takes the start heightfield as a file (--initial)");
  if (f.gradient.empty() == f.divergence.empty()) fail("reconstruct", "give either a gradient or a divergence file");
  if (!(o.tolerance > 0)) fail("reconstruct", "tolerance must be positive, got {}", o.tolerance);
  if (o.max_cycles < 1) fail("reconstruct", "max cycles must be at least 1, got {}", o.max_cycles);
  if (o.dirichlet_border && f.initial.empty())
    fail("reconstruct", "a Dirichlet border needs the initial heightfield for its values");
  if (f.fixed_mask.empty() != f.fixed_elevation.empty())
    fail("reconstruct", "--fixed-mask and --fixed-elevation go together");

  // Headers only: the grid, its georeference, the file's mean elevation.
  int W = 0, H = 0;
  Georef georef;
  Metadata meta;
  double source_mean = std::numeric_limits<double>::quiet_NaN();
  bool central = false;
  std::shared_ptr<RowSource> div_src;
  if (!f.gradient.empty()) {
    const GradientField head = io::read_gradient_rows(f.gradient, 0, 0, &H);
    W = head.width;
    georef = head.georef;
    meta = head.metadata;
    source_mean = head.mean_elevation;
    central = gradient_format(head) == GradientFormat::Central;
  } else {
    div_src = std::make_shared<RowSource>(f.divergence);
    W = div_src->width();
    H = div_src->height();
    georef = div_src->header().georef;
    meta = div_src->header().metadata;
  }
  if (W < 1 || H < 1) fail("reconstruct", "empty input grid");
  const double cx = georef.cell_x, cy = georef.cell_y;
  if (!(cx > 0) || !(cy > 0) || !std::isfinite(cx) || !std::isfinite(cy))
    fail("reconstruct", "cell size must be positive and finite, got {} x {} m", cx, cy);
  if (size_t(W) * size_t(H) > size_t(UINT32_MAX)) fail("reconstruct", "grid {}x{} has too many cells", W, H);
  std::shared_ptr<RowSource> init_src, mask_src, elev_src;
  if (!f.initial.empty()) {
    init_src = std::make_shared<RowSource>(f.initial);
    init_src->require_size(W, H, "the initial heightfield");
  }
  if (!f.fixed_mask.empty()) {
    mask_src = std::make_shared<RowSource>(f.fixed_mask);
    mask_src->require_size(W, H, "fixed mask");
    elev_src = std::make_shared<RowSource>(f.fixed_elevation);
    elev_src->require_size(W, H, "fixed elevation");
  }

  hypre::BandReader read = [&](int y0, int y1, int h0, int h1) {
    hypre::Band b;
    const double icx = 1.0 / cx, icy = 1.0 / cy;
    if (!f.gradient.empty()) {
      // Rows [y0, y1) need gy of the row above (the backward difference); central gradients the
      // row below too (the staggered gy of a row averages it with the next).
      const int r0 = std::max(0, y0 - 1), r1 = central ? std::min(H, y1 + 1) : y1;
      auto g = std::make_shared<GradientField>(io::read_gradient_rows(f.gradient, r0, r1));
      for (size_t i = 0; i < g->gx.size(); ++i)
        if (!std::isfinite(g->gx[i]) || !std::isfinite(g->gy[i]))
          fail("reconstruct", "{}: gradient has a NaN/Inf value at cell ({}, {})", f.gradient, i % size_t(W),
               r0 + i / size_t(W));
      if (central) central_to_staggered_rows(*g, r0, y1, H);
      b.div = staggered_rows(g, r0, W, H, icx, icy);
    } else {
      auto d = std::make_shared<const Heightfield>(div_src->rows(y0, y1));
      for (size_t i = 0; i < d->z.size(); ++i)
        if (!std::isfinite(d->z[i]))
          fail("reconstruct", "{}: the divergence has a NaN value at cell ({}, {})", f.divergence, i % size_t(W),
               y0 + i / size_t(W));
      b.div = [d, y0, W](int y, double* out) {
        const float* row = d->z.data() + size_t(y - y0) * W;
        for (int x = 0; x < W; ++x) out[x] = row[x];
      };
    }
    // The start heightfield's halo band [h0, h1): its own rows start the solve; all of them give
    // the border's and "freeze" constraints' values.
    Heightfield start;
    if (init_src) {
      start = init_src->rows(h0, h1);
      for (size_t i = 0; i < start.z.size(); ++i)
        if (!std::isfinite(start.z[i]))
          fail("reconstruct", "{}: the initial/warm-start heightfield has a NaN value at cell ({}, {})", f.initial,
               i % size_t(W), h0 + i / size_t(W));
      b.initial.assign(start.z.begin() + ptrdiff_t(size_t(y0 - h0) * W),
                       start.z.begin() + ptrdiff_t(size_t(y1 - h0) * W));
    }
    // Constraints of rows [h0, h1) only, in the order of the whole path (rasters, file, border).
    if (mask_src || !f.constraints.empty() || o.dirichlet_border) {
      ConstraintSet c = ConstraintSet::band(W, H, h0, h1 - h0);
      if (mask_src) c.add_rasters(mask_src->rows(h0, h1), elev_src->rows(h0, h1), f.fixed_mask);
      if (!f.constraints.empty()) {
        if (init_src)
          c.outside_current = [src = init_src](int x, int y) { return double(src->rows(y, y + 1).z[size_t(x)]); };
        add_constraints_file(c, f.constraints, georef, init_src ? &start : nullptr);
      }
      if (o.dirichlet_border) c.add_border(start);
      c.hard_cells(b.hard_index, b.hard_value);
    }
    // The readers go before the solve (a non-GDAL raster is held whole until here).
    div_src.reset();
    init_src.reset();
    mask_src.reset();
    elev_src.reset();
    return b;
  };
  const double target = o.mean ? *o.mean : source_mean;
  return hypre::solve(W, H, georef, meta, read, target, o, false);
}

}  // namespace terracl
