// SPDX-License-Identifier: Apache-2.0
// Program building with a two-level cache: in memory per Device, and on disk as device binaries
// keyed by a hash of everything that can change the binary (source, options, platform, device,
// driver). A stale or corrupt cache entry is ignored and rebuilt, never an error.
#include <terracl/device.hpp>
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/warm_up.hpp>

#include <fmt/format.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace terracl {
namespace detail {
const std::map<std::string, std::string>& embedded_kernels();
}

namespace fs = std::filesystem;

namespace {

// Kernels are built as OpenCL C 1.2 and never with fast-math: determinism and NaN safety matter
// more to us than the last few per cent.
const char* kBaseOptions = "-cl-std=CL1.2";

uint64_t fnv1a(const std::string& s, uint64_t h = 1469598103934665603ull) {
  for (unsigned char c : s) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

fs::path cache_dir() {
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x) return fs::path(x) / "terracl";
  if (const char* home = std::getenv("HOME"); home && *home) return fs::path(home) / ".cache" / "terracl";
  return {};
}

bool env_on(const char* name) {
  const char* v = std::getenv(name);
  return v && *v && std::string(v) != "0";
}

bool disk_cache_enabled() { return !env_on("TERRACL_NO_CACHE"); }

// PoCL caches every program it builds (keyed by the preprocessed source, options and device) and
// every kernel it specialises at launch, but asking it for a program's binary makes it compile
// every kernel of the program for a generic work-group size (~10 s of CPU on first use for the
// multigrid programs). So on PoCL a command's own first use does not write our cache; the warm-up
// runs (`terracl devices --warm`) do, with TERRACL_PROGRAM_CACHE=1. Reading it stays on: loading
// a binary skips the preprocessing (and its temporary files) of a source build, ~50 ms a run.
bool writes_binaries(const std::string& platform) {
  const char* pocl_cache = std::getenv("POCL_KERNEL_CACHE");
  const bool pocl_caches = !(pocl_cache && std::string(pocl_cache) == "0");
  return !(platform.find("Portable Computing Language") != std::string::npos && pocl_caches) ||
         env_on("TERRACL_PROGRAM_CACHE");
}

std::string build_log(const cl::Program& p, const cl::Device& d) {
  try {
    return p.getBuildInfo<CL_PROGRAM_BUILD_LOG>(d);
  } catch (const cl::Error&) {
    return "(no build log available)";
  }
}

}  // namespace

const std::string& kernel_source(const std::string& file) {
  // Sources with their `#include "name.clh"` lines replaced by the embedded headers (one level:
  // headers include nothing), built once.
  static const std::map<std::string, std::string> resolved = [] {
    const auto& k = detail::embedded_kernels();
    std::map<std::string, std::string> out;
    for (const auto& [name, src] : k) {
      if (name.size() > 4 && name.compare(name.size() - 4, 4, ".clh") == 0) continue;
      std::string text;
      std::istringstream in(src);
      for (std::string line; std::getline(in, line);) {
        const std::string tag = "#include \"";
        if (line.rfind(tag, 0) == 0 && line.size() > tag.size() + 1 && line.back() == '"') {
          const std::string header = line.substr(tag.size(), line.size() - tag.size() - 1);
          auto h = k.find(header);
          if (h == k.end()) fail("device", "kernels/{}.cl includes unknown header kernels/{}", name, header);
          text += h->second;
        } else {
          text += line;
        }
        text += '\n';
      }
      out.emplace(name, std::move(text));
    }
    return out;
  }();
  auto it = resolved.find(file);
  if (it == resolved.end()) fail("device", "no embedded kernel file kernels/{}.cl", file);
  return it->second;
}

std::vector<std::string> kernel_files() {
  std::vector<std::string> out;
  for (const auto& [name, src] : detail::embedded_kernels())
    if (name.size() <= 4 || name.compare(name.size() - 4, 4, ".clh") != 0) out.push_back(name);
  return out;
}

cl::Program& Device::program(const std::string& file, const std::string& extra_options) {
  return program_from_source(file, kernel_source(file), extra_options);
}

cl::Program& Device::program_from_source(const std::string& file, const std::string& src,
                                         const std::string& extra_options) {
  std::string options = extra_options.empty() ? kBaseOptions : std::string(kBaseOptions) + " " + extra_options;
  // The launch shape is compiled in (kernels/launch.clh): the wide shape's kernels do one cell each.
  if (m_info.launch == "wide") options += " -DTERRACL_WIDE=1";
  const std::string mem_key = file + "\n" + options + "\n" + std::to_string(fnv1a(src));
  {
    std::lock_guard<std::mutex> lock(m_mutex);
    if (auto it = m_programs.find(mem_key); it != m_programs.end()) return it->second;
  }
  // The build itself runs outside the lock (OpenCL program calls are thread-safe): a program needed
  // now does not wait for another thread's build of a different one (the studio's background
  // warm-up, terracl/warm_up.hpp). Two threads building the same program keep the first.
  auto keep = [&](const cl::Program& p) -> cl::Program& {
    std::lock_guard<std::mutex> lock(m_mutex);
    return m_programs.emplace(mem_key, p).first->second;
  };

  uint64_t h = fnv1a(src);
  for (const std::string& part : {options, m_info.platform, m_info.name, m_info.driver_version, m_info.device_version})
    h = fnv1a("\x1f" + part, h);
  const fs::path dir = cache_dir();
  const bool use_disk = disk_cache_enabled() && !dir.empty();
  const fs::path bin_path = dir / fmt::format("{}-{:016x}.bin", file, h);

  if (use_disk && path_exists(bin_path.string())) {
    std::ifstream in(bin_path, std::ios::binary);
    std::vector<unsigned char> bin((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (!bin.empty()) {
      try {
        cl::Program::Binaries bins{bin};
        cl::Program p(m_context, {m_device}, bins);
        p.build({m_device}, options.c_str());
        return keep(p);
      } catch (const cl::Error&) {
        // Corrupt or incompatible binary: fall through to a source build that rewrites it.
      }
    }
  }

  cl::Program p(m_context, src);
  try {
    p.build({m_device}, options.c_str());
  } catch (const cl::Error& e) {
    throw Error("device", fmt::format("building kernels/{}.cl for {} failed ({}) with options '{}'. Build log:\n{}",
                                      file, m_info.name, describe(e), options, build_log(p, m_device)));
  }

  if (use_disk && writes_binaries(m_info.platform)) {
    try {
      auto bins = p.getInfo<CL_PROGRAM_BINARIES>();
      if (!bins.empty() && !bins[0].empty()) {
        fs::create_directories(dir);
        const fs::path tmp = bin_path.string() + fmt::format(".tmp{}", std::rand());
        {
          std::ofstream out(tmp, std::ios::binary);
          out.write(reinterpret_cast<const char*>(bins[0].data()), std::streamsize(bins[0].size()));
        }
        fs::rename(tmp, bin_path);
      }
    } catch (const std::exception&) {
      // A read-only or full cache folder only costs the next run a rebuild.
    }
  }
  return keep(p);
}

size_t warm_up(Device& device, const std::vector<std::pair<std::string, std::string>>& programs,
               const std::function<bool()>& stop) {
  size_t ready = 0;
  for (const auto& [file, options] : programs) {
    if (stop && stop()) break;
    try {
      device.program(file, options);
      ++ready;
    } catch (const std::exception&) {
      // Reported where the program is first used.
    }
  }
  return ready;
}

}  // namespace terracl
