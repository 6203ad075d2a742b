// SPDX-License-Identifier: Apache-2.0
// The other half of the CLI's lazily loaded libraries (cmake/GenLazyStubs.cmake): the first call
// of a stubbed function lands here, loads its library, and points the stub's slot at the real
// function. GDAL and libtiff (with the hundred libraries GDAL needs) thus cost nothing to
// commands that never open a raster: `--version`, `devices`, `stages`, PNG/EXR/RAW16/npy work.
#include <dlfcn.h>
#include <unistd.h>

#include <cstdio>

extern "C" {
extern const unsigned terracl_lazy_count;
extern const char* const terracl_lazy_libs[];
extern const char* const terracl_lazy_names[];
extern const unsigned char terracl_lazy_lib_of[];
extern void* terracl_lazy_slots[];

// Called from the stubs' common entry (no C++ frame below it to unwind into): a failure ends the
// process with the reason, as the dynamic linker would have at start-up.
void* terracl_lazy_resolve(unsigned long index) {
  static void* handles[8];
  const char* name = index < terracl_lazy_count ? terracl_lazy_names[index] : "?";
  const unsigned lib = index < terracl_lazy_count ? terracl_lazy_lib_of[index] : 0;
  void* h = __atomic_load_n(&handles[lib], __ATOMIC_ACQUIRE);
  if (!h && index < terracl_lazy_count) {
    h = dlopen(terracl_lazy_libs[lib], RTLD_LAZY | RTLD_GLOBAL);
    if (h) __atomic_store_n(&handles[lib], h, __ATOMIC_RELEASE);
  }
  void* f = h ? dlsym(h, name) : nullptr;
  if (!f) {
    const char* why = dlerror();
    std::fprintf(stderr, "terracl: cannot call %s in %s: %s\n", name,
                 index < terracl_lazy_count ? terracl_lazy_libs[lib] : "?", why ? why : "not found");
    _exit(127);
  }
  __atomic_store_n(&terracl_lazy_slots[index], f, __ATOMIC_RELEASE);
  return f;
}
}
