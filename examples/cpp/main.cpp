// terracl as a library: read a DEM, raise a summit and pin a terrace with hard constraints,
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

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

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
    const int cx = dem.width / 2, cy = dem.height / 2;
    c.add_point(cx, cy, dem.at(cx, cy) + 300.0, "summit");  // +300 m at the centre
    const double terrace = before.min + 0.25 * (before.max - before.min);
    c.add_polyline({{dem.width * 0.1, dem.height * 0.8, terrace}, {dem.width * 0.4, dem.height * 0.8, terrace}}, 3.0,
                   "terrace");

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

    terracl::ErosionOutputs eo;
    const terracl::Heightfield eroded =
        terracl::erode(*dev, r.height, terracl::ErosionParams::defaults(), steps, nullptr, &eo);
    const terracl::HeightStats after = terracl::compute_stats(eroded);
    std::printf("erode: %d steps (%d sub-steps each), suspended sediment %.3g m3\n", steps, eo.substeps,
                eo.totals.sediment);
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
