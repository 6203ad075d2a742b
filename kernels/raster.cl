// SPDX-License-Identifier: Apache-2.0
// Elementary raster operations shared by launchers and used by the device-layer tests.
// OpenCL C 1.2; no fast-math; FMA contraction off so results match a plain C++ loop bit for bit.
#pragma OPENCL FP_CONTRACT OFF

// dst[offset + i] = value for i < n; 64-bit offsets and counts (buffers may pass 2^31 floats).
__kernel void fill_value(__global float* dst, const float value, const ulong offset, const ulong n) {
  const size_t i = get_global_id(0);
  if (i < n) dst[offset + i] = value;
}

// dst = a * x + y
__kernel void axpy(__global float* dst, const float a, __global const float* x, __global const float* y, const int n) {
  const int i = get_global_id(0);
  if (i < n) dst[i] = a * x[i] + y[i];
}
