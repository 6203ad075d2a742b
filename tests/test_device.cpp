// SPDX-License-Identifier: Apache-2.0
#include "test_helpers.hpp"

#include <terracl/device.hpp>
#include <terracl/error.hpp>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <thread>

using namespace terracl;

TEST(Device, DefaultDeviceExists) {
  const auto devs = list_devices();
  ASSERT_FALSE(devs.empty()) << "no OpenCL device; CI needs pocl-opencl-icd";
  Device& d = test::device();
  EXPECT_FALSE(d.info().name.empty());
  EXPECT_GT(d.info().max_alloc, 0u);
}

// Every kernel file must compile on the default device (PoCL in CI).
TEST(Device, EveryKernelFileCompiles) {
  Device& d = test::device();
  const auto files = kernel_files();
  ASSERT_FALSE(files.empty());
  for (const auto& f : files) {
    EXPECT_NO_THROW(d.program(f)) << "kernels/" << f << ".cl";
  }
}

TEST(Device, KernelRunsAndMatchesHost) {
  Device& d = test::device();
  const int n = 1000;
  std::vector<float> x(n), y(n), out(n);
  for (int i = 0; i < n; ++i) x[i] = 0.1f * i, y[i] = 3.0f - i;
  cl::Buffer bx = d.buffer(n * 4, CL_MEM_READ_WRITE, "x"), by = d.buffer(n * 4, CL_MEM_READ_WRITE, "y"),
             bo = d.buffer(n * 4, CL_MEM_READ_WRITE, "out");
  d.queue().enqueueWriteBuffer(bx, CL_TRUE, 0, n * 4, x.data());
  d.queue().enqueueWriteBuffer(by, CL_TRUE, 0, n * 4, y.data());
  cl::Kernel k = d.kernel("raster", "axpy");
  k.setArg(0, bo);
  k.setArg(1, 2.5f);
  k.setArg(2, bx);
  k.setArg(3, by);
  k.setArg(4, n);
  d.queue().enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(round_up(n, 64)), cl::NDRange(64));
  d.queue().enqueueReadBuffer(bo, CL_TRUE, 0, n * 4, out.data());
  for (int i = 0; i < n; ++i) ASSERT_EQ(out[i], 2.5f * x[i] + y[i]) << i;
}

TEST(Device, BuildFailurePrintsLog) {
  // A kernel name that does not exist is a clear error naming the kernel and the file.
  Device& d = test::device();
  try {
    d.kernel("raster", "no_such_kernel");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_kernel"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("CL_INVALID_KERNEL_NAME"), std::string::npos) << e.what();
  }
  try {
    d.program("nonexistent_file");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("nonexistent_file"), std::string::npos);
  }
}

TEST(Device, CompileErrorCarriesFileOptionsAndLog) {
  Device& d = test::device();
  const std::string bad = "__kernel void broken(__global float* x) { x[0] = undeclared_variable_q; }\n";
  try {
    d.program_from_source("broken_test", bad, "-DTERRACL_TEST_OPTION=1");
    FAIL() << "expected a build failure";
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("broken_test"), std::string::npos) << msg;
    EXPECT_NE(msg.find("-DTERRACL_TEST_OPTION=1"), std::string::npos) << msg;
    EXPECT_NE(msg.find("undeclared_variable_q"), std::string::npos) << "build log missing: " << msg;
    EXPECT_NE(msg.find("CL_BUILD_PROGRAM_FAILURE"), std::string::npos) << msg;
  }
}

TEST(Device, AllocationBeyondLimitIsClearError) {
  Device& d = test::device();
  try {
    d.buffer(size_t(d.info().max_alloc) + 1024, CL_MEM_READ_WRITE, "huge test buffer");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("huge test buffer"), std::string::npos) << e.what();
  }
}

