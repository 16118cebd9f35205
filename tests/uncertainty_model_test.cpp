// The reported stddev's honesty terms (issue 17, item 6): the segments' inflation pooled over the
// DOFs, a drifting INS's height error in tz's stddev, and the INS's heading error in yaw's.
#include <gtest/gtest.h>

#include <algorithm>
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
  rep.segments_ok = 3;
  rep.stddev_whole_drive << 3e-3, 1e-5, std::numeric_limits<double>::infinity(), 3e-4, 3e-4, 3e-4;
  const Vec6 sd = stddev_with_repeatability(formal, rep);
  // Inflation: geometric mean of 30, 0.1, 30, 30, 30 = 30 * 300^(-1/5) (x, y, yaw alone: lower),
  // over the geometric mean's shortfall for three segments.
  const double inflation = 30.0 * std::pow(300.0, -0.2) / 0.843;
  EXPECT_NEAR(sd[1], inflation * 1e-4, 1e-9);
  EXPECT_GT(sd[1], 10.0 * rep.stddev_whole_drive[1]);
  EXPECT_DOUBLE_EQ(sd[0], 3e-3);
  EXPECT_DOUBLE_EQ(sd[5], 3e-4);
  EXPECT_NEAR(sd[3], 30.0 / 0.843 * 1e-5, 1e-12);  // roll and pitch: their own 30 over the shortfall
  EXPECT_DOUBLE_EQ(sd[2], 1.0);  // tz is not the segments' business
  // No segments: the formal stddev stays.
  const Vec6 none = stddev_with_repeatability(formal, RepeatabilityResult{});
  for (int i = 0; i < 6; ++i) EXPECT_DOUBLE_EQ(none[i], formal[i]) << i;
}

// The formal stddev is the more optimistic for x, y and yaw (the turns') than for roll and pitch
// (the ground's): a DOF takes its kind's inflation when that is above the drive's.
TEST(Repeatability, EachKindOfDofTakesTheLargerInflation) {
  Vec6 formal;
  formal << 1e-4, 1e-4, 1.0, 1e-5, 1e-5, 1e-5;
  RepeatabilityResult rep;
  rep.segments_ok = 3;
  // segments / formal: x 40, y 20, roll 10, pitch 10, yaw 40.
  rep.stddev_whole_drive << 4e-3, 2e-3, std::numeric_limits<double>::infinity(), 1e-4, 1e-4, 4e-4;
  const Vec6 sd = stddev_with_repeatability(formal, rep);
  const double drive = std::pow(40.0 * 20.0 * 10.0 * 10.0 * 40.0, 0.2), turns = std::pow(40.0 * 20.0 * 40.0, 1.0 / 3.0);
  ASSERT_GT(turns, drive);
  EXPECT_NEAR(sd[1], turns / 0.843 * 1e-4, 1e-12);  // above the segments' 2e-3
  EXPECT_NEAR(sd[0], std::max(4e-3, turns / 0.843 * 1e-4), 1e-12);
  EXPECT_NEAR(sd[3], drive / 0.843 * 1e-5, 1e-12);  // the ground's own 10 is below the drive's
  EXPECT_NEAR(sd[4], drive / 0.843 * 1e-5, 1e-12);
  EXPECT_NEAR(sd[5], std::max(4e-4, turns / 0.843 * 1e-5), 1e-12);
}

// The time offset's formal stddev (a few microseconds on the check's drives, its errors tenths of
// a millisecond) takes the turns' inflation, or the segments' own spread when that is larger;
// an offset not estimated (infinite) and a study without segments leave it as it is.
TEST(Repeatability, TimeOffsetStddevTakesTheTurnsInflation) {
  Vec6 formal;
  formal << 1e-4, 1e-4, 1.0, 1e-5, 1e-5, 1e-5;
  RepeatabilityResult rep;
  rep.segments_ok = 3;
  rep.stddev_whole_drive << 4e-3, 2e-3, std::numeric_limits<double>::infinity(), 1e-4, 1e-4, 4e-4;
  rep.time_offset_stddev_whole_drive_s = 1e-5;
  const double turns = std::pow(40.0 * 20.0 * 40.0, 1.0 / 3.0) / 0.843;
  EXPECT_NEAR(time_offset_stddev_with_repeatability(6e-6, formal, rep), turns * 6e-6, 1e-12);
  rep.time_offset_stddev_whole_drive_s = 1e-3;
  EXPECT_DOUBLE_EQ(time_offset_stddev_with_repeatability(6e-6, formal, rep), 1e-3);
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(time_offset_stddev_with_repeatability(inf, formal, rep), inf);
  EXPECT_DOUBLE_EQ(time_offset_stddev_with_repeatability(6e-6, formal, RepeatabilityResult{}), 6e-6);
}

// The whole drive's stddev from a spread of n segments: spread / (d_n sqrt(n)).
TEST(Repeatability, WholeDriveStddevPerSpread) {
  EXPECT_NEAR(whole_drive_stddev_per_spread(3), 1.0 / (1.693 * std::sqrt(3.0)), 1e-12);
  EXPECT_NEAR(whole_drive_stddev_per_spread(2), 1.0 / (1.128 * std::sqrt(2.0)), 1e-12);
  EXPECT_EQ(whole_drive_stddev_per_spread(9), whole_drive_stddev_per_spread(5));
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
