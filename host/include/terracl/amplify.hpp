// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Sparse-dictionary terrain amplification (Guérin et al. 2016, "Sparse representation of terrains
/// for procedural modeling", sections 4-5) with the block-mean bias correction of the gradient
/// paper (section 5.3).
///
/// Vocabulary: a *patch* is a P x P window of a heightfield; its *support* is the inscribed disc
/// and its blending weight g(r) = (1 - r^2)^3 (r = distance to the centre / radius). The patch
/// vector has its mean over the disc removed. A dictionary D (K x N) holds N atoms as columns.
/// A multi-resolution dictionary holds H (high resolution, P x P) and L (the block mean of each H
/// atom, P/f x P/f, masked to its disc and L2-normalised); H is scaled by the same factor so that a
/// coefficient found on L carries over to H.
#include <terracl/heightfield.hpp>
#include <terracl/progress.hpp>

#include <Eigen/Dense>

#include <complex>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace terracl {

/// Column-major float matrices of patches and atoms: one signal (a flattened patch) per column.
using MatrixF = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic>;
using VectorF = Eigen::Matrix<float, Eigen::Dynamic, 1>;

// ---------------------------------------------------------------- patches (patches.cpp)

/// Disc weight g(r) = (1 - r^2)^3 for r < 1, else 0 (C1 at r = 1).
double disc_weight(double r);
/// P x P weights g(|p - c| / (P/2)) with the centre c at ((P-1)/2, (P-1)/2), row-major.
std::vector<float> patch_weights(int size);
/// 1 inside the disc support (weight > 0), 0 outside, row-major P x P.
std::vector<float> patch_mask(int size);

/// Patches of `h` (size x size windows at top-left positions (x, y) = k * stride, clamped so the
/// last one touches the border) as columns of a size^2 x n matrix, each with its disc mean
/// removed and masked to the disc. `means` receives the removed means.
MatrixF extract_patches(const Heightfield& h, int size, int stride, std::vector<float>* means = nullptr,
                        std::vector<std::pair<int, int>>* positions = nullptr);

/// Weighted blend of patches (section 4.1): f = sum g_i (z_i + patch_i) / sum g_i over the
/// positions given by `positions` (top-left corners). Cells no patch covers are NaN.
Heightfield blend_patches(int width, int height, int size, const MatrixF& patches, const std::vector<float>& means,
                          const std::vector<std::pair<int, int>>& positions);

// ---------------------------------------------------------------- OMP (omp.cpp)

/// Sparse codes of n signals with at most `sparsity` atoms each: entry j of signal i is
/// (index[i*s + j], coef[i*s + j]); unused entries have index -1 and coefficient 0.
struct SparseCodes {
  int sparsity = 0;
  std::vector<int32_t> index;
  std::vector<float> coef;
  size_t count() const { return sparsity ? index.size() / size_t(sparsity) : 0; }
};

/// Batch-OMP (Rubinstein et al. 2008): Gram matrix G = D^T D precomputed, the active set grown by
/// Cholesky updates. Columns of D must have unit L2 norm. Parallel over signals (`threads` 0 =
/// hardware concurrency). Stops early for a signal when its residual vanishes.
SparseCodes batch_omp(const MatrixF& D, const MatrixF& X, int sparsity, int threads = 0);

/// D * codes (K x n), the reconstruction of the coded signals.
MatrixF decode(const MatrixF& D, const SparseCodes& codes);

// ---------------------------------------------------------------- K-SVD (ksvd.cpp)

