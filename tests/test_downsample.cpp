// SPDX-License-Identifier: Apache-2.0
#include "test_helpers.hpp"

#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/stage.hpp>

using namespace terracl;

TEST(Downsample, BlockMeansAndGeoreferencing) {
  Heightfield h = read_heightfield(test::data_path("crops/presidential_128x96.tif"));
  const StageInfo* s = StageRegistry::instance().find("downsample");
  ASSERT_NE(s, nullptr);
  StageData data;
  data.height = h;
  data.current = DataKind::Heightfield;
  const json opts = resolve_options(*s, json{{"factor", 4}}, "/0");
  StageContext ctx{data, opts, nullptr, {}, "downsample", {}};
  s->run(ctx);
  const Heightfield& o = *data.height;
  ASSERT_EQ(o.width, 32);
  ASSERT_EQ(o.height, 24);
  double sum = 0;
  for (int v = 0; v < 4; ++v)
    for (int u = 0; u < 4; ++u) sum += h.at(4 * 5 + u, 4 * 7 + v);
  EXPECT_NEAR(o.at(5, 7), sum / 16, 1e-3);
  EXPECT_DOUBLE_EQ(o.georef.geotransform[1], 4 * h.georef.geotransform[1]);
  EXPECT_DOUBLE_EQ(o.georef.geotransform[0], h.georef.geotransform[0]);
  EXPECT_NEAR(o.georef.cell_x, 4 * h.georef.cell_x, 1e-9);
  EXPECT_THROW(resolve_options(*s, json{{"factor", "four"}}, "/0"), Error);
}

TEST(Downsample, CliRefusesBadFactor) {
  test::TempDir tmp;
  auto r = test::run_cli("downsample " + test::data_path("crops/frontrange_64.asc") + " -o " + tmp.path("o.tif") +
                         " --factor 0");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.out.find("factor: 0 is out of range; expected an integer from 1 to 4096"), std::string::npos) << r.out;
  EXPECT_EQ(tmp.count(), 0u);
  auto ok = test::run_cli("downsample " + test::data_path("crops/frontrange_64.asc") + " -o " + tmp.path("o.tif") +
                          " --factor 8");
  EXPECT_EQ(ok.exit_code, 0) << ok.out;
}
