// SPDX-License-Identifier: Apache-2.0
// Multi-resolution dictionaries (H, L): learning from exemplars and the .tdic file format
// (docs/amplify.md). L is the block mean of each H atom, masked to the low-resolution disc; both are
// divided by |L| so that a coefficient found on L carries over to H unchanged.
#include <terracl/amplify.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>

#include <fmt/format.h>

#include "io/checked_output.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <numeric>
#include <optional>
#include <random>

namespace terracl {

namespace {

constexpr char kMagic[4] = {'T', 'D', 'I', 'C'};
// Version 2 added the atoms' low-resolution norms (flag bit 1), version 3 faithful mode's regression
// (flag bit 3), version 4 the gain calibration amplify needs for the per-input HF gain (flag bit 5);
// version 1 to 3 files still load (without it: the per-input HF gain is off); version 5 flag bit 6,
// the gain calibrated for the anisotropic detail correlation (versions 1 to 4: for one rho).
constexpr uint32_t kVersion = 5;
constexpr int32_t kFlagConstrained = 1, kFlagNorms = 2, kFlagDetailBlend = 4, kFlagRegression = 8,
                  kFlagBandlimitedBase = 16, kFlagCalibration = 32, kFlagAnisotropy = 64;
constexpr size_t kCalibrationBytes = 4 * 8;

// The four values of GainCalibration that Dictionary keeps (all > 0, or the dictionary has none).
bool has_calibration(const Dictionary& d) {
  return d.hf_gain > 0 && d.rmse_gain > 0 && d.hf_target > 0 && d.spectral_scale > 0;
}

uint64_t fnv1a(const std::string& bytes) {
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : bytes) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

// Little-endian writers/readers (the format is little-endian on every host).
template <typename T>
void put(std::string& out, T v) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if constexpr (sizeof(T) > 1) {
    const uint16_t probe = 1;
    if (*reinterpret_cast<const unsigned char*>(&probe) == 0) std::reverse(b, b + sizeof(T));
  }
  out.append(reinterpret_cast<const char*>(b), sizeof(T));
}

struct Reader {
  const std::string& data;
  const std::string& path;
  size_t pos = 0;
  template <typename T>
  T get(const char* what) {
    if (pos + sizeof(T) > data.size())
      fail("dictionary", "{}: truncated file (reading {} at byte {} of {})", path, what, pos, data.size());
    unsigned char b[sizeof(T)];
    std::memcpy(b, data.data() + pos, sizeof(T));
    if constexpr (sizeof(T) > 1) {
      const uint16_t probe = 1;
      if (*reinterpret_cast<const unsigned char*>(&probe) == 0) std::reverse(b, b + sizeof(T));
    }
    pos += sizeof(T);
    T v;
    std::memcpy(&v, b, sizeof(T));
    return v;
  }
};

// Block mean by f of a P x P column-major-free (row-major) patch vector, masked to the low disc.
VectorF downsample_atom(const VectorF& h, int P, int f, const std::vector<float>& low_mask) {
  const int p = P / f;
  VectorF l(p * p);
  for (int y = 0; y < p; ++y)
    for (int x = 0; x < p; ++x) {
      double s = 0;
      for (int v = 0; v < f; ++v)
        for (int u = 0; u < f; ++u) s += h[(y * f + v) * P + x * f + u];
      l[y * p + x] = float(low_mask[y * p + x] * s / (f * f));
    }
  return l;
}

}  // namespace