/// K-SVD settings: dictionary size, sparsity of the codes, iterations, seed and threads.
struct KsvdOptions {
  int atoms = 256;
  int sparsity = 2;
  int iterations = 10;
  /// Problem 2 of the paper: every atom is a (normalised) training signal.
  bool constrained = false;
  unsigned seed = 1;
  int threads = 0;
};
/// A learned dictionary and its training error per iteration.
struct KsvdResult {
  MatrixF D;                 ///< K x N, unit-norm columns
  std::vector<int> source;   ///< constrained: training column of each atom; else -1
  std::vector<double> rmse;  ///< RMS representation error after each iteration's atom update
};
/// K-SVD (Aharon et al. 2006) on the columns of F (zero-mean signals), or its constrained variant
/// where the replacement atom is searched among the training signals.
KsvdResult learn_ksvd(const MatrixF& F, const KsvdOptions& o, const Progress& progress = {});

// ---------------------------------------------------------------- dictionaries (dictionary.cpp)

/// Linear regression of an f x f output block (minus its input cell) from the input's (2r+1)^2
/// neighbourhood (minus the cell), one per class of gradient direction: the least-squares linear
/// upsampler of the exemplar's terrain. The block means of its output equal the input exactly (the
/// training targets sum to zero per block, so do the weights).
struct BlockRegression {
  int factor = 4, radius = 2, classes = 1;
  long samples = 0;                   ///< training blocks
  std::vector<MatrixF> weights;       ///< per class: f^2 x features_count()
  int features_count() const;
};

/// Coupled high/low-resolution patch dictionary (a .tdic file): atom i of `low` is matched
/// against the input, atom i of `high` supplies the detail.
struct Dictionary {
  int patch = 16;        ///< P: high-resolution patch size (cells)
  int factor = 4;        ///< f: resolution ratio between H and L (1: single resolution)
  int sparsity = 1;      ///< sparsity the dictionary was learned for
  bool constrained = false;
  double cell_x = 0, cell_y = 0;  ///< cell size (m) of the exemplar H was taken from
  MatrixF high;          ///< P^2 x N
  MatrixF low;           ///< (P/f)^2 x N, unit-norm columns, masked to the low-resolution disc
  /// Gain applied to the synthesized detail (output minus bicubic of the input), calibrated on the
  /// exemplar: blending overlapping patches averages uncorrelated detail away.
  float detail_gain = 1.0f;
  /// The atom search the gain was calibrated for, and the default of amplifications with this
  /// dictionary (AmplifyOptions::neighbours, magnitude_weight). Version 1 files: 1 and 0.
  int neighbours = 3;
  float magnitude_weight = 0.4f;
  /// The blend the gain was calibrated for (AmplifyOptions::blend): "detail", or "average" for files
  /// without flag bit 2 (written before the detail blend existed).
  std::string blend = "detail";
  /// The base the gain was calibrated for (AmplifyOptions::base): "bicubic", or "bandlimited" (flag
  /// bit 4, format version 3).
  std::string base = "bicubic";
  /// Whether the gain was calibrated with the anisotropic detail correlation
  /// (AmplifyOptions::detail_anisotropy; flag bit 6, format version 5). Files of versions 1-4 were
  /// calibrated with one rho: false, and amplify keeps one rho with them.
  bool anisotropy = true;
  /// Norm (m) of each atom's low-resolution patch before normalisation (the relief it was cut
  /// from), used by the magnitude term of the search; empty when unknown (K-SVD atoms).
  std::vector<float> low_norm;
  /// Faithful mode's regression (learned on the same exemplar at the same cell size and factor;
  /// `amplify --mode faithful --dictionary` uses it at every step); empty weights when absent
  /// (version 1 and 2 files, or an exemplar too small). Stored from version 3 on.
  BlockRegression regression;
  std::string description;
  /// The calibration's HF-matching and RMSE-budget gains, its HF target and spectral scale
  /// (GainCalibration), which let `amplify` recalibrate the gain on each input's own spectrum
  /// (docs/amplify.md, "per-input HF"). Stored from .tdic version 4 on (flag bit 5); -1 when unknown
  /// (files of versions 1-3, exemplars too small to calibrate): the per-input gain is then off.
  double hf_gain = -1, rmse_gain = -1, hf_target = -1, spectral_scale = -1;
  bool has_regression() const { return !regression.weights.empty(); }
  int atoms() const { return int(high.cols()); }
  int low_patch() const { return patch / factor; }
};

