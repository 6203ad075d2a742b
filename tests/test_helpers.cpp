// SPDX-License-Identifier: Apache-2.0
#include "test_helpers.hpp"

#include <terracl/io.hpp>

#include <algorithm>
#include <sstream>
#include <fstream>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <numeric>
#include <random>

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>

namespace terracl::test {

Device& device() {
  static std::shared_ptr<Device> d;
  if (!d) {
    try {
      d = Device::open();
    } catch (const std::exception& e) {
      ADD_FAILURE() << "no OpenCL device (CI must have PoCL): " << e.what();
      throw;
    }
  }
  return *d;
}

TempDir::TempDir() {
  static int counter = 0;
  m_dir = std::filesystem::temp_directory_path() /
          ("terracl-test-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
  std::filesystem::remove_all(m_dir);
  std::filesystem::create_directories(m_dir);
}

TempDir::~TempDir() {
  std::error_code ec;
  std::filesystem::remove_all(m_dir, ec);
}

size_t TempDir::count() const {
  size_t n = 0;
  for ([[maybe_unused]] auto& e : std::filesystem::directory_iterator(m_dir)) ++n;
  return n;
}

CmdResult run_cli(const std::string& args) {
  const std::string cmd = std::string(TERRACL_CLI) + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  CmdResult r{-1, ""};
  if (!p) return r;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  const int status = pclose(p);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

double cli_peak_rss_mib(const std::vector<std::string>& args) {
  std::vector<std::string> all = {TERRACL_PEAK_RSS, TERRACL_CLI};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  int fds[2];
  if (pipe(fds) != 0) return -1;
  const pid_t pid = fork();
  if (pid == 0) {
    const int null = ::open("/dev/null", O_WRONLY);
    dup2(null, 1);
    dup2(fds[1], 2);
    ::close(fds[0]);
    execv(argv[0], argv.data());
    _exit(127);
  }
  ::close(fds[1]);
  std::string err;
  char buf[4096];
  ssize_t n;
  while ((n = ::read(fds[0], buf, sizeof buf)) > 0 || (n < 0 && errno == EINTR))
    if (n > 0) err.append(buf, size_t(n));
  ::close(fds[0]);
  int status = 0;
  if (pid < 0 || waitpid(pid, &status, 0) != pid || !WIFEXITED(status) || WEXITSTATUS(status) != 0) return -1;
  const size_t at = err.rfind("peak_rss_kib ");
  return at == std::string::npos ? -1 : std::strtod(err.c_str() + at + 13, nullptr) / 1024.0;
}

std::string data_path(const std::string& rel) { return std::string(TERRACL_SOURCE_DIR) + "/data/" + rel; }

Heightfield n44_window(int x0, int y0, int n) {
  Heightfield h = read_heightfield(data_path("dem/N44W072.hgt"));
  if (h.count_nodata()) fill_nodata_harmonic(h);
  Heightfield c(n, n);
  c.georef = h.georef;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) c.at(x, y) = h.at(x0 + x, y0 + y);
  return c;
}

Heightfield smooth_terrain(int w, int h, double cell, double relief, unsigned seed) {
  Heightfield t(w, h);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  struct Wave {
    double kx, ky, phase, amp;
  };
  std::vector<Wave> waves;
  for (int i = 0; i < 6; ++i)
    waves.push_back({(1 + 3 * u(rng)) * 2 * M_PI / w, (1 + 3 * u(rng)) * 2 * M_PI / h, 2 * M_PI * u(rng), relief / (i + 2)});
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double v = 1000.0;
      for (auto& wv : waves) v += wv.amp * std::sin(wv.kx * x + wv.ky * y + wv.phase);
      t.at(x, y) = float(v);
    }
  t.georef.cell_x = t.georef.cell_y = cell;
  return t;
}

size_t bit_differences(const Heightfield& a, const Heightfield& b) {
  if (a.width != b.width || a.height != b.height) return size_t(-1);
  size_t n = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    const bool an = std::isnan(a.z[i]), bn = std::isnan(b.z[i]);
    n += (an != bn) || (!an && std::memcmp(&a.z[i], &b.z[i], 4) != 0);
  }
  return n;
}

std::vector<double> d8_area(const Heightfield& h, double cell_area) {
  const int w = h.width, n = int(h.size());
  const double lx = h.georef.cell_x, ly = h.georef.cell_y;
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return h.z[a] > h.z[b]; });
  std::vector<double> area(n, cell_area);
  for (int i : order) {
    const int x = i % w, y = i / w;
    double best = 0;
    int to = -1;
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int xx = x + dx, yy = y + dy;
        if ((!dx && !dy) || xx < 0 || yy < 0 || xx >= w || yy >= h.height) continue;
        const int j = yy * w + xx;
        const double s = (double(h.z[i]) - h.z[j]) / std::hypot(dx * lx, dy * ly);
        if (s > best) best = s, to = j;
      }
    if (to >= 0) area[to] += area[i];
  }
  return area;
}

}  // namespace terracl::test

namespace terracl::test {

std::string file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace terracl::test