void save_dictionary(const Dictionary& d, const std::string& path) {
  std::string out;
  out.append(kMagic, 4);
  put<uint32_t>(out, kVersion);
  put<int32_t>(out, d.patch);
  put<int32_t>(out, d.factor);
  put<int32_t>(out, d.atoms());
  put<int32_t>(out, d.sparsity);
  const bool norms = !d.low_norm.empty();
  if (norms && d.low_norm.size() != size_t(d.atoms()))
    fail("dictionary", "{} atom norms for {} atoms", d.low_norm.size(), d.atoms());
  const bool reg = d.has_regression();
  if (reg) {
    const BlockRegression& g = d.regression;
    const auto rows = Eigen::Index(d.factor) * d.factor, cols = Eigen::Index(g.features_count());
    if (g.factor != d.factor || g.weights.size() != size_t(g.classes) ||
        std::any_of(g.weights.begin(), g.weights.end(), [&](const MatrixF& w) { return w.rows() != rows || w.cols() != cols; }))
      fail("dictionary", "the faithful regression (factor {}, {} classes) does not fit the dictionary (factor {})", g.factor,
           g.classes, d.factor);
  }
  put<int32_t>(out, (d.constrained ? kFlagConstrained : 0) | (norms ? kFlagNorms : 0) |
                         (d.blend == "detail" ? kFlagDetailBlend : 0) | (reg ? kFlagRegression : 0) |
                         (d.base == "bandlimited" ? kFlagBandlimitedBase : 0) |
                         (has_calibration(d) ? kFlagCalibration : 0) | (d.anisotropy ? kFlagAnisotropy : 0));
  put<double>(out, d.cell_x);
  put<double>(out, d.cell_y);
  put<float>(out, d.detail_gain);
  put<int32_t>(out, d.neighbours);
  put<float>(out, d.magnitude_weight);
  put<uint32_t>(out, uint32_t(d.description.size()));
  out += d.description;
  for (Eigen::Index i = 0; i < d.high.size(); ++i) put<float>(out, d.high.data()[i]);
  for (Eigen::Index i = 0; i < d.low.size(); ++i) put<float>(out, d.low.data()[i]);
  for (float v : d.low_norm) put<float>(out, v);
  if (has_calibration(d))  // float64: a loaded dictionary amplifies bit for bit as the one learned in memory
    for (double v : {d.hf_gain, d.rmse_gain, d.hf_target, d.spectral_scale}) put<double>(out, v);
  if (reg) {
    put<int32_t>(out, d.regression.radius);
    put<int32_t>(out, d.regression.classes);
    put<int64_t>(out, int64_t(d.regression.samples));
    for (const MatrixF& w : d.regression.weights)  // f^2 x n, row-major
      for (Eigen::Index i = 0; i < w.rows(); ++i)
        for (Eigen::Index j = 0; j < w.cols(); ++j) put<float>(out, w(i, j));
  }
  put<uint64_t>(out, fnv1a(out));
  write_atomically(path, [&](const std::string& tmp) { io::write_file_checked(tmp, out); });
}

