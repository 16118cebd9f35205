// The simulated INS errors have the statistics their documentation states (ins_error.hpp, README
// "Simulated INS errors"), the events sit where the ground truth says, and the INS reports its
// quality as documented.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "tool/tool_config.hpp"
#include "sim/ins_error.hpp"
#include "sim/simulate.hpp"

namespace insalign::sim {
namespace {

// Per-axis variance of the walk's position and heading at time t over many seeds.
struct WalkVariance {
  Vec3 position_m2 = Vec3::Zero();
  double heading_rad2 = 0.0;
};
WalkVariance walk_variance(const InsErrorConfig& c, double t_s, int seeds) {
  WalkVariance v;
  for (int s = 0; s < seeds; ++s) {
    const InsWalk walk = make_walk(c, 0.0, 200.0, 1000 + s);
    v.position_m2 += walk.position.at(t_s).cwiseAbs2();
    v.heading_rad2 += std::pow(walk.heading_at(t_s), 2);
  }
  v.position_m2 /= seeds;
  v.heading_rad2 /= seeds;
  return v;
}

TEST(SimInsError, DriftVarianceGrowsLinearlyAtTheDocumentedRate) {
  const InsErrorConfig c;  // 5 mm/sqrt(s) per axis, heading 0.002 deg/sqrt(s)
  const int seeds = 600;   // relative standard error of a variance: sqrt(2/600) = 6 %
  const WalkVariance early = walk_variance(c, 25.0, seeds);
  const WalkVariance late = walk_variance(c, 100.0, seeds);
  for (int axis = 0; axis < 3; ++axis) {
    const double rate = axis < 2 ? c.drift_horizontal_m_per_sqrt_s : c.drift_vertical_m_per_sqrt_s;
    EXPECT_NEAR(late.position_m2[axis] / (rate * rate * 100.0), 1.0, 0.2) << "axis " << axis;
    EXPECT_NEAR(early.position_m2[axis] / (rate * rate * 25.0), 1.0, 0.2) << "axis " << axis;
  }
  EXPECT_NEAR(late.position_m2.sum() / early.position_m2.sum(), 4.0, 0.6);  // linear in time
  const double heading_rate_rad = c.drift_heading_deg_per_sqrt_s * kRadPerDeg;
  EXPECT_NEAR(late.heading_rad2 / (heading_rate_rad * heading_rate_rad * 100.0), 1.0, 0.2);
  // Exactly zero at the start.
  const InsWalk walk = make_walk(c, 10.0, 50.0, 7);
  EXPECT_EQ(walk.position.at(10.0), Vec3::Zero());
  EXPECT_EQ(walk.position.at(3.0), Vec3::Zero());
  EXPECT_EQ(walk.heading_at(10.0), 0.0);
}

TEST(SimInsError, RtkFixedErrorIsBoundedAtItsDocumentedSigma) {
  Vec3 sum_sq = Vec3::Zero(), sum_sq_late = Vec3::Zero();
  const int seeds = 500;
  for (int s = 0; s < seeds; ++s) {
    const InsDrift d = make_rtk_fixed_drift(1.0, 0.0, 600.0, 77 + s);
    sum_sq += d.at(0.0).cwiseAbs2();
    sum_sq_late += d.at(550.0).cwiseAbs2();
  }
  // Stationary: the same 1 cm / 1 cm / 1.5 cm at the start and ten minutes later (no growth).
  for (const Vec3& v : {sum_sq, sum_sq_late}) {
    const Vec3 sigma = (v / seeds).cwiseSqrt();
    EXPECT_NEAR(sigma.x(), 0.01, 0.0015);
    EXPECT_NEAR(sigma.y(), 0.01, 0.0015);
    EXPECT_NEAR(sigma.z(), 0.015, 0.002);
  }
}

SimConfig event_drive() {
  SimConfig c;
  c.seed = 31;
  c.duration_s = 150.0;
  c.ins_noise_scale = 0.0;  // the events alone
  c.ins_error.float_episodes = 2;
  c.ins_error.wrong_fixes = 1;
  c.ins_error.outages = 1;
  return c;
}

Vec3 position_error(const World& w, double t) {
  const StampedPose p = reported_poses(w, {t}, 9).front();
  return p.T_world_ins.translation() - w.poses_true.T_world_ins(t).translation();
}

TEST(SimInsError, EventsSitWhereTheGroundTruthSaysAndAreReportedAsDocumented) {
  const World w = build_world(event_drive());
  ASSERT_EQ(w.ins_events.size(), 4u);
  const double t0 = w.frame_times_s.front(), t1 = w.frame_times_s.back();
  int floats = 0, wrong = 0, outages = 0;
  for (std::size_t i = 0; i < w.ins_events.size(); ++i) {
    const InsEvent& e = w.ins_events[i];
    EXPECT_GE(e.t_begin_s, t0 + 14.0);
    EXPECT_LE(e.t_end_s, t1 - 14.0);
    if (i > 0) {
      EXPECT_GE(e.t_begin_s, w.ins_events[i - 1].t_end_s + 5.0) << "events overlap";
    }
    const double mid = 0.5 * (e.t_begin_s + e.t_end_s);
    const InsQuality q_mid = ins_quality(w, mid);
    if (e.kind == InsEventKind::kFloatEpisode) {
      ++floats;
      EXPECT_NEAR(e.t_end_s - e.t_begin_s, 8.0, 1e-9);
      EXPECT_NEAR(position_error(w, mid).norm(), 0.3, 1e-3);  // the peak in the middle
      EXPECT_LT(position_error(w, e.t_begin_s + 0.2).norm(), 0.01);  // ramps up from zero
      EXPECT_EQ(q_mid.solution, GnssSolution::kRtkFloat);
      EXPECT_NEAR(q_mid.horizontal_stddev_m, 0.3, 1e-3);
      EXPECT_NEAR(ins_quality(w, e.t_begin_s + 1e-3).horizontal_stddev_m, 0.1, 1e-3);
    } else if (e.kind == InsEventKind::kWrongFix) {
      ++wrong;
      EXPECT_NEAR(e.t_end_s - e.t_begin_s, 5.0, 1e-9);
      EXPECT_NEAR(position_error(w, e.t_begin_s + 0.01).norm(), 0.5, 1e-9);
      EXPECT_NEAR(position_error(w, e.t_end_s - 0.01).norm(), 0.5, 1e-9);
      EXPECT_EQ(q_mid.solution, GnssSolution::kRtkFixed) << "a wrong fix is not flagged";
      EXPECT_LT(q_mid.horizontal_stddev_m, 0.02);
    } else {
      ++outages;
      EXPECT_NEAR(e.t_end_s - e.t_begin_s, 10.0, 1e-9);
      EXPECT_NEAR(position_error(w, mid).norm(), 0.3 / 4.0, 1e-3);  // quadratic growth
      EXPECT_NEAR(position_error(w, e.t_end_s - 1e-3).norm(), 0.3, 1e-3);
      EXPECT_EQ(q_mid.solution, GnssSolution::kInsOnly);
      EXPECT_GT(ins_quality(w, e.t_end_s - 0.1).horizontal_stddev_m, 2.0 * q_mid.horizontal_stddev_m);
      const StampedPose p = reported_poses(w, {e.t_end_s - 1e-3}, 9).front();
      const Mat3 dR = p.T_world_ins.linear() * w.poses_true.T_world_ins(p.t_s).linear().transpose();
      const Vec3 rpy_deg = rpy_from_rotation(dR) * kDegPerRad;
      EXPECT_NEAR(std::abs(rpy_deg.z()), 0.05, 1e-3);
      EXPECT_NEAR(std::abs(rpy_deg.x()), 0.02, 1e-3);
    }
    // Right after the event the INS is exact again (scale 0) and says RTK fixed.
    EXPECT_LT(position_error(w, e.t_end_s + 0.01).norm(), 1e-9);
    EXPECT_EQ(ins_quality(w, e.t_end_s + 0.01).solution, GnssSolution::kRtkFixed);
  }
  EXPECT_EQ(floats, 2);
  EXPECT_EQ(wrong, 1);
  EXPECT_EQ(outages, 1);
  // The per-frame quality the in-memory dataset carries follows the same spans.
  int float_frames = 0;
  for (const InsQuality& q : ins_quality_series(w, w.frame_times_s)) float_frames += q.solution == GnssSolution::kRtkFloat;
  EXPECT_NEAR(float_frames, 2 * 80, 2);
}

TEST(SimInsError, DriftModelIsExactAtTheStartAndSaysHowUncertainItIs) {
  SimConfig c;
  c.seed = 12;
  c.duration_s = 100.0;
  c.ins_noise_scale = 0.0;
  c.ins_error.model = InsErrorModel::kDrift;
  const World w = build_world(c);
  EXPECT_TRUE(w.drift.knots_m.empty());
  EXPECT_LT(position_error(w, w.frame_times_s.front() - 0.1).norm(), 1e-12);
  EXPECT_LT(position_error(w, w.frame_times_s.front()).norm(), 0.003);
  const double late = position_error(w, w.frame_times_s.back()).norm();
  EXPECT_GT(late, 0.002);  // sqrt(3 * 100) * 5 mm = 8.7 cm expected; far below that is a broken walk
  EXPECT_LT(late, 0.5);
  const InsQuality q = ins_quality(w, w.frame_times_s.back());
  EXPECT_EQ(q.solution, GnssSolution::kRtkFixed);
  EXPECT_NEAR(q.horizontal_stddev_m, 0.005 * std::sqrt(w.frame_times_s.back() - 1700000000.0), 1e-3);
}

TEST(SimInsError, EventsThatDoNotFitAreRefusedAndTheConfigKeysWork) {
  SimConfig c;
  c.duration_s = 20.0;
  c.ins_error.outages = 3;
  EXPECT_THROW(build_world(c), std::invalid_argument);
  const cli::ToolConfig tool = cli::tool_config_with({"sim.ins_error.model=drift", "sim.ins_error.wrong_fixes=2"});
  EXPECT_EQ(tool.sim.ins_error.model, InsErrorModel::kDrift);
  EXPECT_EQ(tool.sim.ins_error.wrong_fixes, 2);
  InsErrorModel m = InsErrorModel::kRtkFixed;
  EXPECT_TRUE(parse_ins_error_model("drift", m));
  EXPECT_EQ(m, InsErrorModel::kDrift);
  EXPECT_FALSE(parse_ins_error_model("rtk_fixed", m));
}

}  // namespace
}  // namespace insalign::sim