// Allocation accounting is per physical device: two Device objects on the same device see each
// other's buffers, and a buffer's bytes are returned when it is released.
TEST(Device, AllocationAccountingIsPerPhysicalDeviceAndReleases) {
  Device& d = test::device();
  auto other = Device::open(std::to_string(d.info().index));
  const uint64_t before = d.allocated_bytes();
  EXPECT_EQ(other->allocated_bytes(), before);
  {
    cl::Buffer b = other->buffer(1 << 20, CL_MEM_READ_WRITE, "accounting test");
    EXPECT_EQ(d.allocated_bytes(), before + (1 << 20));
  }
  // The bytes come back in the buffer's destructor callback, which a driver may run later on its
  // own thread (NVIDIA's does, after clReleaseMemObject has returned): wait for it, boundedly.
  other->queue().finish();
  for (int i = 0; i < 200 && d.allocated_bytes() != before; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_EQ(d.allocated_bytes(), before);
}

TEST(Device, BadIndexIsClearError) {
  EXPECT_THROW(Device::open("9999"), Error);
  EXPECT_THROW(Device::open("no-such-device-name-xyz"), Error);
}

TEST(Device, ClErrorNames) {
  EXPECT_STREQ(cl_error_name(CL_OUT_OF_RESOURCES), "CL_OUT_OF_RESOURCES");
  EXPECT_STREQ(cl_error_name(CL_INVALID_KERNEL_NAME), "CL_INVALID_KERNEL_NAME");
  cl::Error e(CL_OUT_OF_RESOURCES, "clEnqueueNDRangeKernel");
  EXPECT_EQ(describe(e), "clEnqueueNDRangeKernel: CL_OUT_OF_RESOURCES (-5)");
}

TEST(Device, ProgramBinaryCacheOnDisk) {
  test::TempDir tmp;
  const char* old = std::getenv("XDG_CACHE_HOME");
  const std::string saved = old ? old : "";
  setenv("XDG_CACHE_HOME", tmp.dir().c_str(), 1);
  unsetenv("TERRACL_NO_CACHE");
  setenv("TERRACL_PROGRAM_CACHE", "1", 1);  // on PoCL ours is written only when this is set
  {
    auto d = Device::open();
    d->program("raster");
  }
  const auto dir = tmp.dir() / "terracl";
  ASSERT_TRUE(std::filesystem::exists(dir));
  size_t n = 0;
  for (auto& e : std::filesystem::directory_iterator(dir)) n += e.path().extension() == ".bin";
  EXPECT_EQ(n, 1u);
  {
    // A second device object loads the binary and its kernels still compute correctly.
    auto d = Device::open();
    cl::Buffer b = d->buffer(64 * 4, CL_MEM_READ_WRITE, "b");
    d->fill(b, 7.5f, 0, 64);
    std::vector<float> out(64);
    d->queue().enqueueReadBuffer(b, CL_TRUE, 0, 256, out.data());
    for (float v : out) ASSERT_EQ(v, 7.5f);
  }
  // Corrupt the cached binary: the next build must ignore it and rebuild, not fail.
  for (auto& e : std::filesystem::directory_iterator(dir)) std::ofstream(e.path(), std::ios::binary) << "garbage";
  {
    auto d = Device::open();
    EXPECT_NO_THROW(d->program("raster"));
  }
  // TERRACL_NO_CACHE=1 writes nothing.
  std::filesystem::remove_all(dir);
  setenv("TERRACL_NO_CACHE", "1", 1);
  {
    auto d = Device::open();
    d->program("raster");
  }
  EXPECT_FALSE(std::filesystem::exists(dir));
  unsetenv("TERRACL_NO_CACHE");
  unsetenv("TERRACL_PROGRAM_CACHE");
  if (old)
    setenv("XDG_CACHE_HOME", saved.c_str(), 1);
  else
    unsetenv("XDG_CACHE_HOME");
}

// Static check (DESIGN.md, "Devices"): element indices that scale with the grid are computed in
// 64 bits. A product of an int row/column with a pitch (`y * W`, `(y + 1) * P`) overflows past
// 2^31 cells (render's 3 * (y * w + x) at 716 M cells), which no test can allocate on this machine.
// Flags int declarations and array subscripts that multiply by a grid dimension without size_t;
// a line may opt out with "index-ok:" and its reason.
TEST(Kernels, GridIndexProductsAre64Bit) {
  const std::regex decl(R"(\bint\s+\w+\s*=\s*[^;]*\*\s*\(?\s*(W|H|P|w|h|Wc|Hc|Pc|width|height|pitch|N)\b)");
  const std::regex sub(R"(\[([^\[\]]*\*\s*\(?\s*(W|w|P|Pc|Wc|width|pitch)\b[^\[\]]*)\])");
  std::vector<std::string> bad;
  for (const auto& f : kernel_files()) {
    std::istringstream in(kernel_source(f));
    std::string line;
    for (int no = 1; std::getline(in, line); ++no) {
      const auto t = line.find_first_not_of(" \t");
      if (t == std::string::npos || line.compare(t, 2, "//") == 0 || line.find("index-ok:") != std::string::npos)
        continue;
      bool flag = std::regex_search(line, decl) && line.find("size_t") == std::string::npos;
      for (std::sregex_iterator m(line.begin(), line.end(), sub), e; m != e && !flag; ++m) {
        const std::string s = (*m)[1];
        flag = s.find("size_t") == std::string::npos && s.find("long") == std::string::npos;
      }
      if (flag) bad.push_back(f + ".cl:" + std::to_string(no) + ": " + line);
    }
  }
  EXPECT_TRUE(bad.empty()) << "32-bit grid index products:\n" << [&] {
    std::string s;
    for (auto& b : bad) s += b + "\n";
    return s;
  }();
  // The check itself catches the pattern it is for.
  EXPECT_TRUE(std::regex_search(std::string("    __global uchar* p = out + 3 * (y * w + x);"), decl) ||
              std::regex_search(std::string("    const float c = z[y * w + x];"), sub));
  EXPECT_TRUE(std::regex_search(std::string("  const int row = (y + 1) * P + PAD;"), decl));
}

// Launch shapes: chosen from the device's properties (CPU bit of CL_DEVICE_TYPE), shown
// by `terracl devices`, forced by TERRACL_LAUNCH so that both shapes run on PoCL.
TEST(Device, LaunchShapeFromPropertiesAndForced) {
  unsetenv("TERRACL_LAUNCH");
  for (const auto& d : list_devices()) EXPECT_EQ(d.launch, d.type == "CPU" ? "rows" : "wide") << d.name;
  setenv("TERRACL_LAUNCH", "wide", 1);
  for (const auto& d : list_devices()) EXPECT_EQ(d.launch, "wide") << d.name;
  setenv("TERRACL_LAUNCH", "sideways", 1);
  EXPECT_THROW(list_devices(), Error);
  unsetenv("TERRACL_LAUNCH");
}
