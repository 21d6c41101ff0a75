#include "nephos/lbm/job.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "nephos/core/error.hpp"
#include "nephos/core/test_support.hpp"

namespace nephos::lbm {

TEST(LbmJob, ChecksNameTheRequestsFields) {
  // Every check that needs no lattice fails before any work, naming the field the front ends
  // show as their option or keyword.
  SingleProcess one;
  auto key_of = [&](const LbmRequest& r) {
    try {
      run_lbm(r, one);
    } catch (const Error& e) {
      return e.context().key;
    }
    return std::string("(no error)");
  };
  LbmRequest r;
  r.out = test_support::temp_path("lbm_job_checks");
  r.iterations = -1;
  EXPECT_EQ(key_of(r), "iterations");
  r = LbmRequest{.out = r.out};
  r.sun_elevation_deg = 0;
  EXPECT_EQ(key_of(r), "sun");
  r = LbmRequest{.out = r.out};
  r.percolation = 17;
  EXPECT_EQ(key_of(r), "percolation");
  r = LbmRequest{.out = r.out};
  r.width = 0;
  EXPECT_EQ(key_of(r), "size");
  r = LbmRequest{.out = r.out};
  r.silos = -2;
  EXPECT_EQ(key_of(r), "silos");
  r = LbmRequest{.out = r.out};
  r.resume = "checkpoint.bin";
  r.storage = Storage::fp16;
  EXPECT_EQ(key_of(r), "storage");
  EXPECT_FALSE(std::filesystem::exists(r.out));  // nothing written
}

TEST(LbmJob, RunsTheStagesAsTheyRunAlone) {
  // The pipeline's fields are those of the stages run one after the other by hand, bit for
  // bit: the water model stepped from the same silos, percolated with the same seed, lit with
  // the same sun. Fault caught: a stage fed another stage's field or parameters.
  LbmRequest r;
  r.grid = {16, 16, 12};
  r.iterations = 6;
  r.percolation = 2;
  r.width = 32, r.height = 24;
  r.seed = 9;
  r.out = test_support::temp_path("lbm_job_run");
  SingleProcess one;
  const LbmResult res = run_lbm(r, one);
  EXPECT_EQ(res.steps_done, 6);
  for (const char* f : {"lbm.nc", "clouds.vdb", "render.png"}) EXPECT_TRUE(std::filesystem::exists(r.out / f)) << f;

  const WaterModelParams params;
  WaterModel model(r.grid, params);
  model.initialise(make_silos(r.grid, params, r.seed), r.seed);
  for (int t = 0; t < 6; ++t) model.step();
  EXPECT_EQ(res.vapour, model.vapour());
  PercolationParams pp;
  pp.refinement = 2;
  Percolation perc(r.grid, model.vapour(), pp, r.seed);
  perc.run();
  EXPECT_EQ(res.percolated, perc.coarse_density());
  LightingSolver light(r.grid, perc.coarse_density(), LightingParams{});
  light.solve();
  EXPECT_EQ(res.light, light.light());
  std::filesystem::remove_all(r.out);
}

TEST(LbmJob, CondensateFractionRampsFromRho10) {
  const auto c = condensate_fraction({0.5f, 1.0f, 1.05f, 1.2f}, 1.0);
  EXPECT_EQ(c[0], 0.0f);
  EXPECT_EQ(c[1], 0.0f);
  EXPECT_NEAR(c[2], 0.5f, 1e-6);  // 1.05 as a float
  EXPECT_EQ(c[3], 1.0f);
}

}  // namespace nephos::lbm
