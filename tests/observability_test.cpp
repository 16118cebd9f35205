#include "core/observability.hpp"

#include <gtest/gtest.h>

#include "core/rough.hpp"
#include "test_world.hpp"

namespace insalign {
namespace {

using testing::Drive;

std::array<bool, 6> flags(std::initializer_list<int> undetermined) {
  std::array<bool, 6> d{true, true, true, true, true, true};
  for (int i : undetermined) d[i] = false;
  return d;
}

std::string describe_flags(const DofVerdict& v) {
  std::string s;
  for (int i = 0; i < 6; ++i) s += std::string(kDofNames[i]) + (v.determined[i] ? "=det " : "=UNDET ");
  return s + "| " + v.explanation;
}

TEST(Observability, FlagsTheWeakDirectionOfAnInformationMatrix) {
  // 1e6 residuals of 2 cm: strong everywhere except tz (translation lever 1, rotation lever 10 m).
  Mat6 H = Mat6::Identity() * 1e6;
  H.bottomRightCorner<3, 3>() *= 100.0;
  H(2, 2) = 1e-3;
  const DofVerdict v = assess_observability(H, 0.02, 1e6);
  EXPECT_EQ(v.determined, flags({2})) << describe_flags(v);
  EXPECT_FALSE(unobservable_reason(v).has_value()) << "tz alone is not fatal";
  EXPECT_TRUE(std::isinf(v.stddev(2)));
  EXPECT_NEAR(v.stddev(0), 0.02 / 1e3, 1e-9);  // sigma * sqrt(1 / 1e6)

  // Two DOFs that only move together (tx and yaw seen only as tx + 5 m * yaw): one must go.
  Eigen::Matrix<double, 6, 1> j = Eigen::Matrix<double, 6, 1>::Zero();
  j(0) = 1.0;
  j(5) = 5.0;
  Mat6 H2 = Mat6::Identity() * 1e6;
  H2.bottomRightCorner<3, 3>() *= 100.0;
  H2(0, 0) = H2(5, 5) = 0.0;
  H2 += 1e6 * j * j.transpose();
  const DofVerdict v2 = assess_observability(H2, 0.02, 1e6);
  EXPECT_NE(v2.determined[0], v2.determined[5]) << describe_flags(v2);
  EXPECT_TRUE(unobservable_reason(v2).has_value());

  const DofVerdict none = assess_observability(Mat6::Zero(), 0.02, 1e6);
  EXPECT_EQ(none.determined, flags({0, 1, 2, 3, 4, 5}));
  ASSERT_TRUE(unobservable_reason(none).has_value());
  EXPECT_NE(unobservable_reason(none)->find("standing still"), std::string::npos);
}

TEST(Observability, LeverageTestRejectsADirectionOnlyNoiseAveragingDetermines) {
  // tz is excited with a tiny lever (0.5 mm per cm) but by 1e8 residuals: the noise test
  // passes, the leverage test must not.
  Mat6 H = Mat6::Identity() * 1e8;
  H(2, 2) = 1e8 * 0.05 * 0.05 * 1e-4;  // RMS shift per metre of tz: 5e-4 m
  EXPECT_TRUE(assess_observability(H, 0.02).determined[2]);
  EXPECT_FALSE(assess_observability(H, 0.02, 1e8).determined[2]);
}

struct Case {
  const char* name;
  Drive drive;
  bool ground_only;
  int frames;
  std::array<bool, 6> expected;
  bool fatal;
};

class DriveVerdict : public ::testing::TestWithParam<Case> {};

TEST_P(DriveVerdict, FlagsTheRightDegreesOfFreedom) {
  const Case& c = GetParam();
  testing::Scene scene = testing::town_scene(3);
  if (c.ground_only) scene.boxes.clear();
  const auto drive = testing::town_drive(c.drive, testing::roof_mount(60.0), c.frames, 5, scene);
  const Iso3 init = testing::perturbed(drive.T_ins_lidar_true, 1.0, 0.05, 9);
  const FrameStore store = testing::store_of(drive.data);
  const RoughResult r = calibrate_rough(store, rough_frame_groups(store), init, 0.0);
  EXPECT_EQ(r.observability.determined, c.expected) << c.name << ": " << describe_flags(r.observability);
  EXPECT_EQ(unobservable_reason(r.observability).has_value(), c.fatal) << c.name;
  EXPECT_EQ(r.outcome.status == StageStatus::kUndetermined, c.fatal) << c.name;
  EXPECT_FALSE(r.observability.explanation.empty());
  EXPECT_FALSE(r.tz_estimated);
}

INSTANTIATE_TEST_SUITE_P(
    Drives, DriveVerdict,
    ::testing::Values(Case{"figure8", Drive::kFigure8, false, 240, flags({2}), false},
                      Case{"standstill", Drive::kStandstill, false, 40, flags({0, 1, 2, 3, 4, 5}), true},
                      Case{"straight", Drive::kStraight, false, 80, flags({0, 1, 2, 3}), true},
                      Case{"ground_only", Drive::kFigure8, true, 240, flags({0, 1, 2, 5}), true}),
    [](const ::testing::TestParamInfo<Case>& info) { return std::string(info.param.name); });

}  // namespace
}  // namespace insalign
