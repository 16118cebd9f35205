// When the INS trajectory correction is applied (decide_application): only where the drive shows
// the INS drifting and the correction stays within what its random-walk prior allows. A
// correction many times its prior is the LiDAR fitting something other than the INS's drift:
// a vertical ramp of 1.7 m over a 3-minute city drive left a left-mounted HDL-32's pitch 0.157
// deg off (bench/check_accuracy drive 201; 0.001 deg with the correction refused).
// (Walks of the prior: ratio of RMS to the expected 0.85 median, 2.14 at the 99th percentile,
// 3.2 the largest of 20000.)
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/trajectory_correction.hpp"

namespace insalign {
namespace {

TrajectoryCorrection knots_every_second(int seconds) {
  TrajectoryCorrection s;
  for (int k = 0; k <= seconds; ++k) s.t_s.push_back(1.7e9 + k);
  return s;
}

// The expected RMS the gate compares with is what walks drawn from the prior actually show.
TEST(TrajectoryGate, PriorRmsIsWhatWalksOfThePriorShow) {
  const TrajectoryCorrectionConfig config;  // 5 mm/sqrt(s)
  const TrajectoryCorrection s = knots_every_second(180);
  const Vec3 prior = prior_rms_axes_m(s, config, {});
  EXPECT_NEAR(prior.z(), 0.005 * std::sqrt(180.0 / 6.0), 1e-9);
  std::mt19937 rng(7);
  std::normal_distribution<double> step(0.0, config.drift_m_per_sqrt_s);
  double sum_ratio_sq = 0.0, worst = 0.0;
  int above = 0;  // walks beyond 0.6 of the gate
  constexpr int kWalks = 2000;
  for (int w = 0; w < kWalks; ++w) {
    std::vector<double> x(s.t_s.size(), 0.0);
    for (std::size_t k = 1; k < x.size(); ++k) x[k] = x[k - 1] + step(rng);
    double mean = 0.0, var = 0.0;
    for (double v : x) mean += v / static_cast<double>(x.size());
    for (double v : x) var += (v - mean) * (v - mean) / static_cast<double>(x.size());
    const double ratio = std::sqrt(var) / prior.x();
    sum_ratio_sq += ratio * ratio;
    worst = std::max(worst, ratio);
    above += ratio > 0.6 * config.max_prior_ratio ? 1 : 0;
  }
  EXPECT_NEAR(sum_ratio_sq / kWalks, 1.0, 0.08);
  EXPECT_LT(worst, config.max_prior_ratio) << "the gate would refuse walks of its own prior";
  EXPECT_LT(above, kWalks / 100) << "a walk of the prior at 0.6 of the gate is rare (about 1 in 300)";
}

// The INS's stated accuracy widens the prior where it grows faster than the assumed walk.
TEST(TrajectoryGate, StatedGrowthWidensThePrior) {
  const TrajectoryCorrectionConfig config;
  const TrajectoryCorrection s = knots_every_second(100);
  std::vector<InsQuality> quality;
  for (const double t : s.t_s) {  // a stated stddev growing as a 20 mm/sqrt(s) walk
    InsQuality q;
    q.t_s = t;
    q.horizontal_stddev_m = q.vertical_stddev_m = 0.02 * std::sqrt(t - s.t_s.front());
    quality.push_back(q);
  }
  EXPECT_NEAR(prior_rms_axes_m(s, config, quality).x(), 0.02 * std::sqrt(100.0 / 6.0), 1e-6);
  EXPECT_NEAR(prior_rms_axes_m(s, config, {}).x(), 0.005 * std::sqrt(100.0 / 6.0), 1e-9);
}

TrajectoryCorrection found(const Vec3& rms_axes_m) {
  TrajectoryCorrection s = knots_every_second(180);
  s.correction_rms_axes_m = rms_axes_m;
  s.correction_rms_m = rms_axes_m.norm();
  s.prior_rms_axes_m = prior_rms_axes_m(s, TrajectoryCorrectionConfig{}, {});
  s.cost_ins_rms_m = 0.0235;  // drive 201's plane thickness: 46% thinner corrected
  s.cost_corrected_rms_m = 0.0126;
  return s;
}

TEST(TrajectoryGate, ACorrectionFarBeyondItsPriorIsNotApplied) {
  TrajectoryCorrectionConfig config;
  config.mode = TrajectoryCorrectionMode::kAuto;
  TrajectoryCorrection ramp = found({0.0056, 0.0158, 0.506});  // drive 201
  decide_application(config, ramp);
  EXPECT_FALSE(ramp.applied);
  EXPECT_NE(ramp.decision.find("vertical part (506 mm RMS) is 18x"), std::string::npos) << ramp.decision;

  TrajectoryCorrection drift = found({0.030, 0.025, 0.020});  // a walk the prior expects
  decide_application(config, drift);
  EXPECT_TRUE(drift.applied) << drift.decision;

  TrajectoryCorrection small = found({0.010, 0.010, 0.005});  // below apply_min_rms_m
  decide_application(config, small);
  EXPECT_FALSE(small.applied);
  EXPECT_NE(small.decision.find("consistent"), std::string::npos) << small.decision;

  // An INS that states its drift needs no size from the LiDAR, only a thinner map (drift study
  // seeds 8 and 9: 24.6 mm, 17-18% thinner, refused before; yaw 0.030 deg off instead of 0.021).
  decide_application(config, small, /*ins_states_drift=*/true);
  EXPECT_TRUE(small.applied) << small.decision;
  TrajectoryCorrection no_gain = found({0.010, 0.010, 0.005});
  no_gain.cost_corrected_rms_m = 0.95 * no_gain.cost_ins_rms_m;  // 5% thinner: an RTK fix's noise
  decide_application(config, no_gain, /*ins_states_drift=*/true);
  EXPECT_FALSE(no_gain.applied);
  EXPECT_NE(no_gain.decision.find("does not confirm"), std::string::npos) << no_gain.decision;

  config.mode = TrajectoryCorrectionMode::kAlways;  // the user's word wins
  decide_application(config, ramp);
  EXPECT_TRUE(ramp.applied);
}

}  // namespace
}  // namespace insalign
