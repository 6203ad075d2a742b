// SPDX-License-Identifier: Apache-2.0
// terracl as a library: read a DEM, add a mesa and a crest as hard elevation constraints,
// reconstruct from the DEM's own gradient, erode, write a GeoTIFF.
//
//   terracl_example IN OUT [EROSION_STEPS]
//
// Exits 1 (with the library's "<stage>: message") on any error, and when a hard constraint is not
// kept exactly, so CI can run it as a test (scripts/package-check.sh).
#include <terracl/constraints.hpp>
#include <terracl/device.hpp>
#include <terracl/erosion.hpp>
#include <terracl/error.hpp>
#include <terracl/gradient.hpp>
#include <terracl/io.hpp>
#include <terracl/reconstruct.hpp>
#include <terracl/version.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s IN OUT [EROSION_STEPS]\n", argv[0]);
    return 2;
  }
  const std::string in = argv[1], out = argv[2];
  const int steps = argc > 3 ? std::atoi(argv[3]) : 100;
  try {
    // Device choice as the CLI's: OCL_PLATFORM / OCL_DEVICE / OCL_TYPE, else the first GPU.
    auto dev = terracl::Device::open();
    std::printf("terracl %s on %s\n", terracl::version(), dev->info().name.c_str());

    terracl::ReadOptions ro;
    ro.fill_nodata = true;  // SRTM voids would make the gradient non-finite
    const terracl::Heightfield dem = terracl::read_heightfield(in, ro);
    const terracl::HeightStats before = terracl::compute_stats(dem);

    // The edit lives in the gradient domain: the DEM's own slopes, plus hard elevations.
    const terracl::GradientField g = terracl::extract_gradient(*dev, dem);
    terracl::ConstraintSet c(dem.width, dem.height);
    // The DEM's own border stays where it is (a raster constraint on a one-cell frame); without any
    // hard cell outside the edits, raising them would lift the whole map.
    terracl::Heightfield frame(dem.width, dem.height, 0.0f);
    for (int y = 0; y < dem.height; ++y)
      for (int x = 0; x < dem.width; ++x)
        if (x == 0 || y == 0 || x == dem.width - 1 || y == dem.height - 1) frame.at(x, y) = 1.0f;
    c.add_rasters(frame, dem, "border");
    // A mesa: an octagon around the centre held flat 100 m above the mean of the cells it covers.
    const double cx = dem.width / 2.0, cy = dem.height / 2.0, radius = std::min(dem.width, dem.height) / 40.0 + 2;
    const double pi = 3.14159265358979323846;
    std::vector<std::array<double, 2>> octagon;
    for (int i = 0; i < 8; ++i)
      octagon.push_back({cx + radius * std::cos(i * pi / 4), cy + radius * std::sin(i * pi / 4)});
    double sum = 0;
    int n = 0;
    for (int y = int(cy - radius / 2); y <= int(cy + radius / 2); ++y)
      for (int x = int(cx - radius / 2); x <= int(cx + radius / 2); ++x, ++n) sum += dem.at(x, y);
    c.add_polygon(octagon, sum / n + 100.0, "mesa");
    // A new crest: a polyline from the terrain up to 150 m above it and back down (z is interpolated
    // along the line), so it meets the terrain at both ends.
    const double x0 = dem.width * 0.15, x1 = dem.width * 0.3, x2 = dem.width * 0.45, y0 = dem.height * 0.75,
                 y1 = dem.height * 0.7;
    c.add_polyline({{x0, y0, dem.at(int(x0), int(y0))},
                    {x1, y1, dem.at(int(x1), int(y1)) + 150.0},
                    {x2, y0, dem.at(int(x2), int(y0))}},
                   3.0, "crest");

    terracl::SolverOptions so;
    so.tolerance = 1e-6;
    const terracl::ReconstructResult r = terracl::reconstruct(*dev, g, c, so);
    std::printf("reconstruct: %d cycles, relative residual %.2e (%s), %zu hard cells, %.0f ms\n", r.cycles,
                r.residuals.empty() ? 0.0 : r.residuals.back(),
                r.converged ? "converged" : r.stagnated ? "float32 floor" : "not converged", r.hard_cells, r.total_ms);
    for (int y = 0; y < dem.height; ++y)
      for (int x = 0; x < dem.width; ++x)
        if (c.is_hard(x, y) && r.height.at(x, y) != c.value(x, y)) {
          std::fprintf(stderr, "hard cell (%d, %d) moved: %g != %g\n", x, y, r.height.at(x, y), c.value(x, y));
          return 1;
        }

    const terracl::Heightfield eroded = terracl::erode(*dev, r.height, terracl::ErosionParams::defaults(), steps);
    double change = 0, largest = 0;
    for (size_t i = 0; i < eroded.size(); ++i) {
      const double d = std::abs(double(eroded.z[i]) - r.height.z[i]);
      change += d;
      largest = std::max(largest, d);
    }
    const terracl::HeightStats after = terracl::compute_stats(eroded);
    std::printf("erode: %d steps, bed change mean %.2f m, largest %.1f m\n", steps, change / eroded.size(), largest);
    std::printf("elevation %.1f..%.1f m -> %.1f..%.1f m, mean slope %.2f -> %.2f deg\n", before.min, before.max,
                after.min, after.max, before.mean_slope_deg, after.mean_slope_deg);

    terracl::write_heightfield(eroded, out);  // temporary name + rename: never a partial file
    std::printf("wrote %s (%d x %d)\n", out.c_str(), eroded.width, eroded.height);
    return 0;
  } catch (const terracl::Error& e) {
    std::fprintf(stderr, "terracl_example ERROR: %s\n", e.what());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "terracl_example ERROR: %s\n", e.what());
  }
  return 1;
}