/// Writes the documented .tdic format (docs/amplify.md) atomically.
void save_dictionary(const Dictionary& d, const std::string& path);
/// Reads a .tdic file; throws a clear error naming the file for a truncated, corrupt (checksum)
/// or inconsistent file.
Dictionary load_dictionary(const std::string& path);

/// How a dictionary is learned from an exemplar (`terracl dictionary learn`).
struct LearnOptions {
  int patch = 16;
  int factor = 4;
  int atoms = 1024;
  int sparsity = 1;
  int iterations = 6;
  /// "constrained" (atoms are real exemplar patches; the default), "ksvd", or "complete"
  /// (every training patch is an atom).
  std::string method = "constrained";
  int stride = 2;             ///< spacing of training patches in exemplar cells
  int max_patches = 60000;    ///< random subset of training patches (0 = all)
  unsigned seed = 1;
  int threads = 0;
  /// Calibrate the detail gain by a split-exemplar test (learn on one half, amplify the other's
  /// block means, compare roughness) at this output patch spacing.
  bool calibrate = true;
  int calibration_spacing = 8;
  /// Search settings the detail gain is calibrated for (AmplifyOptions::neighbours, candidates,
  /// magnitude_weight).
  int calibration_neighbours = 3;
  int calibration_candidates = 0;
  float calibration_magnitude_weight = 0.4f;
  std::string calibration_blend = "detail";
  /// AmplifyOptions::base the gain is calibrated for (and amplify's default with this dictionary).
  std::string calibration_base = "bandlimited";
  /// AmplifyOptions::detail_anisotropy of the amplification the gain is calibrated for (and what
  /// amplify uses with this dictionary; Dictionary::anisotropy).
  bool calibration_anisotropy = true;
  /// HF energy ratio the gain aims at on the held-out folds. Slightly above 1: the exemplar's own
  /// folds resemble each other more than the input's terrain (x4 on the bundled DEMs: the ratio
  /// against the truth is 1.16 / 0.67 of the held-out one; docs/amplify.md).
  double calibration_hf_target = 1.1;
  /// Folds of the calibration's cross-validation (strips across the exemplar's longer axis).
  int calibration_folds = 2;
  /// Faithful mode: neighbourhood radius of the BlockRegression learned and stored with the
  /// dictionary (0: none). Skipped when the exemplar holds too few complete neighbourhoods.
  int faithful_radius = 3;
};
/// Builds a multi-resolution dictionary (H, L) from exemplars at the high resolution.
/// Throws when an exemplar is smaller than a patch or P is not a multiple of f.
Dictionary learn_dictionary(const std::vector<Heightfield>& exemplars, const LearnOptions& o,
                            const Progress& progress = {});

// ---------------------------------------------------------------- atom search (flann_search.cpp)

/// Best atoms (s = 1) for zero-mean queries over unit-norm atoms: the nearest neighbours of q/|q|
/// among {+d, -d}; coefficient <q, d>. Entries [i k, i k + k) belong to query i, best first
/// (index -1 where fewer were found).
struct AtomMatch {
  std::vector<int32_t> index;
  std::vector<float> coef;
};

/// The magnitude feature of a low-resolution patch norm n (m): log(n + 0.1). With a weight w > 0 and
/// the atoms' norms (Dictionary::low_norm), the search minimises |q/|q| -+ d|^2 + w^2 (feature(s |q|) -
/// feature(n_d))^2, preferring atoms cut from exemplar patches of the query's relief; s rescales the
/// query to the dictionary's cell size.
float magnitude_feature(float norm);

