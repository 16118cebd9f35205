// Global initialisation: its pieces on synthetic inputs, and the whole on simulated drives.
#include <random>

#include <gtest/gtest.h>

#include "core/global_init.hpp"

namespace insalign {
namespace {

TEST(GroundPlane, FitsTiltedGroundAmongWalls) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.02);
  const Iso3 T_world_lidar = make_transform({0, 0, 1.85}, {6, -8, 120});  // tilted sensor, 1.85 m up
  std::vector<Vec3> p_lidar;
  const Iso3 T_lidar_world = T_world_lidar.inverse();
  for (int i = 0; i < 8000; ++i) p_lidar.push_back(T_lidar_world * Vec3(20 * u(rng), 20 * u(rng), noise(rng)));
  for (int i = 0; i < 6000; ++i)  // a wall, a lot of points
    p_lidar.push_back(T_lidar_world * Vec3(6 + noise(rng), 15 * u(rng), 4 + 4 * u(rng)));
  const GroundPlane g = fit_ground_plane(p_lidar, GlobalInitConfig{});
  ASSERT_TRUE(g.valid);
  const Vec3 n_true = T_lidar_world.linear() * Vec3::UnitZ();
  EXPECT_LT(std::acos(std::min(1.0, g.normal.dot(n_true))) * kDegPerRad, 0.2);
  EXPECT_NEAR(g.height_m, 1.85, 0.02);
  const Mat3 R = levelling_rotation(g.normal);
  EXPECT_LT((R * g.normal - Vec3::UnitZ()).norm(), 1e-9);
}

// Planar motions A (INS) and B = X^-1 A X (levelled LiDAR) for a known planar X.
std::vector<MotionPair> synthetic_pairs(const Iso3& X, int n, bool turning, std::mt19937& rng, double noise_m) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, noise_m);
  std::vector<MotionPair> pairs;
  for (int i = 0; i < n; ++i) {
    const double turn_deg = turning ? 25 * u(rng) : 0.5 * u(rng);
    const double heading = turn_deg * 0.5 * kRadPerDeg;
    const double dist = 1.0 + u(rng);
    Iso3 A = make_transform({dist * std::cos(heading), dist * std::sin(heading), 0.02 * u(rng)},
                            {0.3 * u(rng), 0.3 * u(rng), turn_deg});
    Iso3 B = X.inverse() * A * X;
    B.translation() += Vec3(noise(rng), noise(rng), noise(rng));
    pairs.push_back({A, B});
  }
  return pairs;
}

TEST(PlanarHandEye, RecoversYawAndLeverArmWithOutliers) {
  std::mt19937 rng(3);
  for (double yaw_deg : {-170.0, -60.0, 10.0, 95.0, 179.0}) {
    const Iso3 X = make_transform({0.8, -0.45, 0.9}, {0, 0, yaw_deg});
    std::vector<MotionPair> pairs = synthetic_pairs(X, 20, true, rng, 0.01);
    // Two gross registration failures: a wrong translation and a wrong turn.
    pairs[3].T_lev0_lev1.translation() += Vec3(1.0, -0.7, 0);
    pairs[7].T_lev0_lev1.linear() = pairs[7].T_lev0_lev1.linear() * make_transform({0, 0, 0}, {0, 0, 8}).linear();
    const PlanarHandEyeResult he = solve_planar_hand_eye(pairs, 0.9);
    ASSERT_TRUE(he.valid);
    EXPECT_TRUE(he.lever_arm_observed);
    EXPECT_FALSE(he.inlier[3]);
    EXPECT_FALSE(he.inlier[7]);
    EXPECT_LT(std::abs(std::remainder(he.yaw_rad * kDegPerRad - yaw_deg, 360.0)), 0.5) << yaw_deg;
    EXPECT_LT((he.t_xy_m - Eigen::Vector2d(0.8, -0.45)).norm(), 0.03) << yaw_deg;
  }
}

TEST(PlanarHandEye, StraightDrivingGivesYawButNotLeverArm) {
  std::mt19937 rng(5);
  const Iso3 X = make_transform({0.8, -0.45, 0.9}, {0, 0, 135});
  const PlanarHandEyeResult he = solve_planar_hand_eye(synthetic_pairs(X, 10, false, rng, 0.01), 0.9);
  ASSERT_TRUE(he.valid);
  EXPECT_FALSE(he.lever_arm_observed);
  EXPECT_LT(std::abs(std::remainder(he.yaw_rad * kDegPerRad - 135.0, 360.0)), 1.0);
  EXPECT_EQ(he.t_xy_m, Eigen::Vector2d::Zero());
}

TEST(OccupancyScore, CountsVoxels) {
  const std::vector<Vec3> pts = {Vec3(0.1, 0.1, 0.1), Vec3(0.2, 0.2, 0.2), Vec3(-0.1, 0.1, 0.1)};
  EXPECT_EQ(occupancy_score(pts, 0.5), 2.0);
}

}  // namespace
}  // namespace insalign
