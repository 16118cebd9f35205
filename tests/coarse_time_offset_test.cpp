// The coarse LiDAR-to-INS time offset from rotation angles: found where the turning rate changes,
// refused where it cannot be told, and end to end on a host-stamped LiDAR stage 2 alone cannot reach.
#include <gtest/gtest.h>

#include <cmath>

#include "core/coarse_time_offset.hpp"
#include "core/pipeline.hpp"
#include "sim/simulate.hpp"
#include "sim/world_dataset.hpp"

namespace insalign {
namespace {

// A car whose heading follows yaw_deg(t), sampled at 100 Hz.
template <class Yaw>
PoseStream turning(Yaw yaw_deg, double duration_s) {
  std::vector<StampedPose> poses;
  for (double t = 0.0; t <= duration_s + 1e-9; t += 0.01)
    poses.push_back({1000.0 + t, make_transform(Vec3(t, 0, 0), {0.0, 0.0, yaw_deg(t)})});
  return PoseStream(std::move(poses));
}

// Pairs as the LiDAR would measure them when its clock is offset_s behind the INS's.
std::vector<AnglePair> pairs_seen(const PoseStream& poses, double offset_s, double noise_deg) {
  std::vector<AnglePair> pairs;
  int k = 0;
  for (double t = 1002.0; t < 1000.0 + 28.0; t += 1.1, ++k) {
    const double t1 = t + 0.5;
    const Mat3 R = poses.T_world_ins(t + offset_s).linear().transpose() * poses.T_world_ins(t1 + offset_s).linear();
    const double wobble = (k % 2 ? 1.0 : -1.0) * noise_deg;
    pairs.push_back({t, t1, Eigen::AngleAxisd(R).angle() * kDegPerRad + wobble});
  }
  return pairs;
}

TEST(CoarseTimeOffset, FoundWhereTheTurningRateChanges) {
  // Weaving: the turning rate changes all the time, as in a figure-8.
  const PoseStream poses = turning([](double t) { return 40.0 * std::sin(0.4 * t); }, 30.0);
  for (double offset : {-0.8, -0.31, 0.12, 0.4, 0.95}) {
    const CoarseTimeOffset r = fit_time_offset(pairs_seen(poses, offset, 0.02), poses, {});
    EXPECT_TRUE(r.applied) << r.explanation;
    // Coarse is enough: within half of stage 2's own search (+-0.05 s), which refines it.
    EXPECT_NEAR(r.offset_s, offset, 0.025) << r.explanation;
  }
  // Within stage 2's own reach it is left alone, whatever the search's minimum.
  const CoarseTimeOffset small = fit_time_offset(pairs_seen(poses, 0.01, 0.0), poses, {});
  EXPECT_FALSE(small.applied) << small.explanation;
  EXPECT_EQ(small.offset_s, 0.0);
}

TEST(CoarseTimeOffset, SteadyTurningOrTooFewPairsDecideNothing) {
  // A constant turning rate gives the same angle for any offset: nothing to take.
  const PoseStream circle = turning([](double t) { return 6.0 * t; }, 30.0);
  const CoarseTimeOffset steady = fit_time_offset(pairs_seen(circle, 0.3, 0.02), circle, {});
  EXPECT_FALSE(steady.applied) << steady.explanation;
  EXPECT_EQ(steady.offset_s, 0.0);
  const PoseStream poses = turning([](double t) { return 40.0 * std::sin(0.4 * t); }, 30.0);
  std::vector<AnglePair> few = pairs_seen(poses, 0.3, 0.0);
  few.resize(3);
  EXPECT_FALSE(fit_time_offset(few, poses, {}).applied);
}

// A LiDAR stamping its sweeps with the host's receive time, 0.3 s late: beyond stage 2's search
// (+-0.05 s) this gave centimetres of error with exit 0 before the init looked for it.
TEST(CoarseTimeOffset, HostStampedLidarIsCalibratedEndToEnd) {
  sim::SimConfig sc;
  sc.seed = 9;
  sc.duration_s = 40.0;
  sc.azimuth_step_deg = 1.0;
  sc.time_offset_s = -0.3;
  const auto world = std::make_shared<const sim::World>(sim::build_world(sc));
  Dataset data = sim::world_dataset(world);
  data.T_ins_lidar_init.reset();  // the init's own search
  PipelineConfig config;
  config.repeatability.segments = 0;
  const CalibrationResult r = run_calibration(make_frame_store(data, config), config);
  ASSERT_TRUE(r.init.time_offset.applied) << r.init.explanation;
  EXPECT_NEAR(r.time_offset_s, sc.time_offset_s, 0.002);
  const ExtrinsicError err = extrinsic_error(r.T_ins_lidar, world->T_ins_lidar_true);
  EXPECT_LT(err.dt_m.head<2>().cwiseAbs().maxCoeff(), 0.01);
  EXPECT_LT(err.drpy_deg.cwiseAbs().maxCoeff(), 0.03);
  std::printf("init %+.3f s, final %+.4f s; %.1f mm, %.4f deg\n", r.init.time_offset.best_offset_s, r.time_offset_s,
              1e3 * err.dt_m.head<2>().norm(), err.angle_deg);
}

}  // namespace
}  // namespace insalign