/// Exact scan (one GEMM per block of queries), k best atoms.
AtomMatch exact_atom_search(const MatrixF& D, const MatrixF& Q, int threads = 0, int k = 1,
                            const std::vector<float>* atom_norm = nullptr, float weight = 0, float query_scale = 1);

/// FLANN randomized kd-tree forest over {+d, -d} (plus the weighted magnitude feature when `atom_norm`
/// is given and `weight` > 0). `checks` < 0 means unlimited (exact). The trees' randomisation is
/// seeded by `seed`: the same seed gives the same index and results in every run.
class AtomIndex {
 public:
  AtomIndex(const MatrixF& D, int trees = 4, int checks = 512, unsigned seed = 1,
            const std::vector<float>* atom_norm = nullptr, float weight = 0);
  ~AtomIndex();
  AtomIndex(const AtomIndex&) = delete;
  AtomIndex& operator=(const AtomIndex&) = delete;
  /// The k nearest atoms of each query (see AtomMatch).
  AtomMatch search(const MatrixF& Q, int threads = 0, int k = 1, float query_scale = 1) const;
  int trees() const { return m_trees; }
  int checks() const { return m_checks; }

 private:
  struct Impl;
  Impl* m_impl;
  const MatrixF& m_atoms;
  int m_trees, m_checks;
  float m_weight = 0;
};

/// Quality and speed of the approximate (FLANN) atom search against the exact scan.
struct RecallReport {
  int samples = 0;
  double recall = 0;            ///< fraction of queries where FLANN picks the exact best atom
  double ms_per_query_flann = 0, ms_per_query_exact = 0;
};
/// Compares FLANN with the exact scan on `samples` columns of Q (chosen evenly).
RecallReport measure_recall(const MatrixF& D, const MatrixF& Q, int trees, int checks, int samples = 2000,
                            unsigned seed = 1, const std::vector<float>* atom_norm = nullptr, float weight = 0);

// ---------------------------------------------------------------- amplification (amplify.cpp)

