// The pose-only pre-check: standing still, driving straight and too little turning must be called
// out in words a person understands; a figure-8 passes; the real 5-sweep sample is a standstill.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <random>

#include "core/motion_check.hpp"
#include "files/poses.hpp"

namespace insalign {
namespace {

/// 100 Hz poses of a vehicle path with INS-like noise (1 cm position, 0.01/0.03 deg attitude) and
/// 10 Hz frames over the same span.
struct Drive {
  PoseStream poses;
  std::vector<FrameInfo> frames;
};

template <class PathFn>
Drive make_drive(PathFn path, double duration_s, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  std::vector<StampedPose> poses;
  for (int k = 0; k * 0.01 <= duration_s + 0.2; ++k) {
    const double t = 1000.0 + k * 0.01;
    const auto [p, yaw] = path(t - 1000.0);
    Iso3 T = Iso3::Identity();
    T.linear() = rotation_from_rpy(Vec3(0.01 * n01(rng), 0.01 * n01(rng), yaw + 0.03 * n01(rng)) * kRadPerDeg);
    T.translation() = p + 0.01 * Vec3(n01(rng), n01(rng), n01(rng));
    poses.push_back({t, T});
  }
  Drive d;
  d.poses = PoseStream(std::move(poses));
  for (int k = 1; k * 0.1 <= duration_s + 1e-9; ++k) d.frames.push_back({std::to_string(k), 1000.0 + k * 0.1});
  return d;
}

TEST(MotionCheck, StandstillFailsWithAPlainReason) {
  const Drive d = make_drive([](double) { return std::pair{Vec3(3, 4, 1), 30.0}; }, 60.0, 1);
  const MotionCheck m = check_motion(d.poses, d.frames);
  EXPECT_FALSE(m.ok);
  EXPECT_FALSE(m.rotation_determined);
  EXPECT_FALSE(m.lever_arm_xy_determined);
  EXPECT_LT(m.distance_m, 5.0);  // pose noise must not add up to a drive
  EXPECT_LT(m.heading_change_deg, 20.0);
  EXPECT_NEAR(m.duration_s, 59.9, 0.11);
  EXPECT_NE(m.explanation.find("moved only"), std::string::npos) << m.explanation;
  EXPECT_NE(m.explanation.find("standing still"), std::string::npos) << m.explanation;
  EXPECT_NE(m.explanation.find("figure-8"), std::string::npos) << m.explanation;
}

TEST(MotionCheck, StraightDriveFailsNamingTheLeverArm) {
  const Drive d = make_drive([](double t) { return std::pair{Vec3(4.0 * t, 0.5 * t, 1), 7.1}; }, 30.0, 2);
  const MotionCheck m = check_motion(d.poses, d.frames);
  EXPECT_FALSE(m.ok);
  EXPECT_NEAR(m.distance_m, 30.0 * std::hypot(4.0, 0.5), 3.0);
  EXPECT_NEAR(m.max_speed_mps, std::hypot(4.0, 0.5), 0.3);
  EXPECT_LT(m.lever_arm_sensitivity, 0.05);
  EXPECT_FALSE(m.lever_arm_xy_determined);
  EXPECT_NE(m.explanation.find("turned only"), std::string::npos) << m.explanation;
  EXPECT_NE(m.explanation.find("lever arm x, y is not determined"), std::string::npos) << m.explanation;
  EXPECT_NE(m.explanation.find("roll"), std::string::npos) << m.explanation;
}

TEST(MotionCheck, GentleCurveIsNotEnoughTurning) {
  // 20 deg of heading change over 100 m: one lane bend, not a turn.
  const Drive d = make_drive(
      [](double t) {
        const double r = 286.0, psi = 5.0 * t / r;  // 5 m/s on a 286 m radius
        return std::pair{Vec3(r * std::sin(psi), r * (1 - std::cos(psi)), 1), psi * kDegPerRad};
      },
      20.0, 3);
  const MotionCheck m = check_motion(d.poses, d.frames);
  EXPECT_FALSE(m.ok);
  EXPECT_NEAR(m.heading_spread_deg, 20.0, 1.5);
  EXPECT_LT(m.lever_arm_sensitivity, 0.35);
  EXPECT_NE(m.explanation.find("turned only"), std::string::npos) << m.explanation;
}

TEST(MotionCheck, FigureEightPasses) {
  const Drive d = make_drive(
      [](double t) {
        const double a = 15.0, w = 4.0 / (1.3 * a), u = w * t;
        const Vec3 v(a * w * std::cos(u), a * w * std::cos(2.0 * u), 0.0);
        return std::pair{Vec3(a * std::sin(u), a * std::sin(u) * std::cos(u), 1.0),
                         std::atan2(v.y(), v.x()) * kDegPerRad};
      },
      60.0, 4);
  const MotionCheck m = check_motion(d.poses, d.frames);
  EXPECT_TRUE(m.ok) << m.explanation;
  EXPECT_TRUE(m.rotation_determined);
  EXPECT_TRUE(m.lever_arm_xy_determined);
  EXPECT_GT(m.distance_m, 150.0);
  EXPECT_GT(m.heading_change_deg, 400.0);
  EXPECT_GT(m.heading_spread_deg, 180.0);
  EXPECT_GT(m.lever_arm_sensitivity, 0.8);
  EXPECT_NE(m.explanation.find("tz needs fiducials"), std::string::npos) << m.explanation;
}

TEST(MotionCheck, OnlyTheFramesTimeSpanCounts) {
  // A figure-8 of poses, but frames only during the first 0.5 s: a standstill for the calibration.
  Drive d = make_drive(
      [](double t) {
        const double a = 15.0, w = 4.0 / (1.3 * a), u = w * t;
        return std::pair{Vec3(a * std::sin(u), a * std::sin(u) * std::cos(u), 1.0), u * 30.0};
      },
      60.0, 5);
  d.frames.resize(5);
  const MotionCheck m = check_motion(d.poses, d.frames);
  EXPECT_FALSE(m.ok);
  EXPECT_NEAR(m.duration_s, 0.4, 1e-9);
  EXPECT_LT(m.distance_m, 2.0);
}

TEST(MotionCheck, EmptyInputsAreNotOk) {
  const MotionCheck m = check_motion(PoseStream{}, {});
  EXPECT_FALSE(m.ok);
  EXPECT_FALSE(m.explanation.empty());
}

TEST(MotionCheck, RealSampleIsAStandstill) {
  const std::filesystem::path dir = std::filesystem::path(INSALIGN_SHARED_DATA_DIR) / "opencalib-sample";
  if (!std::filesystem::exists(dir / "NovAtel-pose-lidar-time.txt")) {
    GTEST_SKIP() << "real sample not found in " << dir;
  }
  const io::PoseFile file = io::read_pose_file(dir / "NovAtel-pose-lidar-time.txt");
  ASSERT_EQ(file.frame_names.size(), file.T_world_ins.size());
  std::vector<StampedPose> stamped;
  std::map<std::string, double> time_of;
  for (std::size_t i = 0; i < file.T_world_ins.size(); ++i) {
    ASSERT_TRUE(std::isfinite(file.t_s[i])) << file.frame_names[i];
    stamped.push_back({file.t_s[i], file.T_world_ins[i]});
    time_of[file.frame_names[i]] = file.t_s[i];
  }
  std::vector<FrameInfo> frames;
  for (const auto& entry : std::filesystem::directory_iterator(dir / "top_center_lidar")) {
    if (entry.path().extension() != ".pcd") continue;
    const std::string name = entry.path().stem().string();
    ASSERT_TRUE(time_of.count(name)) << name;
    frames.push_back({name, time_of[name]});
  }
  std::sort(frames.begin(), frames.end(), [](const auto& a, const auto& b) { return a.t_end_s < b.t_end_s; });
  ASSERT_EQ(frames.size(), 5u);
  const MotionCheck m = check_motion(PoseStream(std::move(stamped)), frames);
  EXPECT_FALSE(m.ok);
  EXPECT_LT(m.distance_m, 0.001);
  EXPECT_NEAR(m.duration_s, 0.4, 0.01);
  EXPECT_NE(m.explanation.find("mm over the 0.4 s of 5 frames"), std::string::npos) << m.explanation;
  EXPECT_NE(m.explanation.find("standing still"), std::string::npos) << m.explanation;
  std::cout << "real sample: " << m.explanation << "\n";
}

}  // namespace
}  // namespace insalign
