// SPDX-License-Identifier: Apache-2.0
// NumPy .npy read/write: fixtures written by numpy (data/npy/make_fixtures.py),
// the refusals with their reasons, and a round trip with numpy itself (full build only, where
// python3-numpy is installed; the core build runs the fixture cases).
#include "test_helpers.hpp"

#include <terracl/error.hpp>
#include <terracl/io.hpp>

#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>

using namespace terracl;

namespace {

std::string npy(const std::string& name) { return test::data_path("npy/" + name); }

// The fixture grid: value 100 * row + column (+ offset), row 0 first.
void expect_grid(const Heightfield& h, double offset) {
  ASSERT_EQ(h.width, 4);
  ASSERT_EQ(h.height, 3);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 4; ++x) EXPECT_EQ(h.z[size_t(y) * 4 + x], float(100 * y + x + offset)) << x << "," << y;
}

std::string error_of(const std::string& path) {
  try {
    read_heightfield(path);
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

std::string run(const std::string& cmd) {
  std::string out;
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  if (!p) return "popen failed";
  std::array<char, 4096> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) out.append(buf.data(), n);
  const int rc = pclose(p);
  return rc == 0 ? out : "exit " + std::to_string(rc) + ": " + out;
}

}  // namespace

TEST(Npy, ReadsTheFourDtypesNumpyWrites) {
  EXPECT_EQ(format_from_extension("a/b.NPY"), FileFormat::NPY);
  expect_grid(read_heightfield(npy("f4_3x4.npy")), 0.25);
  expect_grid(read_heightfield(npy("f8_3x4.npy")), 0.25);
  expect_grid(read_heightfield(npy("i2_3x4.npy")), -150);
  expect_grid(read_heightfield(npy("u2_3x4.npy")), 60000);
  expect_grid(read_heightfield(npy("f4_v2_3x4.npy")), 0.25);  // format version 2.0 header
}

TEST(Npy, RefusesWhatItCannotReadWithTheReason) {
  EXPECT_NE(error_of(npy("fortran_3x4.npy")).find("Fortran"), std::string::npos) << error_of(npy("fortran_3x4.npy"));
  EXPECT_NE(error_of(npy("big_endian_3x4.npy")).find("big-endian"), std::string::npos);
  EXPECT_NE(error_of(npy("shape_3d.npy")).find("2-D"), std::string::npos) << error_of(npy("shape_3d.npy"));
  const std::string i4 = error_of(npy("i4_3x4.npy"));
  EXPECT_NE(i4.find("'<i4'"), std::string::npos) << i4;
  EXPECT_NE(i4.find("i4_3x4.npy"), std::string::npos) << i4;  // names the file

  test::TempDir dir;
  // Not an .npy at all, and a truncated one.
  {
    std::ofstream(dir.path("text.npy")) << "hello";
    EXPECT_NE(error_of(dir.path("text.npy")).find("NUMPY"), std::string::npos);
    std::ifstream in(npy("f4_3x4.npy"), std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(dir.path("short.npy"), std::ios::binary) << bytes.substr(0, bytes.size() - 4);
    EXPECT_NE(error_of(dir.path("short.npy")).find("data bytes"), std::string::npos) << error_of(dir.path("short.npy"));
  }
}

TEST(Npy, WriteReadRoundTripKeepsValuesNodataAndCellSize) {
  test::TempDir dir;
  Heightfield h = test::smooth_terrain(37, 23, 12.5);
  h.z[5] = NAN;
  h.metadata["source"] = "test";
  write_heightfield(h, dir.path("t.npy"));
  EXPECT_EQ(dir.count(), 2u);  // the array and its sidecar, no temporary left
  const Heightfield r = read_heightfield(dir.path("t.npy"));
  ASSERT_EQ(r.width, 37);
  ASSERT_EQ(r.height, 23);
  EXPECT_TRUE(std::isnan(r.z[5]));
  for (size_t i = 0; i < h.size(); ++i)
    if (i != 5) ASSERT_EQ(r.z[i], h.z[i]);
  EXPECT_EQ(r.georef.cell_x, 12.5);
  EXPECT_EQ(r.metadata.at("source"), "test");
  // The header is the one numpy.save writes for this array (version 1.0, 64-byte aligned).
  std::ifstream in(dir.path("t.npy"), std::ios::binary);
  std::string head(128, '\0');
  in.read(head.data(), 128);
  EXPECT_EQ(head.substr(0, 8), std::string("\x93NUMPY\x01\x00", 8));
  EXPECT_NE(head.find("{'descr': '<f4', 'fortran_order': False, 'shape': (23, 37), }"), std::string::npos);
  EXPECT_EQ((10 + (unsigned char)head[8]) % 64, 0);
}

TEST(NpyNumpy, NumpyReadsOursAndWeReadNumpys) {
  test::TempDir dir;
  Heightfield h = test::smooth_terrain(19, 11, 10.0);
  write_heightfield(h, dir.path("ours.npy"));
  // numpy loads terracl's file; the sum of the values and the shape must agree.
  const std::string out = run("/usr/bin/python3 -c \"import numpy as np; a = np.load('" + dir.path("ours.npy") +
                              "'); print(a.shape, a.dtype, repr(float(a.astype('f8').sum())))\"");
  double sum = 0;
  for (float v : h.z) sum += v;
  EXPECT_EQ(out.substr(0, out.find(')') + 1), "(11, 19)") << out;
  EXPECT_NE(out.find("float32"), std::string::npos) << out;
  const double got = std::strtod(out.substr(out.rfind(' ') + 1).c_str(), nullptr);
  EXPECT_NEAR(got, sum, 1e-9 * std::fabs(sum)) << out;
  // numpy writes a float64 array of 0.5 * (row * 7 + column); terracl reads it.
  const std::string made = run("/usr/bin/python3 -c \"import numpy as np; r, c = np.mgrid[0:5, 0:7]; np.save('" +
                               dir.path("theirs.npy") + "', 0.5 * (r * 7 + c))\"");
  ASSERT_EQ(made, "");
  const Heightfield t = read_heightfield(dir.path("theirs.npy"));
  ASSERT_EQ(t.width, 7);
  ASSERT_EQ(t.height, 5);
  for (size_t i = 0; i < t.size(); ++i) EXPECT_EQ(t.z[i], 0.5f * float(i));
}

TEST(NpyNumpy, CliConvertsToNpy) {
  test::TempDir dir;
  const auto r = test::run_cli("convert " + test::data_path("crops/frontrange_64.asc") + " " + dir.path("f.npy"));
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const Heightfield a = read_heightfield(test::data_path("crops/frontrange_64.asc"));
  const Heightfield b = read_heightfield(dir.path("f.npy"));
  ASSERT_EQ(a.width, b.width);
  ASSERT_EQ(a.height, b.height);
  for (size_t i = 0; i < a.size(); ++i) ASSERT_EQ(a.z[i], b.z[i]);
  EXPECT_NEAR(b.georef.cell_x, a.georef.cell_x, 1e-9);
}
