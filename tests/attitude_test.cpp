// The attitude conventions of inslog/attitude.hpp against vehicle axes built from first principles
// (ins_log_test_util.hpp): heading, then pitch about the right axis (nose up), then roll about the
// forward axis (right side down).
#include <gtest/gtest.h>

#include <random>

#include "ins_log_test_util.hpp"
#include "inslog/attitude.hpp"

namespace insalign::io {
namespace {

using test::vehicle_axes;

void expect_near(const Vec3& a, const Vec3& b, double tol = 1e-12) {
  EXPECT_LT((a - b).norm(), tol) << a.transpose() << " vs " << b.transpose();
}

struct Direction {
  const char* name;
  double heading_cw_deg;  // from north
  Vec3 forward_enu;
};
const Direction kDirections[] = {{"north", 0.0, {0, 1, 0}}, {"east", 90.0, {1, 0, 0}},
                                 {"south", 180.0, {0, -1, 0}}, {"west", 270.0, {-1, 0, 0}}};

TEST(Attitude, NovatelForwardIsYDrivingNorthEastSouthWest) {
  for (const auto& d : kDirections) {
    SCOPED_TRACE(d.name);
    const Mat3 R = R_enu_ins_novatel(0.0, 0.0, d.heading_cw_deg);  // azimuth clockwise from north
    expect_near(R * Vec3::UnitY(), d.forward_enu);
    expect_near(R * Vec3::UnitZ(), Vec3::UnitZ());
    expect_near(R * Vec3::UnitX(), d.forward_enu.cross(Vec3::UnitZ()));  // x right
  }
}

TEST(Attitude, NedForwardIsXDrivingNorthEastSouthWest) {
  for (const auto& d : kDirections) {
    SCOPED_TRACE(d.name);
    const Mat3 R = R_enu_ins_ned(0.0, 0.0, d.heading_cw_deg);
    expect_near(R * Vec3::UnitX(), d.forward_enu);
    expect_near(R * Vec3::UnitZ(), -Vec3::UnitZ());                      // z down
    expect_near(R * Vec3::UnitY(), d.forward_enu.cross(Vec3::UnitZ()));  // y right
  }
}

TEST(Attitude, EnuForwardIsXDrivingNorthEastSouthWest) {
  for (const auto& d : kDirections) {
    SCOPED_TRACE(d.name);
    const Mat3 R = R_enu_ins_enu(0.0, 0.0, 90.0 - d.heading_cw_deg);  // yaw counter-clockwise from east
    expect_near(R * Vec3::UnitX(), d.forward_enu);
    expect_near(R * Vec3::UnitY(), Vec3::UnitZ().cross(d.forward_enu));  // y left
  }
  // KITTI's own words: yaw 0 = east.
  expect_near(R_enu_ins_enu(0, 0, 0) * Vec3::UnitX(), Vec3::UnitX());
}

TEST(Attitude, SbetTrueHeadingIsPlatformHeadingMinusWander) {
  for (const auto& d : kDirections) {
    SCOPED_TRACE(d.name);
    const double wander = 37.0;
    const Mat3 R = R_enu_ins_sbet(0.0, 0.0, d.heading_cw_deg + wander, wander);
    expect_near(R * Vec3::UnitX(), d.forward_enu);
  }
}

TEST(Attitude, PitchNoseUpAndRollRightSideDownSigns) {
  const double s10 = std::sin(10.0 * M_PI / 180.0);
  // NovAtel: pitch about x (right), positive nose up; roll about y (forward), positive right side down.
  EXPECT_NEAR((R_enu_ins_novatel(0, 10, 0) * Vec3::UnitY()).z(), s10, 1e-12);
  EXPECT_NEAR((R_enu_ins_novatel(10, 0, 0) * Vec3::UnitX()).z(), -s10, 1e-12);
  // NED: pitch positive nose up, roll positive right (y) side down.
  EXPECT_NEAR((R_enu_ins_ned(0, 10, 0) * Vec3::UnitX()).z(), s10, 1e-12);
  EXPECT_NEAR((R_enu_ins_ned(10, 0, 0) * Vec3::UnitY()).z(), -s10, 1e-12);
  // ENU (KITTI): pitch positive front down, roll positive left side up.
  EXPECT_NEAR((R_enu_ins_enu(0, 10, 0) * Vec3::UnitX()).z(), -s10, 1e-12);
  EXPECT_NEAR((R_enu_ins_enu(10, 0, 0) * Vec3::UnitY()).z(), s10, 1e-12);
}

TEST(Attitude, EveryConventionMatchesVehicleAxesBuiltFromFirstPrinciples) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> h(0, 360), a(-40, 40);
  for (int i = 0; i < 200; ++i) {
    const double heading = h(rng), pitch = a(rng), roll = a(rng);
    const auto axes = vehicle_axes(heading, pitch, roll);
    const Mat3 Rn = R_enu_ins_novatel(roll, pitch, heading);
    expect_near(Rn * Vec3::UnitY(), axes.forward, 1e-9);
    expect_near(Rn * Vec3::UnitX(), axes.right, 1e-9);
    expect_near(Rn * Vec3::UnitZ(), axes.up, 1e-9);
    const Mat3 Rd = R_enu_ins_ned(roll, pitch, heading);
    expect_near(Rd * Vec3::UnitX(), axes.forward, 1e-9);
    expect_near(Rd * Vec3::UnitY(), axes.right, 1e-9);
    expect_near(Rd * -Vec3::UnitZ(), axes.up, 1e-9);
    const Mat3 Re = R_enu_ins_enu(roll, -pitch, 90.0 - heading);  // ENU pitch is nose down
    expect_near(Re * Vec3::UnitX(), axes.forward, 1e-9);
    expect_near(Re * Vec3::UnitY(), -axes.right, 1e-9);
    expect_near(Re * Vec3::UnitZ(), axes.up, 1e-9);
  }
}

TEST(Attitude, AnglesOfEachConventionReproduceTheRotation) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 500; ++i) {
    const Mat3 R = Eigen::Quaterniond(u(rng), u(rng), u(rng), u(rng)).normalized().toRotationMatrix();
    const AttitudeDeg n = novatel_angles(R), d = ned_angles(R), e = enu_angles(R);
    EXPECT_LT(test::angle_deg(R_enu_ins_novatel(n.roll_deg, n.pitch_deg, n.heading_deg), R), 1e-9);
    EXPECT_LT(test::angle_deg(R_enu_ins_ned(d.roll_deg, d.pitch_deg, d.heading_deg), R), 1e-9);
    EXPECT_LT(test::angle_deg(R_enu_ins_enu(e.roll_deg, e.pitch_deg, e.heading_deg), R), 1e-9);
    EXPECT_GE(n.heading_deg, 0.0);
    EXPECT_LT(n.heading_deg, 360.0);
    EXPECT_GE(d.heading_deg, 0.0);
    EXPECT_LT(d.heading_deg, 360.0);
  }
  const AttitudeDeg west = ned_angles(R_enu_ins_ned(1.0, 2.0, 270.0));
  EXPECT_NEAR(west.heading_deg, 270.0, 1e-9);
  EXPECT_NEAR(west.pitch_deg, 2.0, 1e-9);
  EXPECT_NEAR(west.roll_deg, 1.0, 1e-9);
}

}  // namespace
}  // namespace insalign::io
