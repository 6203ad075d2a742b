// OpenCL call counter (LD_PRELOAD shim) for the launch / transfer / allocation proxy of issue 19:
// on a CPU device the figures that cost ~10-20 us each on a GPU (launches, small transfers,
// clFinish, buffer creation) are invisible in wall time, so they are counted instead.
// Build and use: scripts/cl-count.sh CMD ARGS... (prints the counts to stderr at exit).
// Counts every call made through the ICD loader by the process; CL_COUNT_VERBOSE=1 also prints
// every buffer creation.
#define _GNU_SOURCE
#define CL_TARGET_OPENCL_VERSION 120
#include <CL/cl.h>
#include <dlfcn.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static atomic_long n_launch, n_write, n_read, n_copy, n_fill, n_map, n_finish, n_flush, n_wait, n_create, n_sub;
static atomic_long write_bytes, read_bytes, create_bytes, n_blocking;

#define NEXT(name) ((__typeof__(&name))dlsym(RTLD_NEXT, #name))

cl_int clEnqueueNDRangeKernel(cl_command_queue q, cl_kernel k, cl_uint dim, const size_t* off, const size_t* gws,
                              const size_t* lws, cl_uint ne, const cl_event* w, cl_event* e) {
  static __typeof__(&clEnqueueNDRangeKernel) f;
  if (!f) f = NEXT(clEnqueueNDRangeKernel);
  atomic_fetch_add(&n_launch, 1);
  return f(q, k, dim, off, gws, lws, ne, w, e);
}
cl_int clEnqueueWriteBuffer(cl_command_queue q, cl_mem b, cl_bool blk, size_t off, size_t sz, const void* p, cl_uint ne,
                            const cl_event* w, cl_event* e) {
  static __typeof__(&clEnqueueWriteBuffer) f;
  if (!f) f = NEXT(clEnqueueWriteBuffer);
  atomic_fetch_add(&n_write, 1);
  atomic_fetch_add(&write_bytes, (long)sz);
  if (blk) atomic_fetch_add(&n_blocking, 1);
  return f(q, b, blk, off, sz, p, ne, w, e);
}
cl_int clEnqueueReadBuffer(cl_command_queue q, cl_mem b, cl_bool blk, size_t off, size_t sz, void* p, cl_uint ne,
                           const cl_event* w, cl_event* e) {
  static __typeof__(&clEnqueueReadBuffer) f;
  if (!f) f = NEXT(clEnqueueReadBuffer);
  atomic_fetch_add(&n_read, 1);
  atomic_fetch_add(&read_bytes, (long)sz);
  if (blk) atomic_fetch_add(&n_blocking, 1);
  return f(q, b, blk, off, sz, p, ne, w, e);
}
cl_int clEnqueueCopyBuffer(cl_command_queue q, cl_mem s, cl_mem d, size_t so, size_t dof, size_t sz, cl_uint ne,
                           const cl_event* w, cl_event* e) {
  static __typeof__(&clEnqueueCopyBuffer) f;
  if (!f) f = NEXT(clEnqueueCopyBuffer);
  atomic_fetch_add(&n_copy, 1);
  return f(q, s, d, so, dof, sz, ne, w, e);
}
cl_int clEnqueueCopyBufferRect(cl_command_queue q, cl_mem s, cl_mem d, const size_t* so, const size_t* dof,
                               const size_t* r, size_t srp, size_t ssp, size_t drp, size_t dsp, cl_uint ne,
                               const cl_event* w, cl_event* e) {
  static __typeof__(&clEnqueueCopyBufferRect) f;
  if (!f) f = NEXT(clEnqueueCopyBufferRect);
  atomic_fetch_add(&n_copy, 1);
  return f(q, s, d, so, dof, r, srp, ssp, drp, dsp, ne, w, e);
}
cl_int clEnqueueFillBuffer(cl_command_queue q, cl_mem b, const void* p, size_t ps, size_t off, size_t sz, cl_uint ne,
                           const cl_event* w, cl_event* e) {
  static __typeof__(&clEnqueueFillBuffer) f;
  if (!f) f = NEXT(clEnqueueFillBuffer);
  atomic_fetch_add(&n_fill, 1);
  return f(q, b, p, ps, off, sz, ne, w, e);
}
void* clEnqueueMapBuffer(cl_command_queue q, cl_mem b, cl_bool blk, cl_map_flags fl, size_t off, size_t sz, cl_uint ne,
                         const cl_event* w, cl_event* e, cl_int* err) {
  static __typeof__(&clEnqueueMapBuffer) f;
  if (!f) f = NEXT(clEnqueueMapBuffer);
  atomic_fetch_add(&n_map, 1);
  return f(q, b, blk, fl, off, sz, ne, w, e, err);
}
cl_int clFinish(cl_command_queue q) {
  static __typeof__(&clFinish) f;
  if (!f) f = NEXT(clFinish);
  atomic_fetch_add(&n_finish, 1);
  return f(q);
}
cl_int clFlush(cl_command_queue q) {
  static __typeof__(&clFlush) f;
  if (!f) f = NEXT(clFlush);
  atomic_fetch_add(&n_flush, 1);
  return f(q);
}
cl_int clWaitForEvents(cl_uint n, const cl_event* l) {
  static __typeof__(&clWaitForEvents) f;
  if (!f) f = NEXT(clWaitForEvents);
  atomic_fetch_add(&n_wait, 1);
  return f(n, l);
}
cl_mem clCreateBuffer(cl_context c, cl_mem_flags fl, size_t sz, void* p, cl_int* err) {
  static __typeof__(&clCreateBuffer) f;
  if (!f) f = NEXT(clCreateBuffer);
  atomic_fetch_add(&n_create, 1);
  atomic_fetch_add(&create_bytes, (long)sz);
  if (getenv("CL_COUNT_VERBOSE")) fprintf(stderr, "cl-count: clCreateBuffer %zu bytes, flags 0x%lx\n", sz, (unsigned long)fl);
  return f(c, fl, sz, p, err);
}
cl_mem clCreateSubBuffer(cl_mem b, cl_mem_flags fl, cl_buffer_create_type t, const void* info, cl_int* err) {
  static __typeof__(&clCreateSubBuffer) f;
  if (!f) f = NEXT(clCreateSubBuffer);
  atomic_fetch_add(&n_sub, 1);
  return f(b, fl, t, info, err);
}

__attribute__((destructor)) static void report(void) {
  fprintf(stderr,
          "cl-count: launches %ld | writes %ld (%.1f MB) reads %ld (%.1f MB) copies %ld fills %ld maps %ld, blocking "
          "%ld | finish %ld flush %ld waits %ld | buffers created %ld (%.1f MB) sub-buffers %ld\n",
          n_launch, n_write, write_bytes / 1e6, n_read, read_bytes / 1e6, n_copy, n_fill, n_map, n_blocking, n_finish,
          n_flush, n_wait, n_create, create_bytes / 1e6, n_sub);
}
