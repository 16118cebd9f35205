// The reported stddev's honesty terms (issue 17, item 6): the segments' inflation pooled over the
// DOFs, a drifting INS's height error in tz's stddev, and the INS's heading error in yaw's.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "core/pipeline.hpp"
#include "core/repeatability.hpp"
#include "core/tz_coupling.hpp"
#include "sim/simulate.hpp"
#include "sim/world_dataset.hpp"

namespace insalign {
namespace {

// One DOF's segments agreeing by chance must not leave it at its (10-50x optimistic) formal
// stddev: it is lifted to the drive's typical inflation; the others keep the segments' value.
TEST(Repeatability, StddevFloorPoolsTheSegmentsInflation) {
  Vec6 formal;
  formal << 1e-4, 1e-4, 1.0, 1e-5, 1e-5, 1e-5;
  RepeatabilityResult rep;
  rep.stddev_whole_drive << 3e-3, 1e-5, std::numeric_limits<double>::infinity(), 3e-4, 3e-4, 3e-4;
  const Vec6 sd = stddev_with_repeatability(formal, rep);
  // Inflation: geometric mean of 30, 0.1, 30, 30, 30 = 30 * 300^(-1/5).
  const double inflation = 30.0 * std::pow(300.0, -0.2);
  EXPECT_NEAR(sd[1], inflation * 1e-4, 1e-9);
  EXPECT_GT(sd[1], 10.0 * rep.stddev_whole_drive[1]);
  EXPECT_DOUBLE_EQ(sd[0], 3e-3);
  EXPECT_DOUBLE_EQ(sd[3], 3e-4);
  EXPECT_DOUBLE_EQ(sd[2], 1.0);  // tz is not the segments' business
  // No segments: the formal stddev stays.
  const Vec6 none = stddev_with_repeatability(formal, RepeatabilityResult{});
  for (int i = 0; i < 6; ++i) EXPECT_DOUBLE_EQ(none[i], formal[i]) << i;
}

// An RTK-fixed INS states a constant accuracy: the assumed height error stays. A drifting one
// states a growing stddev: its growth enters (5 mm/sqrt(s) over 30 s: about 16 mm RMS).
// The INS's heading error is in yaw's stddev and nowhere else; a yaw the drive did not determine
// stays undetermined.
TEST(InsHeading, AddsToYawOnly) {
  PipelineConfig config;
  config.ins_heading_sigma_deg = 0.01;
  CalibrationResult r;
  r.stddev << 1e-3, 1e-3, 1e-2, 1e-5, 1e-5, 0.003 * kRadPerDeg;
  const Vec6 before = r.stddev;
  add_ins_heading_error(config, r);
  EXPECT_NEAR(r.stddev[5] * kDegPerRad, std::hypot(0.003, 0.01), 1e-12);
  for (int i = 0; i < 5; ++i) EXPECT_EQ(r.stddev[i], before[i]) << i;
  EXPECT_NEAR(r.ins_heading_sigma_rad * kDegPerRad, 0.01, 1e-12);
  r.stddev[5] = std::numeric_limits<double>::infinity();
  add_ins_heading_error(config, r);
  EXPECT_TRUE(std::isinf(r.stddev[5]));
}

TEST(TzCoupling, InsHeightSigmaFollowsTheStatedDrift) {
  sim::SimConfig sc;
  sc.seed = 3;
  sc.duration_s = 30.0;
  sc.azimuth_step_deg = 2.0;
  const PipelineConfig config;
  const auto fixed_world = std::make_shared<const sim::World>(sim::build_world(sc));
  const Dataset fixed = sim::world_dataset(fixed_world);
  ASSERT_FALSE(fixed.ins_quality.empty());
  EXPECT_NEAR(ins_height_sigma_m(make_frame_store(fixed, config), 0.01), 0.01, 1e-6);
  sc.ins_error.model = sim::InsErrorModel::kDrift;
  const auto drift_world = std::make_shared<const sim::World>(sim::build_world(sc));
  const Dataset drift = sim::world_dataset(drift_world);
  const double sigma = ins_height_sigma_m(make_frame_store(drift, config), 0.01);
  const double q = sc.ins_error.drift_vertical_m_per_sqrt_s;
  EXPECT_GT(sigma, std::hypot(0.01, 0.7 * q * std::sqrt(15.0)));
  EXPECT_LT(sigma, std::hypot(0.01, 1.3 * q * std::sqrt(15.0)));
}

}  // namespace
}  // namespace insalign
