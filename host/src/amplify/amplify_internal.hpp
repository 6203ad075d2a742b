// SPDX-License-Identifier: Apache-2.0
#pragma once
// What the amplify sources share and do not export: one step's engine and its calibration, the
// option checks, and the folds of the exemplar calibrations.
#include <terracl/amplify.hpp>

#include <memory>
#include <string>
#include <vector>

namespace terracl::amplify_internal {

/// Steps of `f` that make `factor` (a power of f); throws otherwise.
int steps_for(int factor, int f);
/// Throws a clear error for options the dictionary cannot serve.
void check_options(const AmplifyOptions& o, const Dictionary& d);
/// The dictionary's search settings where the options leave them open (its gain was calibrated for them).
AmplifyOptions resolved(AmplifyOptions o, const Dictionary& d);
/// The FLANN index over the atoms when the search uses one (sparsity 1, many atoms or --search flann).
std::unique_ptr<AtomIndex> make_index(const Dictionary& d, const AmplifyOptions& o);

/// Input cells a step's output cell depends on, on each side.
int step_halo(const Dictionary& d, const AmplifyOptions& o);
/// The output of one x f step over the window `low` whose first cell is the step input's global cell
/// (ox, oy), with the detail blend's correlation rho and anisotropy delta (amplify_step.cpp).
/// `input_gain` > 0: the gain chosen for this input where the options leave it open; `relief`: a later
/// cascade step's relief scale; `raw`: the blended detail only (no gain, base or bias correction).
Heightfield amplify_step(const Heightfield& low, int ox, int oy, int step, float rho, float delta, const Dictionary& d,
                         const AmplifyOptions& o, const AtomIndex* index, const Progress& progress,
                         float input_gain = -1, float relief = 1, bool raw = false);

/// Inputs smaller than this (cells a side) get no per-input HF gain: too few bins for the spectral fit.
constexpr int kMinSpectralInput = 64;
/// Per step: `steps` rhos, then `steps` gains, `steps` deltas and `steps` relief scales, measured on
/// the whole input (amplify_calibration.cpp); empty when the blend is not `detail`.
std::vector<float> step_correlations(const AmplifyWindowReader& read, int width, int height, int steps,
                                     const Dictionary& d, const AmplifyOptions& o, const AtomIndex* index,
                                     bool first_is_input = true);

/// [a0, a1) along the exemplar's long axis (x when wide), [o0, o1) across: the calibration folds.
Heightfield fold_crop(const Heightfield& ex, bool wide, int a0, int a1, int o0, int o1);

}  // namespace terracl::amplify_internal