/// Settings of amplify() (`terracl amplify`); 0 / negative values mean "the dictionary's".
struct AmplifyOptions {
  int factor = 4;          ///< total factor: 4, 16, 64, 256 (x4 steps)
  int spacing = 8;         ///< spacing of output patches (high-resolution cells, multiple of 4)
  int sparsity = 1;
  std::string search = "auto";  ///< auto | flann | exact | omp (auto: flann for s=1 and > 4096 atoms)
  int trees = 2;
  int checks = 8;
  /// Sparsity 1: the k best atoms are averaged (their coefficients divided by k); 0 = the
  /// dictionary's (the setting its detail gain was calibrated for).
  int neighbours = 0;
  /// Pool of nearest atoms from which each patch draws its `neighbours` (seeded by the patch's
  /// position; <= neighbours: the nearest ones). Varies the detail of identical footprints.
  int candidates = 0;
  /// Weight of the magnitude term of the atom search (see magnitude_feature; 0 = off; < 0 = the
  /// dictionary's).
  float magnitude_weight = -1;
  unsigned seed = 1;       ///< seed of FLANN's randomized kd-trees (the output is reproducible per seed)
  int tile = 1024;         ///< output tile size (cells); memory stays bounded by the tiles
  bool bias_correction = true;
  float detail_gain = -1;  ///< < 0: the dictionary's calibrated gain
  /// With the dictionary's gain (detail_gain < 0), the detail blend and the bias correction: recalibrate
  /// the gain on each step's input spectrum when the dictionary was calibrated in this process
  /// (Dictionary::spectral_scale; `amplify --exemplar`, `dictionary evaluate`). docs/amplify.md.
  bool hf_from_input = true;
  /// amplify_from_exemplars at x16 (two x4 steps), the dictionary's gain: the first step's gain chosen
  /// end to end on the exemplar's held-out folds (both steps simulated; docs/amplify.md, "per-scale calibration").
  bool cascade_calibration = true;
  /// Patch blend. "detail": the bicubic of the input plus the patches' details (patch minus the smooth part of
  /// its block means, smooth_part_operator) blended by sum w d / sqrt(sum w^2), variance-preserving,
  /// so the patch grid leaves no trace; "average": the patches themselves blended by sum w p / sum w
  /// (the paper's blend; detail fades between patch centres).
  std::string blend = "auto";  ///< detail | average | auto (the dictionary's, see Dictionary::blend)
  /// Detail blend: the correlation rho between overlapping patches' details that the blend's
  /// normalisation sqrt((1 - rho) sum w^2 + rho (sum w)^2) assumes (0: independent, 1: the average);
  /// < 0: measured on the output's own patches (a first pass over the tiles).
  float detail_correlation = -1.f;
  /// Detail blend with a measured rho: also measure the anisotropy delta (x-neighbour overlaps
  /// correlated by rho + delta, y-neighbour ones by rho - delta), which removes the ripple with the
  /// patch spacing one rho leaves on anisotropic terrain (docs/amplify.md). Only
  /// with a dictionary whose gain was calibrated so (Dictionary::anisotropy; not .tdic files before
  /// version 5): false, or such a dictionary, gives one rho.
  bool detail_anisotropy = true;
  /// Detail blend, steps after the first of a cascade (x16 and beyond): the step's detail gain is
  /// multiplied by (q_ref / q_med)^b, q_med the median relief of the step's patch footprints (the norm
  /// the magnitude term uses, over the step's measured region, like rho), q_ref the dictionary's median
  /// atom footprint norm (complete and constrained dictionaries only; K-SVD atoms have none). The atom
  /// search ties each patch's detail to its footprint's relief as the exemplar's patches do (detail ~
  /// relief^(1 - b)); across terrains the fine relief follows the relief less, and a later step's
  /// footprints are the previous step's RMSE-capped synthesis (docs/amplify.md).
  /// < 0: b = 1 - that exponent fitted on the dictionary's atoms (detail_relief_exponent); 0: off
  /// (no relief scale); > 0: this b. Applies whatever the gain's source (also an explicit detail_gain).
  float cascade_relief_exponent = -1.f;
  /// Internal (amplify_from_exemplars, the cascade calibration): this call's first step is a later
  /// step of a cascade whose steps run as separate calls.
  bool later_cascade_step = false;
  /// Detail mode's base, the part the input's block means determine (upsample()): "bicubic",
  /// "bandlimited" (no knots: no curvature peak at the input cells' centres) or "auto" (the
  /// dictionary's). The patches' details are taken relative to the same base.
  std::string base = "auto";
  /// "detail": plausible relief transferred from the exemplar (the dictionary); "faithful": the
  /// estimate closest to the truth, a BlockRegression per x4 step learned on the exemplar
  /// (amplify_from_exemplars) or the one a dictionary stores (amplify; Dictionary::regression),
  /// block means exact.
  std::string mode = "detail";
  int faithful_radius = 3;  ///< faithful: neighbourhood radius of the regression (input cells)
  int threads = 0;
};

/// The exponent b of AmplifyOptions::cascade_relief_exponent learned from a dictionary: 1 minus the
/// least-squares slope of log |detail| against log |L| over its atoms (at most 4096, evenly spaced),
/// detail = the atom's source patch minus its smooth part (smooth_part_operator with `base`), |L| the
/// norm of its low-resolution footprint (Dictionary::low_norm); clamped to [0, 1]. -1 without atom
/// norms (K-SVD) or with too few atoms.
double detail_relief_exponent(const Dictionary& d, const std::string& base);

/// One or more x4 steps with the dictionary (the same one at every step). The output is
/// georeferenced at the finer cell size and its f x f block means equal the input (correction).
Heightfield amplify(const Heightfield& low, const Dictionary& dict, const AmplifyOptions& o,
                    const Progress& progress = {});
