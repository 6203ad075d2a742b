// SPDX-License-Identifier: Apache-2.0
// How the CLI's process allocates memory (docs/performance.md, "Allocator and GDAL threads").
#include "cli.hpp"

#include <unistd.h>

#ifdef __GLIBC__
#include <malloc.h>
#endif

#include <cstdlib>
#include <fstream>
#include <string>
#include <sys/stat.h>

namespace terracl::cli {

// Stages allocate and free blocks of kilobytes to tens of megabytes (a render strip's compressed
// blocks, amplify's levels, the solver's). With glibc's defaults each thread got its own arena
// and freed blocks were handed back to the kernel, so the same memory was page-faulted in again
// and again: an 8193^2 TRI render took 185,000 page faults. One arena, blocks up to 32 MB from
// the heap, and a heap trimmed only when more than 32 MB lies free at its top: 37,000 faults,
// 5.9 -> 4.5 s (gdaldem 5.1 s); amplify x4 peaks lower, 201 -> 187 MiB (never trimming, it
// peaked at 250 MiB). Setting any of these turns off glibc's sliding thresholds, so all three are
// set. The studio and tiled runs keep everything (apps/cmd_studio.cpp, apps/tile_flags.cpp).
void keep_freed_memory() {
#ifdef __GLIBC__
  mallopt(M_ARENA_MAX, 1);
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 32 << 20);
#endif
}

namespace {

// The subcommand: the first argument that is neither an option nor the value of a global option
// given as a separate word.
std::string subcommand(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--device" || a == "--progress") {
      ++i;
      continue;
    }
    if (!a.empty() && a[0] == '-') continue;
    return a;
  }
  return "";
}

// The first argument after the subcommand that names a file, its size (0: none).
off_t first_file_size(int argc, char** argv, const std::string& sub) {
  bool after = false;
  for (int i = 1; i < argc; ++i) {
    if (!after) {
      after = sub == argv[i];
      continue;
    }
    struct stat s {};
    if (argv[i][0] != '-' && ::stat(argv[i], &s) == 0 && S_ISREG(s.st_mode)) return s.st_size;
  }
  return 0;
}

// Transparent huge pages in the kernel's "madvise" mode (Debian's default): only regions the
// process marks get 2 MB pages. Under "always" they come anyway; under "never" not at all.
bool huge_pages_on_request() {
  std::ifstream f("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string line;
  return std::getline(f, line) && line.find("[madvise]") != std::string::npos;
}

}  // namespace

// Every fresh 4 KB page costs a fault, and on virtual machines a fault is dear: amplify x4 of a
// 1201^2 DEM took 72,000 of them, 0.5 s of its 2.9 s. glibc marks its heap and its large blocks
// for 2 MB pages when the tunable glibc.malloc.hugetlb=1 is set, which it reads only at start-up,
// so the CLI starts itself again with it (the same process id, arguments and environment). Not
// for the commands that only start up (--version, devices, info, stages, a small convert: the
// second start costs ~20 ms), not under MPI launchers, not when the user set the tunable.
// The figures, off against on, are in docs/performance.md, "2 MB pages".
void use_huge_pages(int argc, char** argv) {
#if defined(__linux__) && defined(__GLIBC__)
  const char* env = std::getenv("GLIBC_TUNABLES");
  const std::string tun = env ? env : "";
  if (tun.find("glibc.malloc.hugetlb") != std::string::npos) return;
  for (const char* mpi : {"OMPI_COMM_WORLD_SIZE", "PMI_RANK", "PMIX_RANK", "MPI_LOCALRANKID"})
    if (std::getenv(mpi)) return;
  const std::string sub = subcommand(argc, argv);
  if (sub.empty() || sub == "devices" || sub == "info" || sub == "stages" || sub == "help") return;
  if (sub == "convert" && first_file_size(argc, argv, sub) < (off_t(16) << 20)) return;
  if (!huge_pages_on_request()) return;
  const std::string value = tun.empty() ? "glibc.malloc.hugetlb=1" : tun + ":glibc.malloc.hugetlb=1";
  if (::setenv("GLIBC_TUNABLES", value.c_str(), 1) != 0) return;
  ::execv("/proc/self/exe", argv);
  // Only reached when the exec failed: go on with 4 KB pages, leaving the environment as it was.
  if (env)
    ::setenv("GLIBC_TUNABLES", tun.c_str(), 1);
  else
    ::unsetenv("GLIBC_TUNABLES");
#else
  (void)argc;
  (void)argv;
#endif
}

}  // namespace terracl::cli
