// A LiDAR's sweeps registered to another LiDAR's map (core/map_registration.hpp): a start
// 5 deg / 30 cm off comes back to the truth, the fit measure tells the two apart, and a map the
// sweeps do not share finds nothing.
#include <gtest/gtest.h>

#include "core/map_registration.hpp"
#include "core/stitch.hpp"
#include "test_world.hpp"

namespace insalign {
namespace {

testing::WorldSpec spec_with(const Iso3& T_ins_lidar, unsigned seed) {
  testing::WorldSpec spec;
  spec.frames = 80;
  spec.T_ins_lidar = T_ins_lidar;
  spec.seed = seed;
  return spec;
}

// A roof LiDAR and a right-mirror one, tilted down, on one drive (the stores read the drives in place).
struct TwoLidars {
  testing::TestDrive roof = testing::make_test_drive(spec_with(testing::roof_mount(30.0), 1));
  testing::TestDrive other = testing::make_test_drive(spec_with(make_transform(Vec3(1.6, -0.9, 0.2), Vec3(0.0, 15.0, -75.0)), 2));
  FrameStore roof_store = testing::store_of(roof.data), other_store = testing::store_of(other.data);
};

std::vector<Vec3f> roof_map(const TwoLidars& t, const Vec3& shift = Vec3::Zero()) {
  std::vector<Vec3f> map = stitch_map(t.roof_store, spread_frames(t.roof_store, 40), t.roof.T_ins_lidar_true, 0.0, 0.2);
  for (Vec3f& p : map) p += shift.cast<float>();
  return map;
}

TEST(MapRegistration, AStartDegreesOffComesBackToTheTruth) {
  const TwoLidars t;
  const Iso3 start = testing::perturbed(t.other.T_ins_lidar_true, 5.0, 0.3, 4);
  const MapRegistration registration(t.other_store, roof_map(t), 0.0);
  const MapRegistrationResult r = registration.solve(start);
  const ExtrinsicError e = extrinsic_error(r.T_ins_lidar, t.other.T_ins_lidar_true);
  std::printf("from 5 deg / 30 cm: %.4f deg, %.1f %.1f %.1f mm in %d iterations; RMS %.1f -> %.1f mm, inliers %.2f -> %.2f\n",
              e.angle_deg, 1e3 * e.dt_m.x(), 1e3 * e.dt_m.y(), 1e3 * e.dt_m.z(), r.iterations, 1e3 * r.start.rms_m,
              1e3 * r.end.rms_m, r.start.inlier_ratio(), r.end.inlier_ratio());
  EXPECT_TRUE(r.converged);
  EXPECT_LT(e.angle_deg, 0.05);
  EXPECT_LT(e.dt_m.norm(), 0.01);
  EXPECT_LT(5.0 * r.end.rms_m, r.start.rms_m);
  // The fit measure at the truth is the solution's, at the start the start's.
  EXPECT_NEAR(registration.fit(t.other.T_ins_lidar_true).rms_m, r.end.rms_m, 0.2 * r.end.rms_m);
  EXPECT_DOUBLE_EQ(registration.fit(start).rms_m, r.start.rms_m);
}

TEST(MapRegistration, AMapTheSweepsDoNotShareFindsNothing) {
  const TwoLidars t;
  const MapRegistration registration(t.other_store, roof_map(t, Vec3(500.0, 0.0, 0.0)), 0.0);
  const MapRegistrationResult r = registration.solve(t.other.T_ins_lidar_true);
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.end.inliers, 0u);
  EXPECT_TRUE(r.T_ins_lidar.isApprox(t.other.T_ins_lidar_true));
}

}  // namespace
}  // namespace insalign