/// Tiled amplification (docs/scale.md, "Tiled amplify"): reads cells [x, x + w) x [y, y + h) of the
/// whole input (its georef's cell size the whole raster's).
using AmplifyWindowReader = std::function<Heightfield(int x, int y, int w, int h)>;
/// The detail blend's correlation of every step (empty for the average blend and faithful mode),
/// measured on the central 256^2 cells of each step's input (through `read`): a function of the
/// whole `width` x `height` input only, computed once before the tiles.
std::vector<float> amplify_correlations(const AmplifyWindowReader& read, int width, int height, const Dictionary& dict,
                                        const AmplifyOptions& o);
/// Input cells on each side that an output cell of the whole cascade depends on (patch footprints,
/// the base's taps, the bias correction's passes).
int amplify_halo(const Dictionary& dict, const AmplifyOptions& o);
/// Amplifies the window `low` of the whole input, whose first cell is the input's cell (x0, y0),
/// with the whole input's `correlations` (amplify_correlations): every output cell farther than
/// amplify_halo input cells from a window edge that is not the input's edge equals amplify()'s bit
/// for bit. amplify() is this with the window = the whole input.
Heightfield amplify_window(const Heightfield& low, int x0, int y0, const Dictionary& dict, const AmplifyOptions& o,
                           const std::vector<float>& correlations, const Progress& progress = {});
/// Learns a dictionary per step from the exemplars brought to that step's output cell size
/// (block means when the exemplar is finer), then amplifies. Throws on mismatched cell sizes.
Heightfield amplify_from_exemplars(const Heightfield& low, const std::vector<Heightfield>& exemplars,
                                   const LearnOptions& learn, const AmplifyOptions& o, const Progress& progress = {});
/// Detail gain calibrated by pooled cross-validation on the exemplar (strips across its longer axis,
/// `calibration_folds` of them; each amplified, bias-corrected, by a dictionary learned on the others
/// with the calibration_* search settings): the gain whose pooled HF energy (energy_above) is
/// calibration_hf_target times the held-out truth's, unless the pooled RMSE would then exceed 1.14 x bicubic's (then the largest
/// gain within that budget); clamped to [0.25, 4]; 1 when the exemplar is too small to split.
struct GainCalibration {
  bool calibrated = false;  ///< false: the exemplar was too small to split (gain 1)
  double gain = 1;
  double hf_gain = 1, rmse_gain = 0;     ///< the HF-matching gain and the RMSE budget's largest gain
  double hf_ratio = 0, rmse_ratio = 0;   ///< held-out HF energy ratio and RMSE / bicubic's at `gain`
  /// Held-out truth's HF energy over predicted_energy_above of its block means (pooled); -1 unknown.
  double spectral_scale = -1;
  std::string summary() const;
};
GainCalibration calibrate_detail(const Heightfield& exemplar, const LearnOptions& o);
double calibrate_detail_gain(const Heightfield& exemplar, const LearnOptions& o);
/// z minus its (f+1) x (f+1) box mean (relief finer than one input cell), and its RMS.
std::vector<double> highpass(const Heightfield& h, int f);
/// RMS of highpass(h, f) (m): the relief amplification should restore.
double roughness(const Heightfield& h, int f);
/// Spatialised style: amplifies with each dictionary and blends by `mask` (values in [0, 1] at the
/// input resolution, 1 selects dicts[1]), smoothed over `blend_cells` input cells.
Heightfield amplify_styles(const Heightfield& low, const std::vector<const Dictionary*>& dicts, const Heightfield& mask,
                           double blend_cells, const AmplifyOptions& o, const Progress& progress = {});

/// Terrain synthesis from a coarse painted sketch (elevations already in metres): the sketch is
/// smoothed by a tent filter `smooth_cells` wide, then amplified.
Heightfield synthesize_from_sketch(const Heightfield& sketch, const Dictionary& d, double smooth_cells,
                                   const AmplifyOptions& o, const Progress& progress = {});
