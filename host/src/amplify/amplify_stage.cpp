// SPDX-License-Identifier: Apache-2.0
// The `amplify` stage and the `amplify` benchmark.
#include "amplify/exemplar_warp.hpp"
#include "authoring/landform_detail.hpp"
#include "pipeline/builtin.hpp"

#include <terracl/amplify.hpp>
#include <terracl/error.hpp>
#include <terracl/memory.hpp>
#include <terracl/io.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <sys/resource.h>
#include <filesystem>
#include <optional>
#include <sstream>

namespace terracl {

namespace {

ReadOptions filled() {
  ReadOptions r;
  r.fill_nodata = true;
  return r;
}

std::vector<std::string> split_list(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

// A .tdic file, or `style:NAME`: a bundled style's dictionary (the studio's landform detail).
Dictionary dictionary_from(const std::string& spec) {
  if (spec.rfind("style:", 0) == 0) return edit::bundled_style_dictionary(spec.substr(6));
  return load_dictionary(spec);
}

}  // namespace

AmplifyOptions amplify_options(const json& options) {
  AmplifyOptions o;
  o.factor = options.at("factor").get<int>();
  o.spacing = options.at("spacing").get<int>();
  o.sparsity = options.at("sparsity").get<int>();
  o.search = options.at("search").get<std::string>();
  o.trees = options.at("trees").get<int>();
  o.checks = options.at("checks").get<int>();
  o.seed = unsigned(options.at("seed").get<int>());
  o.neighbours = options.at("neighbours").get<int>();
  o.candidates = options.at("candidates").get<int>();
  o.magnitude_weight = float(options.at("magnitude_weight").get<double>());
  o.tile = options.at("tile").get<int>();
  o.bias_correction = options.at("bias_correction").get<bool>();
  o.detail_gain = float(options.at("detail_gain").get<double>());
  o.blend = options.at("blend").get<std::string>();
  o.mode = options.at("mode").get<std::string>();
  o.base = options.at("base").get<std::string>();
  o.cascade_relief_exponent = float(options.at("cascade_relief_exponent").get<double>());
  return o;
}

namespace {

void run_amplify(StageContext& c) {
  Heightfield& low = c.height();
  const AmplifyOptions o = amplify_options(c.options);
  // A tile of a tiled run (tile/amplify_tiles.cpp): its window's first cell in the whole input, and
  // the whole input's detail correlations.
  std::optional<std::pair<int, int>> window;
  std::vector<float> correlations;
  if (auto it = low.metadata.find("terracl:tile_window"); it != low.metadata.end()) {
    std::istringstream w(it->second);
    int x = 0, y = 0;
    w >> x >> y;
    window = {x, y};
    std::istringstream r(low.metadata.at("terracl:tile_prepass"));
    for (float v; r >> v;) correlations.push_back(v);
    low.metadata.erase("terracl:tile_window");
    low.metadata.erase("terracl:tile_prepass");
  }
  // Before any work: x256 of a 1201^2 tile asked for 10+ GB and failed after 27 s.
  require_raster_size("amplify", fmt::format("the x{} output of a {} x {} input", o.factor, low.width, low.height),
                      int64_t(low.width) * o.factor, int64_t(low.height) * o.factor, 8);
  const bool has_ex = c.has("exemplar"), has_dict = c.has("dictionary");
  if (has_ex == has_dict)
    throw UsageError("amplify", "give exactly one of --exemplar FILE[,FILE...] or --dictionary FILE (a .tdic, or a bundled "
                                "style: --dictionary style:alpine, style:eroded_hills or style:dissected_plateau)");
  Heightfield out;
  if (c.has("style_mask")) {
    if (!has_dict || !c.has("style_dictionary"))
      throw UsageError("amplify", "--style-mask needs --dictionary (mask 0) and --style-dictionary (mask 1)");
    const Dictionary a = dictionary_from(c.get<std::string>("dictionary"));
    const Dictionary b = dictionary_from(c.get<std::string>("style_dictionary"));
    const Heightfield mask = read_heightfield(c.get<std::string>("style_mask"));
    out = amplify_styles(low, {&a, &b}, mask, c.get<double>("style_blend"), o, c.progress);
  } else if (has_dict) {
    const Dictionary d = dictionary_from(c.get<std::string>("dictionary"));
    if (o.mode == "faithful" && !d.has_regression())
      throw UsageError("amplify", fmt::format("--mode faithful: {} stores no faithful regression (format version 2 or "
                                              "older, or learned with --faithful-radius 0); learn it again with "
                                              "`terracl dictionary learn`, or give --exemplar",
                                              c.get<std::string>("dictionary")));
    out = window ? amplify_window(low, window->first, window->second, d, o, correlations, c.progress)
                 : amplify(low, d, o, c.progress);
  } else {
    std::vector<Heightfield> ex;
    std::vector<std::string> notes;
    for (const auto& f : split_list(c.get<std::string>("exemplar"))) {
      if (!path_exists(f)) throw MissingFileError("amplify", fmt::format("--exemplar: file {} does not exist", f), f);
      ex.push_back(read_heightfield(f, filled()));
      if (c.get<bool>("resample_exemplar")) {
        // To the output's cell size (the finest step's); coarser steps average it further.
        ex.back() = resample_exemplar(ex.back(), low.georef, low.georef.cell_x / o.factor, low.georef.cell_y / o.factor, f);
        for (const auto& [k, v] : ex.back().metadata)
          if (k == "amplify_exemplar_resampled") notes.push_back(v);
      }
    }
    if (ex.empty()) throw UsageError("amplify", "--exemplar: no file given");
    LearnOptions l;
    l.patch = c.get<int>("patch");
    l.atoms = c.get<int>("atoms");
    l.sparsity = o.sparsity;
    l.method = c.get<std::string>("method");
    l.seed = o.seed;
    try {
      out = amplify_from_exemplars(low, ex, l, o, c.progress);
    } catch (const Error& e) {
      // The library names the exemplar "<exemplar>" in its warp command; here we know the file.
      std::string m = std::string(e.what()).substr(e.stage().size() + 2);
      const auto files = split_list(c.get<std::string>("exemplar"));
      if (const auto at = m.find("<exemplar>"); at != std::string::npos && files.size() == 1)
        m.replace(at, 10, files[0]);
      if (m == std::string(e.what()).substr(e.stage().size() + 2)) throw;
      throw Error(e.stage(), m);
    }
    if (!notes.empty()) {
      std::string s;
      for (const auto& n : notes) s += (s.empty() ? "" : " | ") + n;
      out.metadata["amplify_exemplar_resampled"] = s;
    }
  }
  out.metadata["amplify_factor"] = std::to_string(o.factor);
  low = std::move(out);
}

}  // namespace

void register_amplify_stages(StageRegistry& r) {
  r.add({"amplify",
         "Amplify a heightfield by 4, 16, 64 or 256 with a multi-resolution sparse dictionary (from exemplars or a "
         ".tdic file); block means of the output match the input.",
         DataKind::Heightfield,
         DataKind::Heightfield,
         {
             OptionSpec{"factor", OptionType::Int, 4, "", "Total amplification factor (power of 4)", {}}.range(2, 256),
             {"exemplar", OptionType::String, nullptr, "", "High-resolution exemplar file(s), comma-separated", {}},
             {"dictionary", OptionType::Path, nullptr, "", "Dictionary file (.tdic) from `terracl dictionary learn`, or a bundled style: style:alpine, style:eroded_hills, style:dissected_plateau", {}},
             OptionSpec{"patch", OptionType::Int, 16, "cells", "Patch size P at the output resolution (with --exemplar)", {}}.range(2, 256),
             OptionSpec{"atoms", OptionType::Int, 1024, "", "Dictionary atoms (with --exemplar, constrained/ksvd)", {}}.range(1, 1 << 20),
             {"method", OptionType::Enum, "complete", "", "Learning method with --exemplar", {"complete", "constrained", "ksvd"}},
             OptionSpec{"spacing", OptionType::Int, 8, "cells", "Spacing of output patches (multiple of 4, <= patch)", {}}.range(1, 256),
             OptionSpec{"sparsity", OptionType::Int, 1, "", "Atoms per patch", {}}.range(1, 64),
             {"search", OptionType::Enum, "auto", "", "Atom search for sparsity 1", {"auto", "flann", "exact", "omp"}},
             OptionSpec{"trees", OptionType::Int, 2, "", "FLANN kd-trees", {}}.range(1, 64),
             OptionSpec{"checks", OptionType::Int, 8, "", "FLANN leaf checks (-1: unlimited, exact)", {}}.range(-1, 1 << 20),
             OptionSpec{"neighbours", OptionType::Int, 0, "", "Sparsity 1: average of the k best atoms (0: the dictionary's, 3 when learned now)", {}}.range(0, 64),
             OptionSpec{"candidates", OptionType::Int, 0, "", "Pool of nearest atoms each patch draws its neighbours from, by position (0: the nearest)", {}}.range(0, 4096),
             OptionSpec{"magnitude_weight", OptionType::Float, -1.0, "", "Weight of the atom search's magnitude term (0: off; -1: the dictionary's, 0.4 when learned now)", {}}.range(-1, 100),
             OptionSpec{"seed", OptionType::Int, 1, "", "Seed of FLANN's trees, the candidate draw and (--exemplar) the training subset: same seed, same output", {}}.range(0, {}),
             OptionSpec{"tile", OptionType::Int, 1024, "cells", "Output tile size (bounds memory)", {}}.range(16, 65536),
             OptionSpec{"detail_gain", OptionType::Float, -1.0, "", "Gain on synthesized detail (-1: the dictionary's calibrated gain)", {}}.range(-1, 100),
             {"bias_correction", OptionType::Bool, true, "", "Match the output's block means to the input", {}},
             {"resample_exemplar", OptionType::Bool, false, "", "Warp each exemplar (GDAL, averaging) to the output's cell size, and to the input's CRS when they differ", {}},
             {"mode", OptionType::Enum, "detail", "", "detail: plausible relief from the exemplar's patches; faithful: the estimate closest to the truth (a regression learned on the exemplar, or the one a version 3 dictionary stores)", {"detail", "faithful"}},
             {"blend", OptionType::Enum, "auto", "", "Patch blend: detail (bicubic + variance-preserving blend of the patches' details, no patch-grid trace), average (the paper's weighted mean of the patches) or auto (the dictionary's; detail when learned now)", {"auto", "detail", "average"}},
             {"base", OptionType::Enum, "auto", "", "Detail mode's base (what the input's block means determine; details are taken relative to it): bicubic, bandlimited (a consistent band-limited kernel: no curvature peak at the input cells' centres) or auto (the dictionary's; bandlimited when learned now, bicubic for dictionaries older than format version 3)", {"auto", "bicubic", "bandlimited"}},
             OptionSpec{"cascade_relief_exponent", OptionType::Float, -1.0, "", "Detail blend, x16 and beyond: steps after the first multiply their detail gain by (q_ref / q_med)^b, q_med the median relief of the step's patch footprints, q_ref the dictionary's atoms' (-1: b from the dictionary's atoms; 0: off)", {}}.range(-1, 4),
             {"style_mask", OptionType::Path, nullptr, "", "Mask at the input resolution: 0 = --dictionary, 1 = --style-dictionary", {}},
             {"style_dictionary", OptionType::Path, nullptr, "", "Second style's dictionary (a .tdic or style:NAME)", {}},
             OptionSpec{"style_blend", OptionType::Float, 4.0, "cells", "Width of the blend across the mask's edge (input cells)", {}}.range(0, 1000),
         },
         run_amplify});
}

void register_amplify_benches(BenchRegistry& r) {
  r.add({"amplify",
         "Amplify a DEM (--set dem=FILE, default data/dem/N44W072.hgt) cropped/averaged to --size, by --set factor=4 "
         "with a dictionary learned from the DEM itself",
         [](const BenchArgs& a) {
           const std::string dem = a.extra.value("dem", std::string("data/dem/N44W072.hgt"));
           const int factor = a.extra.value("factor", 4);
           Heightfield full = read_heightfield(dem, filled());
           LearnOptions l;
           l.method = a.extra.value("method", std::string("complete"));
           l.atoms = a.extra.value("atoms", 1024);
           l.iterations = a.extra.value("iterations", l.iterations);
           l.max_patches = a.extra.value("max_patches", l.max_patches);
           l.calibration_base = a.extra.value("base", l.calibration_base);  // amplify uses the dictionary's
           using clock = std::chrono::steady_clock;
           auto t0 = clock::now();
           const Dictionary d = learn_dictionary({full}, l);
           const double learn_s = std::chrono::duration<double>(clock::now() - t0).count();
           // Input: block means of the DEM so that --size cells cover as much of it as possible.
           int b = std::max(1, std::min(full.width, full.height) / a.size);
           Heightfield low = b > 1 ? block_mean(full, b) : full;
           Heightfield in(std::min(a.size, low.width), std::min(a.size, low.height));
           in.georef = low.georef;
           for (int y = 0; y < in.height; ++y)
             for (int x = 0; x < in.width; ++x) in.at(x, y) = low.at(x, y);
           AmplifyOptions o;
           o.factor = factor;
           o.search = a.extra.value("search", std::string("auto"));
           o.checks = a.extra.value("checks", 8);
           o.trees = a.extra.value("trees", 2);
           o.neighbours = a.extra.value("neighbours", o.neighbours);
           o.magnitude_weight = a.extra.value("magnitude_weight", o.magnitude_weight);
           o.blend = a.extra.value("blend", o.blend);
           o.mode = a.extra.value("mode", o.mode);
           std::vector<double> times;
           Heightfield out;
           // Faithful: the regression learned on the DEM serves every x4 step (self-similarity).
           const BlockRegression reg = o.mode == "faithful" ? learn_block_regression({full}, 4, o.faithful_radius) : BlockRegression{};
           for (int k = 0; k < a.repeats; ++k) {
             auto t1 = clock::now();
             if (o.mode == "faithful") {
               out = in;
               for (int f = 1; f < factor; f *= 4) {
                 Heightfield next = apply_block_regression(out, reg);
                 correct_block_means(next, out, 4);
                 out = std::move(next);
               }
             } else {
               out = amplify(in, d, o);
             }
             times.push_back(std::chrono::duration<double>(clock::now() - t1).count());
           }
           std::sort(times.begin(), times.end());
           fmt::print("amplify: {}x{} -> {}x{} (x{}), dictionary {} atoms ({}, learned in {:.2f} s)\n", in.width, in.height,
                      out.width, out.height, factor, d.atoms(), l.method, learn_s);
           rusage ru{};
           getrusage(RUSAGE_SELF, &ru);
           fmt::print("amplify: median {:.3f} s, min {:.3f} s over {} runs (search {}, trees {}, checks {}); peak RSS {:.0f} MiB, "
                      "output {:.0f} MiB\n", times[times.size() / 2], times.front(), times.size(), o.search, o.trees, o.checks,
                      ru.ru_maxrss / 1024.0, out.size() * 4.0 / (1 << 20));
         }});
}

}  // namespace terracl
