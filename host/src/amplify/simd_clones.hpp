// SPDX-License-Identifier: Apache-2.0
// Hot loops of amplification get an AVX2 copy, chosen at load time where the CPU has it. Not FMA:
// each product and sum then rounds exactly as in the baseline SSE2 copy, so an output does not
// depend on the machine that made it.
#pragma once

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && defined(__linux__)
#define TERRACL_SIMD_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define TERRACL_SIMD_CLONES
#endif
