// SPDX-License-Identifier: Apache-2.0
// `terracl dictionary learn|encode|evaluate`: dictionaries for amplification, the compression report of
// the sparse terrain paper (table 1), and the amplification evaluation table (scripts/eval-amplify.sh).
#include "cli.hpp"

#include <terracl/amplify.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>

#include <fmt/format.h>

#include <chrono>

namespace terracl::cli {
namespace {

ReadOptions filled() {
  ReadOptions r;
  r.fill_nodata = true;
  return r;
}

struct LearnArgs {
  std::vector<std::string> exemplars;
  std::string output;
  LearnOptions o;
  bool constrained = false;
  std::string method;
};

struct EncodeArgs {
  std::string input;
  int atoms = 128, patch = 16, iterations = 8;
  std::vector<int> sparsity{1, 2, 8};
};

struct SketchArgs {
  std::string input, output, dictionary;
  double zmin = 0, zmax = 1000, cell = 100, smooth = 2;
  AmplifyOptions amp;
};

struct EvalArgs {
  std::string input;
  int factor = 4;
  LearnOptions learn;
  AmplifyOptions amp;
  bool header = false;
  std::string save;
  bool no_corr = false;
  int recall_samples = 0;
  int trace_seeds = 1;
  std::vector<int> recall_checks{8, 32, 128, 512};
};

Heightfield crop(const Heightfield& h, int x0, int y0, int w, int ht) {
  Heightfield out(w, ht);
  out.georef = h.georef;
  auto& gt = out.georef.geotransform;
  const auto& g = h.georef.geotransform;
  gt[0] = g[0] + x0 * g[1] + y0 * g[2];
  gt[3] = g[3] + x0 * g[4] + y0 * g[5];
  for (int y = 0; y < ht; ++y)
    for (int x = 0; x < w; ++x) out.at(x, y) = h.at(x0 + x, y0 + y);
  return out;
}

void print_row(const std::string& name, int f, const std::string& method, const AmplifyMetrics& m, double secs) {
  fmt::print("| {:<26} | x{:<3} | {:<22} | {:8.2f} | {:6.2f} | {:5.3f} | {:5.3f} | {:5.3f} | {:7.3f} | {:6.1f} | {:6.1f} | {:5.3f} | {:6.2f} |\n",
             name, f, method, m.rmse, m.psnr, m.hf_ratio, m.roughness_ratio, m.slope_ratio, m.lr_consistency,
             m.patch_peak, m.block_peak, m.d8_agreement, secs);
}

CommandRegistrar reg(40, [](CLI::App& app) {
  auto* dict = app.add_subcommand("dictionary", "Sparse terrain dictionaries: learn, encode (compression report), evaluate");
  dict->require_subcommand(1);

  auto la = std::make_shared<LearnArgs>();
  auto* learn = dict->add_subcommand("learn", "Learn a multi-resolution dictionary (.tdic) from high-resolution exemplars");
  learn->add_option("exemplars", la->exemplars, "Exemplar rasters (same cell size)")->required();
  learn->add_option("-o,--output", la->output, "Output dictionary (.tdic)")->required();
  learn->add_option("--atoms", la->o.atoms, "Number of atoms N")->capture_default_str();
  learn->add_option("--sparsity", la->o.sparsity, "Sparsity s used while learning")->capture_default_str();
  learn->add_option("--patch", la->o.patch, "High-resolution patch size P (multiple of --factor)")->capture_default_str();
  learn->add_option("--factor", la->o.factor, "Resolution ratio between H and L")->capture_default_str();
  learn->add_option("--iterations", la->o.iterations, "K-SVD iterations")->capture_default_str();
  learn->add_option("--stride", la->o.stride, "Spacing of training patches (cells)")->capture_default_str();
  learn->add_option("--max-patches", la->o.max_patches, "Random subset of training patches (0 = all)")->capture_default_str();
  learn->add_option("--base", la->o.calibration_base,
                    "Detail mode's base the gain is calibrated for and amplify uses by default (see amplify --base)")
      ->check(CLI::IsMember({"bicubic", "bandlimited"}))
      ->capture_default_str();
  learn->add_flag("--no-detail-anisotropy{false}", la->o.calibration_anisotropy,
                  "Calibrate the gain for one detail correlation rho (amplify then keeps one rho with this dictionary)");
  learn->add_option("--faithful-radius", la->o.faithful_radius,
                    "Neighbourhood radius (input cells, 1-4) of the faithful mode's regression stored with the dictionary (0: none)")
      ->check(CLI::Range(0, 4))
      ->capture_default_str();
  learn->add_flag("--constrained", la->constrained, "Atoms must be real exemplar patches (problem 2)");
  learn->add_option("--method", la->method, "ksvd | constrained | complete (default ksvd, or constrained with --constrained)")
      ->check(CLI::IsMember({"ksvd", "constrained", "complete"}));
  learn->callback([la] {
    LearnOptions o = la->o;
    o.method = !la->method.empty() ? la->method : la->constrained ? "constrained" : "ksvd";
    std::vector<NamedPath> inputs;
    for (const auto& f : la->exemplars) inputs.push_back({"exemplar", f});
    check_output_paths("dictionary", inputs, {{"-o", la->output}});
    std::vector<Heightfield> ex;
    for (const auto& f : la->exemplars) ex.push_back(read_heightfield(f, filled()));
    auto t0 = std::chrono::steady_clock::now();
    Dictionary d = learn_dictionary(ex, o, make_progress("dictionary"));
    finish_progress();
    save_dictionary(d, la->output);
    if (!globals().quiet)
      fmt::print("{}: {} atoms, patch {} (low {}), factor {}, {} ({:.1f} s)\n", la->output, d.atoms(), d.patch, d.low_patch(),
                 d.factor, d.description, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  });

  auto ea = std::make_shared<EncodeArgs>();
  auto* enc = dict->add_subcommand("encode", "Compression report: storage ratio rho and PSNR for sparsity 1, 2, 8 (paper table 1)");
  enc->add_option("input", ea->input, "DEM")->required();
  enc->add_option("--atoms", ea->atoms, "Dictionary atoms")->capture_default_str();
  enc->add_option("--patch", ea->patch, "Patch size P (patches spaced P/2)")->capture_default_str();
  enc->add_option("--iterations", ea->iterations, "K-SVD iterations")->capture_default_str();
  enc->add_option("--sparsity", ea->sparsity, "Sparsities to report")->capture_default_str();
  enc->callback([ea] {
    const Heightfield h = read_heightfield(ea->input, filled());
    fmt::print("{} ({}x{}, t0 = {} values), {} atoms, {}x{} patches\n", ea->input, h.width, h.height, h.size(), ea->atoms,
               ea->patch, ea->patch);
    fmt::print("| sparsity | rho    | PSNR (dB) | RMSE (m) |\n|---|---|---|---|\n");
    for (int s : ea->sparsity) {
      const EncodeReport r = encode_report(h, s, ea->atoms, ea->patch, ea->iterations);
      fmt::print("| {:8} | {:5.1f} % | {:9.2f} | {:8.2f} |\n", s, 100 * r.rho, r.psnr, r.rmse);
    }
  });

  auto sa = std::make_shared<SketchArgs>();
  sa->amp.factor = 16;
  sa->amp.candidates = 6;  // painted edges give many identical footprints: vary their detail
  auto* sk = dict->add_subcommand("sketch", "Synthesize a terrain from a coarse painted sketch (grey PNG) with a dictionary");
  sk->add_option("input", sa->input, "Sketch image (8/16-bit grey PNG or any raster)")->required();
  sk->add_option("-o,--output", sa->output, "Output heightfield")->required();
  sk->add_option("--dictionary", sa->dictionary, "Dictionary (.tdic)")->required();
  sk->add_option("--zmin", sa->zmin, "Elevation of black (m)")->capture_default_str();
  sk->add_option("--zmax", sa->zmax, "Elevation of white (m)")->capture_default_str();
  sk->add_option("--cell", sa->cell, "Sketch cell size (m)")->capture_default_str();
  sk->add_option("--smooth", sa->smooth, "Tent filter width applied to the sketch (cells)")->capture_default_str();
  sk->add_option("--factor", sa->amp.factor, "Amplification factor (4, 16, 64, 256)")->capture_default_str();
  sk->add_option("--neighbours", sa->amp.neighbours, "Sparsity 1: average of the k best atoms (0: the dictionary's)")
      ->capture_default_str();
  sk->add_option("--candidates", sa->amp.candidates, "Pool of nearest atoms each patch draws its neighbours from")
      ->capture_default_str();
  sk->add_option("--magnitude-weight", sa->amp.magnitude_weight, "Weight of the atom search's magnitude term (0: off; -1: the dictionary's)")
      ->capture_default_str();
  sk->add_option("--seed", sa->amp.seed, "Seed of FLANN's randomized trees")->capture_default_str();
  sk->callback([sa] {
    check_output_paths("dictionary", {{"input", sa->input}, {"--dictionary", sa->dictionary}}, {{"-o", sa->output}});
    ReadOptions r;
    r.zmin = sa->zmin;
    r.zmax = sa->zmax;
    r.cell_size = sa->cell;
    Heightfield s = read_heightfield(sa->input, r);
    if (!s.georef.has_geotransform) {
      // A local metric grid, so that GeoTIFF/ASCII outputs keep the cell size.
      s.georef.geotransform = {0.0, sa->cell, 0.0, 0.0, 0.0, -sa->cell};
      s.georef.has_geotransform = true;
      s.georef.cell_x = s.georef.cell_y = sa->cell;
    }
    const Dictionary d = load_dictionary(sa->dictionary);
    Heightfield out = synthesize_from_sketch(s, d, sa->smooth, sa->amp, make_progress("sketch"));
    finish_progress();
    for (const auto& [k, v] : provenance()) out.metadata[k] = v;
    write_heightfield(out, sa->output);
  });

  auto va = std::make_shared<EvalArgs>();
  va->learn.method = "complete";
  auto* ev = dict->add_subcommand("evaluate",
                                  "Amplification vs bicubic on a DEM: west half exemplar, east half truth, block-mean input");
  ev->add_option("input", va->input, "DEM")->required();
  ev->add_option("--factor", va->factor, "4 or 16")->capture_default_str();
  ev->add_option("--patch", va->learn.patch, "Patch size")->capture_default_str();
  ev->add_option("--atoms", va->learn.atoms, "Atoms (constrained/ksvd)")->capture_default_str();
  ev->add_option("--method", va->learn.method, "complete | constrained | ksvd")->capture_default_str();
  ev->add_option("--max-patches", va->learn.max_patches, "Training patches")->capture_default_str();
  ev->add_option("--stride", va->learn.stride, "Training patch stride")->capture_default_str();
  ev->add_option("--iterations", va->learn.iterations, "K-SVD iterations")->capture_default_str();
  ev->add_option("--spacing", va->amp.spacing, "Output patch spacing")->capture_default_str();
  ev->add_option("--sparsity", va->amp.sparsity, "Sparsity")->capture_default_str();
  ev->add_option("--search", va->amp.search, "auto | flann | exact | omp")->capture_default_str();
  ev->add_option("--checks", va->amp.checks, "FLANN checks")->capture_default_str();
  ev->add_option("--trees", va->amp.trees, "FLANN trees")->capture_default_str();
  ev->add_option("--neighbours", va->amp.neighbours, "Sparsity 1: average of the k best atoms (0: 3)")->capture_default_str();
  ev->add_option("--candidates", va->amp.candidates, "Pool of nearest atoms each patch draws its neighbours from")
      ->capture_default_str();
  ev->add_option("--magnitude-weight", va->amp.magnitude_weight, "Weight of the atom search's magnitude term (0: off; -1: 0.4)")
      ->capture_default_str();
  ev->add_option("--mode", va->amp.mode, "detail | faithful (see amplify --mode)")->capture_default_str();
  ev->add_option("--detail-correlation", va->amp.detail_correlation, "Detail blend: assumed correlation of overlapping details")->capture_default_str();
  ev->add_flag("--no-detail-anisotropy{false}", va->amp.detail_anisotropy,
              "Detail blend: one measured rho for all overlaps (isotropic)");
  ev->add_option("--cascade-relief-exponent", va->amp.cascade_relief_exponent,
                 "Detail blend, x16: the second step's gain times (q_ref / q_med)^b, the relief of the dictionary's atoms over its input's footprints (-1: b from the dictionary; 0: off)")
      ->capture_default_str();
  ev->add_option("--base", va->amp.base, "bicubic | bandlimited | auto (see amplify --base)")->capture_default_str();
  ev->add_option("--blend", va->amp.blend, "detail | average | auto (see amplify --blend)")->capture_default_str();
  ev->add_option("--detail-gain", va->amp.detail_gain, "Gain on the synthesized detail (-1: calibrated)")->capture_default_str();
  ev->add_option("--seed", va->amp.seed, "Seed of the training subset and of FLANN's trees")->capture_default_str();
  ev->add_flag("--header", va->header, "Print the table header first");
  ev->add_flag("--no-corr", va->no_corr, "Also amplify without the bias correction (a row 'no-corr')");
  ev->add_option("--save", va->save, "Also write truth, input, bicubic and amplified output as PREFIX_*.tif");
  ev->add_option("--trace-seeds", va->trace_seeds,
                 "Detail mode: pk S and pk f from the curvature spectra averaged over this many seeds (--seed, --seed + 1, ...)")
      ->check(CLI::Range(1, 16))
      ->capture_default_str();
  ev->add_option("--recall", va->recall_samples, "Also measure FLANN recall against exact search on this many queries");
  ev->add_option("--recall-checks", va->recall_checks, "FLANN checks values for --recall")->capture_default_str();
  ev->callback([va] {
    const Heightfield h = read_heightfield(va->input, filled());
    const int f = va->factor, half = h.width / 2;
    const int w = half / f * f, ht = h.height / f * f;
    const Heightfield west = crop(h, 0, 0, half, h.height);
    const Heightfield truth = crop(h, h.width - w, 0, w, ht);
    const Heightfield low = block_mean(truth, f);
    std::string name = va->input.substr(va->input.find_last_of('/') + 1);
    if (va->header) {
      fmt::print("| {:<26} | {:<4} | {:<22} | {:>8} | {:>6} | {:>5} | {:>5} | {:>5} | {:>7} | {:>6} | {:>6} | {:>5} | {:>6} |\n", "DEM",
                 "f", "method", "RMSE m", "PSNR", "HF", "rough", "slope", "LR m", "pk S", "pk f", "D8", "time s");
      fmt::print("|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    }
    va->learn.seed = va->amp.seed;
    using clock = std::chrono::steady_clock;
    auto t0 = clock::now();
    const Heightfield bic = bicubic_upsample(low, f);
    const double tb = std::chrono::duration<double>(clock::now() - t0).count();
    print_row(name, f, "bicubic", evaluate_amplification(bic, truth, low, f, va->amp.spacing), tb);
    AmplifyOptions o = va->amp;
    o.factor = f;
    t0 = clock::now();
    const Heightfield out = amplify_from_exemplars(low, {west}, va->learn, o);
    const double ta = std::chrono::duration<double>(clock::now() - t0).count();
    const std::string label = o.mode == "faithful" ? fmt::format("faithful r{}", o.faithful_radius)
                                                   : fmt::format("{} P{} S{} s{}", va->learn.method, va->learn.patch, o.spacing, o.sparsity);
    AmplifyMetrics m = evaluate_amplification(out, truth, low, f, o.spacing);
    if (va->trace_seeds > 1 && o.mode == "detail") {
      // The periodic traces averaged over seeds (periodic_trace of several rasters): one output's peak
      // is a noisy variable (x16 pk S 15 / 10 / 4 over seeds 1-3 on the Front Range).
      std::vector<Heightfield> more;
      for (int s = 1; s < va->trace_seeds; ++s) {
        AmplifyOptions os = o;
        LearnOptions ls = va->learn;
        os.seed = ls.seed = o.seed + unsigned(s);
        more.push_back(amplify_from_exemplars(low, {west}, ls, os));
      }
      std::vector<const Heightfield*> all{&out};
      for (const auto& h : more) all.push_back(&h);
      m.patch_peak = periodic_trace(all, o.spacing).peak;
      m.block_peak = periodic_trace(all, f).peak;
    }
    print_row(name, f, label, m, ta);
    if (!va->save.empty()) {
      write_heightfield(truth, va->save + "_truth.tif");
      write_heightfield(low, va->save + "_low.tif");
      write_heightfield(bic, va->save + "_bicubic.tif");
      write_heightfield(out, va->save + "_out.tif");
    }
    for (const char* key : {"amplify_detail_gain", "amplify_calibration", "amplify_hf_calibration", "amplify_relief_scale"})
      if (out.metadata.count(key)) fmt::print("# {} x{} {}: {}\n", name, f, key, out.metadata.at(key));
    if (o.mode == "faithful") return;
    if (va->no_corr) {
      o.bias_correction = false;
      const Heightfield raw = amplify_from_exemplars(low, {west}, va->learn, o);
      print_row(name, f, label + " no-corr", evaluate_amplification(raw, truth, low, f, o.spacing), 0);
    }
    if (va->recall_samples > 0) {
      // The first step's dictionary and queries: the input's low-resolution disc patches.
      LearnOptions l = va->learn;
      l.calibrate = false;
      const Heightfield ex = block_mean(west, f / 4);
      const Dictionary d = learn_dictionary({ex}, l);
      const MatrixF q = extract_patches(block_mean(truth, f), d.low_patch(), 1);
      for (int checks : va->recall_checks) {
        const RecallReport r =
            measure_recall(d.low, q, o.trees, checks, va->recall_samples, o.seed, &d.low_norm,
                           o.magnitude_weight >= 0 ? o.magnitude_weight : d.magnitude_weight);
        fmt::print("# {} x{}: FLANN {} trees, checks {:4}: recall {:5.1f} % over {} queries, {:.3f} ms/query "
                   "(exact scan of {} atoms: {:.3f} ms/query)\n", name, f, o.trees, checks, 100 * r.recall, r.samples,
                   r.ms_per_query_flann, d.atoms(), r.ms_per_query_exact);
      }
    }
  });
});

}  // namespace
}  // namespace terracl::cli
