#include <gtest/gtest.h>

#include <random>

#include "core/deskew.hpp"
#include "core/geometry.hpp"
#include "core/pose_stream.hpp"

namespace insalign {
namespace {

TEST(Geometry, RpyRoundTrip) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-80.0, 80.0);
  for (int i = 0; i < 100; ++i) {
    const Vec3 rpy_deg(u(rng), u(rng), 2.0 * u(rng));
    const Vec3 back = rpy_from_rotation(rotation_from_rpy(rpy_deg * kRadPerDeg)) * kDegPerRad;
    EXPECT_LT((back - rpy_deg).norm(), 1e-9);
  }
}

TEST(Geometry, ExtrinsicErrorIsPerAxisInInsFrame) {
  const Iso3 gt = make_transform({1.0, 2.0, 1.5}, {2.0, -3.0, 90.0});
  Iso3 est = gt;
  est.linear() = rotation_from_rpy(Vec3(0, 0, 0.5) * kRadPerDeg) * gt.linear();  // 0.5 deg about INS z
  est.translation() += Vec3(0.01, -0.02, 0.03);
  const ExtrinsicError e = extrinsic_error(est, gt);
  EXPECT_NEAR(e.drpy_deg.z(), 0.5, 1e-9);
  EXPECT_NEAR(e.drpy_deg.x(), 0.0, 1e-9);
  EXPECT_NEAR(e.angle_deg, 0.5, 1e-9);
  EXPECT_NEAR(e.dt_m.y(), 0.02, 1e-12);
  EXPECT_NEAR(e.dt_norm_m, std::sqrt(0.0014), 1e-12);
}

// A vehicle on a circle at constant speed and yaw rate: interpolation of 10 Hz poses must stay
// within a millimetre of the true path (linear interpolation would cut the corner by ~2 mm).
Iso3 circle_pose(double t) {
  const double radius = 10.0, omega = 0.4;  // rad/s: 4 m/s
  Iso3 T = Iso3::Identity();
  T.translation() = Vec3(radius * std::cos(omega * t), radius * std::sin(omega * t), 0.0);
  T.linear() = rotation_from_rpy(Vec3(0.0, 0.0, omega * t + M_PI / 2));
  return T;
}

TEST(PoseStream, InterpolatesCircleAndRejectsOutside) {
  std::vector<StampedPose> poses;
  for (int k = 0; k <= 100; ++k) poses.push_back({0.1 * k, circle_pose(0.1 * k)});
  const PoseStream stream(poses);
  for (double t = 0.1; t < 9.9; t += 0.0137) {
    const Iso3 T = stream.T_world_ins(t);
    EXPECT_LT((T.translation() - circle_pose(t).translation()).norm(), 1e-3) << t;
    EXPECT_LT(Eigen::AngleAxisd(T.linear() * circle_pose(t).linear().transpose()).angle(), 1e-9);
  }
  EXPECT_THROW(stream.T_world_ins(-0.01), OutOfRangeError);
  EXPECT_THROW(stream.T_world_ins(10.01), OutOfRangeError);
  std::swap(poses[3], poses[4]);
  EXPECT_THROW(PoseStream{poses}, std::invalid_argument);
}

// A sensor moving on the circle scans points of a static world; deskew must bring them into the
// sensor frame at the frame end exactly where a static sensor at that pose would have seen them.
TEST(Deskew, SyntheticMovingSensor) {
  std::vector<StampedPose> poses;
  for (int k = 0; k <= 40; ++k) poses.push_back({0.1 * k, circle_pose(0.1 * k)});
  const PoseStream stream(poses);
  const Iso3 T_ins_lidar = make_transform({0.5, -0.3, 1.6}, {1.0, -2.0, 37.0});
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-20.0, 20.0);
  Sweep sweep;
  sweep.t_end_s = 2.0;
  std::vector<Vec3> p_world_true;
  const int n = 2000;
  for (int i = 0; i < n; ++i) {
    const double dt = -0.1 + 0.1 * (i + 1) / n;
    const Vec3 p_world(u(rng), u(rng), 0.1 * u(rng));
    const Iso3 T_world_lidar = circle_pose(sweep.t_end_s + dt) * T_ins_lidar;
    sweep.p_lidar.push_back((T_world_lidar.inverse() * p_world).cast<float>());
    sweep.dt_s.push_back(static_cast<float>(dt));
    p_world_true.push_back(p_world);
  }
  const Iso3 T_lidarend_world = (circle_pose(sweep.t_end_s) * T_ins_lidar).inverse();
  const std::vector<Vec3f> p_deskewed = deskew_sweep(sweep, stream, T_ins_lidar);
  const std::vector<Vec3f> p_skewed = deskew_sweep(sweep, stream, T_ins_lidar, {.per_point_time = false});
  double max_err = 0.0, max_skew = 0.0;
  for (int i = 0; i < n; ++i) {
    const Vec3 expected = T_lidarend_world * p_world_true[i];
    max_err = std::max(max_err, (p_deskewed[i].cast<double>() - expected).norm());
    max_skew = std::max(max_skew, (p_skewed[i].cast<double>() - expected).norm());
  }
  EXPECT_LT(max_err, 2e-3);   // float storage and interpolation
  EXPECT_GT(max_skew, 0.2);   // without deskew the error is the motion over a sweep
}

// On the circle (4 m/s, 0.4 rad/s about z) the motion table over a sweep holds the true pose,
// velocity and yaw rate at every entry, and nearest() picks the entry of a point's time; near
// the end of the poses the differences stay inside them (no throw).
TEST(Deskew, SweepMotionHoldsPoseAndVelocities) {
  std::vector<StampedPose> poses;
  for (int k = 0; k <= 40; ++k) poses.push_back({0.1 * k, circle_pose(0.1 * k)});
  const PoseStream stream(poses);
  Sweep sweep;
  sweep.t_end_s = 2.0;
  for (int i = 0; i < 100; ++i) {
    sweep.p_lidar.push_back(Vec3f::Zero());
    sweep.dt_s.push_back(static_cast<float>(-0.1 + 0.001 * (i + 1)));
  }
  const double offset_s = 0.03;
  const SweepMotion m = sweep_motion(sweep, stream, offset_s);
  ASSERT_EQ(m.R_world_ins.size(), 11u);
  for (std::size_t i = 0; i < m.R_world_ins.size(); ++i) {
    const double t = sweep.t_end_s + offset_s + m.dt0_s + static_cast<double>(i) * m.step_s;
    EXPECT_LT((m.t_world_ins[i] - circle_pose(t).translation()).norm(), 1e-3) << i;
    const Vec3 v_true(-4.0 * std::sin(0.4 * t), 4.0 * std::cos(0.4 * t), 0.0);
    EXPECT_LT((m.v_world[i] - v_true).norm(), 0.01) << i;
    EXPECT_NEAR(m.w_world[i].z(), 0.4, 1e-3) << i;
    EXPECT_LT(m.w_world[i].head<2>().norm(), 1e-6) << i;
  }
  EXPECT_EQ(m.nearest(-0.1), 0u);
  EXPECT_EQ(m.nearest(-0.0504), 5u);
  EXPECT_EQ(m.nearest(0.5), 10u);
  sweep.t_end_s = 4.0;  // the last pose: the table stays within the stream
  const SweepMotion end = sweep_motion(sweep, stream, 0.0);
  EXPECT_LT((end.t_world_ins.back() - circle_pose(4.0).translation()).norm(), 1e-3);
}

}  // namespace
}  // namespace insalign
