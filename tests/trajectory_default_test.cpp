// The default trajectory correction (trajectory.mode if-drifting) decides from the drive's own
// evidence: the INS's stated accuracy growing along the drive outside the stretches the screen
// leaves out or, where the INS states none (TUM, OpenCalib pose files), the frames' offsets from
// the map of the drive's other times. RTK-fixed, float-episode, wrong-fix and outage drives do not
// engage it; a drifting INS does.
#include <gtest/gtest.h>

#include <cmath>

#include "core/ins_screen.hpp"
#include "core/pipeline.hpp"
#include "sim/simulate.hpp"
#include "sim/world_dataset.hpp"

namespace insalign {
namespace {

// The stated drift the default sees on a short seeded figure-8 with the given INS errors.
double stated_drift_of(const sim::SimConfig& sc) {
  const auto world = std::make_shared<const sim::World>(sim::build_world(sc));
  const Dataset data = sim::world_dataset(world);
  const PipelineConfig config;
  const FrameStore store = make_frame_store(data, config);
  InsScreenResult screen;
  const FrameStore screened = leave_out_status_spans(store, config.ins_screen, screen);
  return stated_drift_rms_m(screened);
}

// if-drifting's verdict on the drive when its INS states nothing: the screen (status, then the
// LiDAR checks with the true extrinsic, as stage 1's is within millimetres of it) gives the evidence.
DriftEvidence unstated_evidence_of(const sim::SimConfig& sc) {
  const auto world = std::make_shared<const sim::World>(sim::build_world(sc));
  Dataset data = sim::world_dataset(world);
  data.ins_quality.clear();
  const PipelineConfig config;
  const FrameStore store = make_frame_store(data, config);
  const InsScreenResult screen =
      lidar_checks(store, world->T_ins_lidar_true, world->lidars.front().time_offset_s, config.ins_screen);
  return drift_evidence(leave_out_spans(store, screen.spans), screen, config.trajectory);
}

sim::SimConfig short_drive(std::uint64_t seed) {
  sim::SimConfig sc;
  sc.seed = seed;
  sc.duration_s = 60.0;
  sc.azimuth_step_deg = 2.0;
  return sc;
}

TEST(TrajectoryDefault, IsIfDriftingAndEngagesOnlyOnADriftingIns) {
  const TrajectoryCorrectionConfig defaults;
  ASSERT_EQ(defaults.mode, TrajectoryCorrectionMode::kIfDrifting);
  for (std::uint64_t seed : {1u, 2u}) {
    sim::SimConfig fixed = short_drive(seed);
    EXPECT_LT(stated_drift_of(fixed), 0.2 * defaults.drifting_min_stated_growth_m) << "RTK fixed, seed " << seed;
    sim::SimConfig events = short_drive(seed);
    events.duration_s = 120.0;
    events.figure8_loops = 5;
    events.ins_error.float_episodes = 2;
    events.ins_error.wrong_fixes = 1;
    events.ins_error.outages = 1;
    EXPECT_LT(stated_drift_of(events), defaults.drifting_min_stated_growth_m) << "float, wrong fix, outage, seed " << seed;
    sim::SimConfig drift = short_drive(seed);
    drift.ins_error.model = sim::InsErrorModel::kDrift;  // 5 mm/sqrt(s): ~27 mm RMS growth over 60 s
    EXPECT_GT(stated_drift_of(drift), 2.0 * defaults.drifting_min_stated_growth_m) << "drift, seed " << seed;
  }
}

TEST(TrajectoryDefault, WithoutStatedAccuracyTheLidarDecides) {
  const TrajectoryCorrectionConfig defaults;
  for (std::uint64_t seed : {1u, 2u}) {
    sim::SimConfig perfect = short_drive(seed);
    perfect.ins_noise_scale = 0.0;
    const DriftEvidence p = unstated_evidence_of(perfect);
    EXPECT_FALSE(p.stated);
    ASSERT_TRUE(p.measured) << p.message;
    EXPECT_FALSE(p.drifting) << "perfect poses, seed " << seed << ": " << p.message;
    // RTK fixed (1 cm Gauss-Markov) sits a few mm below the threshold on the benchmark's drives
    // (bench/results/honest.md); here only its distance from a drifting INS is asserted.
    const DriftEvidence f = unstated_evidence_of(short_drive(seed));
    EXPECT_EQ(f.drifting, f.value_m >= defaults.drifting_min_map_offset_m) << f.message;
    sim::SimConfig drift = short_drive(seed);
    drift.ins_error.model = sim::InsErrorModel::kDrift;
    // Twice the default walk: over these 60 s a 5 mm/sqrt(s) walk sits near the threshold (which
    // is set for drives of about 100 s), 10 mm/sqrt(s) clearly above it.
    drift.ins_error.drift_horizontal_m_per_sqrt_s = 0.01;
    drift.ins_error.drift_vertical_m_per_sqrt_s = 0.01;
    const DriftEvidence d = unstated_evidence_of(drift);
    EXPECT_TRUE(d.drifting) << "drift, seed " << seed << ": " << d.message;
    EXPECT_GT(d.value_m, 1.5 * f.value_m) << d.message << " / " << f.message;
    EXPECT_GT(f.value_m, 2.0 * p.value_m) << f.message << " / " << p.message;
    EXPECT_NE(d.message.find("states no accuracy"), std::string::npos) << d.message;
  }
}

// On the RTK-fixed drive the default costs nothing and answers exactly as `off`; the result says
// why the correction was not estimated.
TEST(TrajectoryDefault, RtkFixedDriveGivesOffsAnswer) {
  sim::SimConfig sc = short_drive(3);
  sc.duration_s = 40.0;
  sc.azimuth_step_deg = 1.0;
  const auto world = std::make_shared<const sim::World>(sim::build_world(sc));
  const Dataset data = sim::world_dataset(world);
  PipelineConfig config;
  config.repeatability.segments = 0;
  const CalibrationResult by_default = run_calibration(make_frame_store(data, config), config);
  config.trajectory.mode = TrajectoryCorrectionMode::kOff;
  const CalibrationResult off = run_calibration(make_frame_store(data, config), config);
  EXPECT_FALSE(by_default.trajectory.applied);
  EXPECT_NE(by_default.trajectory.outcome.message.find("the INS states no drift"), std::string::npos)
      << by_default.trajectory.outcome.message;
  EXPECT_TRUE(by_default.T_ins_lidar.isApprox(off.T_ins_lidar, 1e-12));
  EXPECT_LT(extrinsic_error(by_default.T_ins_lidar, world->T_ins_lidar_true).angle_deg, 0.05);
}

// A one-way city loop with a drifting INS (bench/check_accuracy's drive 32: a Pandar64 at the left
// mirror). The lever arm estimated with the trajectory came out 61.5 mm off at a stated 8 mm while
// the data's errors decided it along the direction the knots mimic it (R_world_ins(t) l); the
// prior alone decides it there now. The time offset stays stage 2's and carries the drift the
// correction measured.
TEST(TrajectoryDefault, EstimatesTheLeverArmOnAOneWayLoopWithinItsStddev) {
  sim::SimConfig sc;
  sc.seed = 1032;
  sc.trajectory = sim::TrajectoryKind::kCityLoop;
  sc.duration_s = 180.0;
  sc.azimuth_step_deg = 0.8;
  sc.lidar_model = "pandar64";
  sc.rig = "lidar:pandar64@left";
  sc.ins_error.model = sim::InsErrorModel::kDrift;
  sc.n_fiducials = 0;
  const auto world = std::make_shared<const sim::World>(sim::build_world(sc));
  const Dataset data = sim::world_dataset(world);
  PipelineConfig config;
  const TrajectoryCorrectionConfig defaults;
  ASSERT_FALSE(defaults.hold_lever_arm);
  const CalibrationResult r = run_calibration(make_frame_store(data, config), config);
  ASSERT_TRUE(r.trajectory.applied) << r.trajectory.decision;  // the drift is seen and corrected
  ASSERT_TRUE(r.refine.has_value());
  const Vec3 err = r.T_ins_lidar.translation() - world->T_ins_lidar_true.translation();
  const Vec3 err_stage2 = r.refine->T_ins_lidar.translation() - world->T_ins_lidar_true.translation();
  std::printf("lever arm error: joint x %.1f y %.1f mm (stated %.1f %.1f), stage 2 x %.1f y %.1f mm\n", 1e3 * err.x(),
              1e3 * err.y(), 1e3 * r.stddev[0], 1e3 * r.stddev[1], 1e3 * err_stage2.x(), 1e3 * err_stage2.y());
  for (int i : {0, 1}) {
    EXPECT_LT(std::abs(err[i]), 0.02) << "axis " << i;  // the data deciding: 61.5 mm
    EXPECT_LT(std::abs(err[i]), 3.0 * r.stddev[i]) << "axis " << i << ", stated " << r.stddev[i];
    EXPECT_EQ(r.ins_drift_stddev[i], 0.0) << "axis " << i << ": the correction's own estimate";
  }
  EXPECT_DOUBLE_EQ(r.time_offset_s, r.refine->time_offset_s) << "the time offset stays stage 2's";
  EXPECT_GT(r.ins_drift_stddev[6], 0.0) << "and carries the drift";
  EXPECT_EQ(r.ins_drift_stddev.segment<3>(3), Vec3::Zero()) << "the rotation is the correction's own estimate";
  EXPECT_LT(extrinsic_error(r.T_ins_lidar, world->T_ins_lidar_true).angle_deg, 0.05);
}

// A drifting INS whose correction is estimated but too weak to apply (here: the gain it must
// bring raised beyond reach): the answer is `off`'s, stage 2 on the INS poses as exact, so every DOF's
// stddev carries the slow error the correction measured (on real scans a 53 mm RMS correction
// that was not applied left yaw 0.13 deg off at a stated 0.04, and `check` called the true
// extrinsic `drifted`: bench/results/check.md).
TEST(TrajectoryDefault, AnUnappliedCorrectionStillCountsInEveryStddev) {
  sim::SimConfig sc = short_drive(4);
  sc.duration_s = 90.0;
  sc.ins_error.model = sim::InsErrorModel::kDrift;
  const auto world = std::make_shared<const sim::World>(sim::build_world(sc));
  const Dataset data = sim::world_dataset(world);
  PipelineConfig config;
  config.repeatability.segments = 0;
  config.trajectory.apply_min_gain = 10.0;
  const CalibrationResult r = run_calibration(make_frame_store(data, config), config);
  config.trajectory.mode = TrajectoryCorrectionMode::kOff;
  const CalibrationResult off = run_calibration(make_frame_store(data, config), config);
  ASSERT_FALSE(r.trajectory.applied) << r.trajectory.decision;
  ASSERT_GE(r.trajectory.t_s.size(), 2u) << "estimated: " << r.trajectory.outcome.message;
  EXPECT_TRUE(r.T_ins_lidar.isApprox(off.T_ins_lidar, 1e-12)) << "not applied: off's answer";
  for (int i : {0, 1, 3, 4, 5}) {
    EXPECT_GT(r.ins_drift_stddev[i], 0.0) << "DOF " << i;
    EXPECT_GE(r.stddev[i], r.ins_drift_stddev[i]) << "DOF " << i;
    EXPECT_GE(r.stddev[i], off.stddev[i]) << "DOF " << i;
  }
  const ExtrinsicError e = extrinsic_error(r.T_ins_lidar, world->T_ins_lidar_true);
  EXPECT_LT(e.drpy_deg.z(), 3.0 * r.stddev[5] * kDegPerRad) << "yaw within 3 stated sigma";
}

}  // namespace
}  // namespace insalign
