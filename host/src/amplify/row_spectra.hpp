// SPDX-License-Identifier: Apache-2.0
// The first half of a 2-D spectrum shared by the evaluation's HF measure (eval.cpp) and the
// input-spectrum prediction (spectral.cpp), so both see the same windowing.
#pragma once

#include <terracl/heightfield.hpp>

#include <complex>
#include <vector>

namespace terracl {

/// `h` with its least-squares plane removed and a 2-D Hann window applied (so that the borders do
/// not leak energy into high frequencies), every row Fourier-transformed: w x h values, row-major.
/// The caller transforms the columns. Linear in h.
std::vector<std::complex<double>> windowed_row_spectra(const Heightfield& h);

}  // namespace terracl