Dictionary load_dictionary(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) fail("dictionary", "cannot open {}", path);
  const std::string data((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  if (data.size() < 4 || std::memcmp(data.data(), kMagic, 4) != 0)
    fail("dictionary", "{}: not a terracl dictionary (no TDIC signature)", path);
  Reader r{data, path, 4};
  const uint32_t version = r.get<uint32_t>("version");
  if (version < 1 || version > kVersion)
    fail("dictionary", "{}: format version {} is not supported (expected 1 to {})", path, version, kVersion);
  Dictionary d;
  d.patch = r.get<int32_t>("patch size");
  d.factor = r.get<int32_t>("factor");
  const int32_t atoms = r.get<int32_t>("atom count");
  d.sparsity = r.get<int32_t>("sparsity");
  const int32_t flags = r.get<int32_t>("flags");
  d.constrained = (flags & kFlagConstrained) != 0;
  d.blend = (flags & kFlagDetailBlend) != 0 ? "detail" : "average";
  const bool norms = version >= 2 && (flags & kFlagNorms) != 0;
  const bool reg = version >= 3 && (flags & kFlagRegression) != 0;
  const bool cal = version >= 4 && (flags & kFlagCalibration) != 0;
  d.base = version >= 3 && (flags & kFlagBandlimitedBase) != 0 ? "bandlimited" : "bicubic";
  d.anisotropy = version >= 5 && (flags & kFlagAnisotropy) != 0;
  d.cell_x = r.get<double>("cell_x");
  d.cell_y = r.get<double>("cell_y");
  d.detail_gain = r.get<float>("detail gain");
  d.neighbours = 1, d.magnitude_weight = 0;  // version 1 gains were calibrated for the nearest atom alone
  if (version >= 2) {
    d.neighbours = r.get<int32_t>("neighbours");
    d.magnitude_weight = r.get<float>("magnitude weight");
    if (d.neighbours < 1 || d.neighbours > 64 || !(d.magnitude_weight >= 0 && d.magnitude_weight < 1e6))
      fail("dictionary", "{}: corrupt header (neighbours {}, magnitude weight {})", path, d.neighbours, d.magnitude_weight);
  }
  if (d.patch < 2 || d.patch > 256 || d.factor < 1 || d.factor > 16 || d.patch % d.factor != 0 || atoms < 1 ||
      atoms > 50'000'000 || d.sparsity < 1 || !(d.cell_x >= 0) || !(d.cell_y >= 0) ||
      !(d.detail_gain > 0 && d.detail_gain < 100))
    fail("dictionary", "{}: corrupt header (patch {}, factor {}, atoms {}, sparsity {})", path, d.patch, d.factor, atoms,
         d.sparsity);
  const uint32_t dlen = r.get<uint32_t>("description length");
  if (dlen > data.size() - r.pos) fail("dictionary", "{}: corrupt header (description length {})", path, dlen);
  d.description = data.substr(r.pos, dlen);
  r.pos += dlen;
  const size_t K = size_t(d.patch) * d.patch, k = size_t(d.low_patch()) * d.low_patch();
  const size_t need = (K + k + (norms ? 1 : 0)) * size_t(atoms) * 4 + (cal ? kCalibrationBytes : 0) + 8;
  // The regression's size follows from its own header (read below); here only a lower bound.
  if (reg ? data.size() - r.pos < need + 16 : data.size() - r.pos != need)
    fail("dictionary", "{}: size {} bytes does not match its header ({} atoms of {}x{} need {} more bytes after byte {}); "
         "truncated or corrupt file", path, data.size(), atoms, d.patch, d.patch, need, r.pos);
  const uint64_t stored = [&] {
    Reader t{data, path, data.size() - 8};
    return t.get<uint64_t>("checksum");
  }();
  if (fnv1a(data.substr(0, data.size() - 8)) != stored) fail("dictionary", "{}: checksum mismatch (corrupt file)", path);
  d.high.resize(Eigen::Index(K), atoms);
  d.low.resize(Eigen::Index(k), atoms);
  for (Eigen::Index i = 0; i < d.high.size(); ++i) d.high.data()[i] = r.get<float>("atoms");
  for (Eigen::Index i = 0; i < d.low.size(); ++i) d.low.data()[i] = r.get<float>("atoms");
  if (norms) {
    d.low_norm.resize(size_t(atoms));
    for (auto& v : d.low_norm) {
      v = r.get<float>("atom norms");
      if (!(v >= 0 && std::isfinite(v))) fail("dictionary", "{}: atom norm {} is not a finite norm (corrupt file)", path, v);
    }
  }
  if (!d.high.allFinite() || !d.low.allFinite()) fail("dictionary", "{}: atoms contain NaN or Inf (corrupt file)", path);
  if (cal) {
    d.hf_gain = r.get<double>("calibration");
    d.rmse_gain = r.get<double>("calibration");
    d.hf_target = r.get<double>("calibration");
    d.spectral_scale = r.get<double>("calibration");
    for (double v : {d.hf_gain, d.rmse_gain, d.hf_target, d.spectral_scale})
      if (!(v > 0 && v < 1e6))
        fail("dictionary", "{}: corrupt calibration (HF-matching gain {}, RMSE-budget gain {}, HF target {}, spectral "
             "scale {}; each must be > 0)", path, d.hf_gain, d.rmse_gain, d.hf_target, d.spectral_scale);
  }
  if (reg) {
    BlockRegression& g = d.regression;
    g.factor = d.factor;
    g.radius = r.get<int32_t>("regression radius");
    g.classes = r.get<int32_t>("regression classes");
    const int64_t samples = r.get<int64_t>("regression samples");
    if (g.radius < 1 || g.radius > 4 || g.classes < 1 || g.classes > 64 || samples < 1)
      fail("dictionary", "{}: corrupt faithful regression header (radius {}, classes {}, samples {})", path, g.radius,
           g.classes, samples);
    g.samples = long(samples);
    const size_t rows = size_t(d.factor) * d.factor, cols = size_t(g.features_count());
    const size_t left = rows * cols * size_t(g.classes) * 4 + 8;
    if (data.size() - r.pos != left)
      fail("dictionary", "{}: size {} bytes does not match its header (a faithful regression of {} classes of {}x{} weights "
           "needs {} more bytes after byte {}); truncated or corrupt file", path, data.size(), g.classes, rows, cols, left,
           r.pos);
    g.weights.assign(size_t(g.classes), MatrixF(Eigen::Index(rows), Eigen::Index(cols)));
    for (MatrixF& w : g.weights) {
      for (Eigen::Index i = 0; i < w.rows(); ++i)
        for (Eigen::Index j = 0; j < w.cols(); ++j) w(i, j) = r.get<float>("regression weights");
      if (!w.allFinite()) fail("dictionary", "{}: faithful regression weights contain NaN or Inf (corrupt file)", path);
    }
  }
  return d;
}

Dictionary learn_dictionary(const std::vector<Heightfield>& exemplars, const LearnOptions& o, const Progress& progress) {
  const int P = o.patch, f = o.factor;
  if (exemplars.empty()) fail("dictionary", "no exemplar given");
  if (f < 1 || P < 4 || P % f != 0 || P / f < 2)
    fail("dictionary", "patch size {} must be a multiple of the factor {} with at least 2 low-resolution cells", P, f);
  if (o.stride < 1) fail("dictionary", "stride must be >= 1");
  const auto& g0 = exemplars[0].georef;
  for (size_t e = 0; e < exemplars.size(); ++e) {
    const auto& h = exemplars[e];
    if (h.width < P || h.height < P)
      fail("dictionary", "exemplar {} ({}x{} cells) is smaller than one {}x{} patch", e + 1, h.width, h.height, P, P);
    require_finite(h, "dictionary", fmt::format("exemplar {}", e + 1));
    const auto& g = h.georef;
    if (std::fabs(g.cell_x / g0.cell_x - 1) > 0.05 || std::fabs(g.cell_y / g0.cell_y - 1) > 0.05)
      fail("dictionary", "mismatched cell sizes: exemplar {} has {:.3f} x {:.3f} m cells, exemplar 1 has {:.3f} x {:.3f} m",
           e + 1, g.cell_x, g.cell_y, g0.cell_x, g0.cell_y);
  }
  // The detail gain's calibration learns and applies dictionaries of its own on the exemplar's
  // folds: first, so that they and this dictionary's atoms are not in memory together.
  std::optional<GainCalibration> calibration;
  if (o.calibrate && f > 1) {
    report_progress(progress, "dictionary", 0.0, "calibrating the detail gain");
    LearnOptions c = o;
    c.calibrate = false;
    c.faithful_radius = 0;  // the folds' dictionaries serve detail mode only
    c.max_patches = o.max_patches / 2;
    calibration = calibrate_detail(exemplars[0], c);
  }
  const int p = P / f;
  const auto low_mask = patch_mask(p);
  double lmsum = 0;
  for (float m : low_mask) lmsum += m;

  // Training patches: full P x P squares minus the mean over the low-resolution disc, so that the
  // block mean of an H vector is exactly its L vector on the disc.
  std::vector<std::pair<int, std::pair<int, int>>> where;
  for (size_t e = 0; e < exemplars.size(); ++e)
    for (int y = 0; y + P <= exemplars[e].height; y += o.stride)
      for (int x = 0; x + P <= exemplars[e].width; x += o.stride) where.push_back({int(e), {x, y}});
  std::mt19937 rng(o.seed);
  if (o.max_patches > 0 && where.size() > size_t(o.max_patches)) {
    std::shuffle(where.begin(), where.end(), rng);
    where.resize(size_t(o.max_patches));
  }
  MatrixF F(P * P, Eigen::Index(where.size()));
  std::vector<char> keep(where.size(), 0);
  parallel_for(where.size(), o.threads, [&](size_t b, size_t e) {
    VectorF v(P * P);
    for (size_t i = b; i < e; ++i) {
      const auto& h = exemplars[where[i].first];
      const auto [x0, y0] = where[i].second;
      for (int y = 0; y < P; ++y)
        for (int x = 0; x < P; ++x) v[y * P + x] = h.at(x0 + x, y0 + y);
      const VectorF l = downsample_atom(v, P, f, low_mask);
      const float z = float(l.sum() / lmsum);
      v.array() -= z;
      F.col(Eigen::Index(i)) = v;
      keep[i] = (l.array() - z * Eigen::Map<const VectorF>(low_mask.data(), p * p).array()).matrix().norm() > 1e-4f;
    }
  });
  // Flat patches carry no shape to match; drop them (in place: a complete dictionary of a 1000^2
  // exemplar holds 60,000 patches, 61 MB per copy).
  Eigen::Index kept = 0;
  for (size_t i = 0; i < keep.size(); ++i)
    if (keep[i]) {
      if (kept != Eigen::Index(i)) F.col(kept) = F.col(Eigen::Index(i));
      ++kept;
    }
  if (kept == 0) fail("dictionary", "the exemplars are flat: no patch has relief to learn from");
  F.conservativeResize(Eigen::NoChange, kept);
  MatrixF T = std::move(F);

  MatrixF H;
  std::vector<float> norms;
  const Eigen::Index training = T.cols();
  if (o.method == "complete") {
    norms.resize(size_t(T.cols()));
    for (Eigen::Index j = 0; j < T.cols(); ++j) norms[size_t(j)] = downsample_atom(T.col(j), P, f, low_mask).norm();
    H = std::move(T);  // the training patches are the atoms
    for (Eigen::Index j = 0; j < H.cols(); ++j) H.col(j).normalize();
  } else if (o.method == "ksvd" || o.method == "constrained") {
    KsvdOptions k;
    k.atoms = o.atoms;
    k.sparsity = o.sparsity;
    k.iterations = o.iterations;
    k.constrained = o.method == "constrained";
    k.seed = o.seed;
    k.threads = o.threads;
    const KsvdResult r = learn_ksvd(T, k, scaled_progress(progress, 0.0, 0.95));
    H = r.D;
    // Constrained atoms are training patches: keep the relief they were cut from.
    if (k.constrained && r.source.size() == size_t(H.cols()) &&
        std::all_of(r.source.begin(), r.source.end(), [](int i) { return i >= 0; }))
      for (int src : r.source) norms.push_back(downsample_atom(T.col(src), P, f, low_mask).norm());
  } else {
    fail("dictionary", "unknown learning method '{}' (constrained, ksvd or complete)", o.method);
  }

  Dictionary d;
  d.patch = P;
  d.factor = f;
  d.sparsity = o.sparsity;
  d.constrained = o.method != "ksvd";
  d.cell_x = g0.cell_x;
  d.cell_y = g0.cell_y;
  d.description = fmt::format("{} dictionary, {} training patches", o.method, training);
  d.neighbours = o.calibration_neighbours;
  d.magnitude_weight = o.calibration_magnitude_weight;
  d.blend = o.calibration_blend;
  d.base = o.calibration_base;
  d.anisotropy = o.calibration_anisotropy;
  std::vector<Eigen::Index> good;
  MatrixF L(p * p, H.cols());
  for (Eigen::Index j = 0; j < H.cols(); ++j) {
    L.col(j) = downsample_atom(H.col(j), P, f, low_mask);
    const float n = L.col(j).norm();
    if (n > 1e-6f) {
      L.col(j) /= n;
      H.col(j) /= n;
      good.push_back(j);
      if (!norms.empty()) d.low_norm.push_back(norms[size_t(j)]);
    }
  }
  // The good atoms, compacted in place (good[i] >= i).
  for (size_t i = 0; i < good.size(); ++i)
    if (good[i] != Eigen::Index(i)) {
      H.col(Eigen::Index(i)) = H.col(good[i]);
      L.col(Eigen::Index(i)) = L.col(good[i]);
    }
  H.conservativeResize(Eigen::NoChange, Eigen::Index(good.size()));
  L.conservativeResize(Eigen::NoChange, Eigen::Index(good.size()));
  d.high = std::move(H);
  d.low = std::move(L);
  T.resize(0, 0);  // the regression and the calibration below learn from the exemplars
  if (o.faithful_radius > 0 && f > 1) {
    // Faithful mode's regression from the same exemplars at the same scale (cheap: normal equations).
    const long n = regression_samples(exemplars, f, o.faithful_radius);
    const long need = 4L * ((2 * o.faithful_radius + 1) * (2 * o.faithful_radius + 1) - 1);
    if (n >= need) {
      d.regression = learn_block_regression(exemplars, f, o.faithful_radius);
      d.description += fmt::format("; faithful regression radius {} from {} blocks", d.regression.radius, d.regression.samples);
    } else {
      d.description += fmt::format("; no faithful regression ({} complete neighbourhoods, {} needed)", n, need);
    }
  }
  if (calibration) {
    d.detail_gain = float(calibration->gain);
    if (calibration->calibrated) {
      d.hf_gain = calibration->hf_gain, d.rmse_gain = calibration->rmse_gain, d.hf_target = o.calibration_hf_target;
      d.spectral_scale = calibration->spectral_scale;
    }
    d.description += "; calibrated " + calibration->summary();
  }
  report_progress(progress, "dictionary", 1.0, fmt::format("{} atoms", d.atoms()));
  return d;
}

}  // namespace terracl