/// In-place tent filter (two separable box passes of radius r, clamped borders).
void smooth_tent(Heightfield& h, int r);

/// f x f block means (the input is cropped to a multiple of f). Georef resampled by 1/f.
Heightfield block_mean(const Heightfield& h, int f);
/// Bicubic (Catmull-Rom) upsampling by f with cell-centre alignment (the baseline).
Heightfield bicubic_upsample(const Heightfield& h, int f);
/// The n x n matrix M = U B of one axis (B: block means by f, U: the bicubic upsampling above, clamped
/// at the ends): M X M^T is the smooth part of an n x n patch X, the part its block means determine;
/// X - M X M^T is its detail.
/// `base` "bandlimited": the same with upsample()'s band-limited kernel (mirrored at the patch edges).
MatrixF smooth_part_operator(int n, int f, const std::string& base = "bicubic");
/// out += scale * bicubic_upsample(low, f), without a full-size temporary.
void add_bicubic(Heightfield& out, const Heightfield& low, int f, float scale);
/// Upsampling by f with cell-centre alignment: `base` "bicubic" (bicubic_upsample) or "bandlimited"
/// (a consistent band-limited kernel: its block means reproduce the input up to its truncation, and
/// its curvature has no peak at the input cells' centres; 16 taps, mirrored edges).
Heightfield upsample(const Heightfield& h, int f, const std::string& base);
/// out += scale * upsample(low, f, base), without a full-size temporary.
void add_upsampled(Heightfield& out, const Heightfield& low, int f, float scale, const std::string& base);
/// The window [X0, X0 + w) x [Y0, Y0 + h) of upsample(low, f, base), row-major into `out` (w h floats).
void upsample_window(const Heightfield& low, int f, const std::string& base, int X0, int Y0, int w, int h, float* out);
/// Input cells on each side that upsample(low, f, base) reads for one output cell (its taps' reach).
int upsample_reach(int f, const std::string& base);
/// Makes every f x f block mean of `high` equal the corresponding cell of `low`: a few smooth
/// back-projection passes (upsample(residual, f, base)), then an exact constant shift per block.
void correct_block_means(Heightfield& high, const Heightfield& low, int f, int smooth_passes = 4,
                         const std::string& base = "bicubic");

// ---------------------------------------------------------------- faithful mode (regression.cpp)

/// Complete (2 radius + 1)^2 neighbourhoods of the exemplars' f x f block means: the training blocks
/// learn_block_regression would use (it needs 4 features_count() of them).
long regression_samples(const std::vector<Heightfield>& exemplars, int f, int radius);
/// Learns from exemplars at the output cell size (their f x f block means are the inputs). `ridge`
/// is relative to the mean feature energy. Throws when the exemplars hold too few blocks.
BlockRegression learn_block_regression(const std::vector<Heightfield>& exemplars, int f, int radius = 2,
                                       int classes = 1, double ridge = 1e-4);
/// x f with the regression (clamped borders). Georef resampled by f.
Heightfield apply_block_regression(const Heightfield& low, const BlockRegression& g, int threads = 0);

// ---------------------------------------------------------------- evaluation (eval.cpp)

/// Quality of an amplified raster against the true fine raster (`scripts/eval-amplify.sh`).
struct AmplifyMetrics {
  double rmse = 0, psnr = 0;
  double hf_ratio = 0;         ///< spectral energy above the low-resolution Nyquist, output / truth
  double roughness_ratio = 0;  ///< RMS of z - box(f+1) mean, output / truth
  double slope_ratio = 0;      ///< mean slope (deg), output / truth
  double lr_consistency = 0;   ///< RMSE between the output's f x f block means and the input (m)
  double patch_peak = 0;       ///< periodic_trace(out, patch spacing).peak: patch-grid trace (~1: none)
  double block_peak = 0;       ///< periodic_trace(out, f).peak: block-grid trace
  double d8_agreement = 0;     ///< d8_agreement(out, truth, 0.002, f)
};
AmplifyMetrics evaluate_amplification(const Heightfield& out, const Heightfield& truth, const Heightfield& low, int f,
                                      int patch_spacing = 8);

