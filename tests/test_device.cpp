#include "test_helpers.hpp"

#include <terracl/device.hpp>
#include <terracl/error.hpp>

#include <cstdlib>

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

TEST(Device, AllocationBeyondLimitIsClearError) {
  Device& d = test::device();
  try {
    d.buffer(size_t(d.info().max_alloc) + 1024, CL_MEM_READ_WRITE, "huge test buffer");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("huge test buffer"), std::string::npos) << e.what();
  }
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