/// The evaluation's HF: the spectrum of h above the input's Nyquist (|fx| or |fy| > 1/(2f) cycles per
/// cell) after removing the least-squares plane and applying a 2-D Hann window (linear in h), and
/// its energy.
std::vector<std::complex<double>> spectrum_above(const Heightfield& h, int f);
double energy_above(const Heightfield& h, int f);
/// The energy_above(., f) a terrain f times finer than `low` (its block means) should have: a power
/// law fitted to low's radially averaged spectrum over the octave below its Nyquist (the f-cell box
/// response undone), extrapolated over the finer grid's bins above that Nyquist. -1 when low is too
/// small (< 16 cells a side) or the fit fails. Real spectra steepen above SRTM's Nyquist, so callers
/// scale it by the ratio measured on the exemplar (GainCalibration::spectral_scale).
double predicted_energy_above(const Heightfield& low, int f);

/// Drainage kept: rivers are the cells whose D8 accumulation (analysis.hpp, d8_flow) reaches
/// `river_fraction` of the grid; the agreement is the mean of the fraction of the truth's river cells
/// within `tolerance` cells (Chebyshev) of an output river cell and the converse (1: same network).
double d8_agreement(const Heightfield& out, const Heightfield& truth, double river_fraction = 0.002, int tolerance = 4);

/// Periodic trace of a patch (or block) grid in a heightfield: the squared curvature (5-point
/// Laplacian) averaged over rows gives a profile along x, averaged over columns one along y.
/// `peak`: the power of a profile's DFT at the grid's frequency (1 / period) over the mean power of
/// the other frequencies within a factor 1.5 of it (about 1 for no trace; the larger of x and y);
/// `ripple`: (max - min) / mean of the profile folded modulo the period (the larger of x and y).
struct PeriodicTrace {
  double peak = 0, ripple = 0;
};
PeriodicTrace periodic_trace(const Heightfield& h, int period);
/// The same over several rasters of one size (e.g. one amplification at several seeds): the profiles'
/// power spectra and folded profiles are averaged before the peak and ripple are read. A ripple the
/// rasters share keeps its peak; the noise around it averages (no trace: a mean of n exponential
/// variables, > 8 with probability ~1e-8 for n = 3 instead of 3e-4 for one).
PeriodicTrace periodic_trace(const std::vector<const Heightfield*>& rasters, int period);

/// Compression report (section 5.1): learn N atoms of P x P patches spaced P/2 on `h`, encode with
/// sparsity s and reconstruct. rho = (K N + n (2 s + 2) + 1) / (w h).
struct EncodeReport {
  int sparsity = 0, atoms = 0, patch = 0, patches = 0;
  double rho = 0, psnr = 0, rmse = 0;
};
/// Learns and encodes `h` as described on EncodeReport (`terracl dictionary encode`).
EncodeReport encode_report(const Heightfield& h, int sparsity, int atoms, int patch, int iterations = 8,
                           const Progress& progress = {});

/// Parallel for over [0, n) in contiguous chunks (threads 0 = hardware concurrency).
void parallel_for(size_t n, int threads, const std::function<void(size_t begin, size_t end)>& body);

/// Parts a per-cell pass over `cells` cells in `rows` rows is split into: one per core, or one
/// below 2^16 cells, where starting a thread costs more than the pass.
size_t row_parts(size_t cells, int rows);
/// body(part, y0, y1) for `parts` consecutive row ranges of `rows` rows, at once.
void for_row_ranges(int rows, size_t parts, const std::function<void(size_t part, int y0, int y1)>& body);

}  // namespace terracl
