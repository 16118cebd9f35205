// Stage 3 on small in-process drives: a flat ground with a few boxes (walls, a parked car), a
// spinning LiDAR ray-cast from its true pose at every firing instant, INS poses with a little noise,
// surveyed fiducials with 5 mm noise. Every test starts from the true extrinsic with tz off by
// 0.3 m plus the small rotation and xy errors that stage 2 leaves (0.01 deg, 5 mm).
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <memory>
#include <random>

#include "core/z_surface.hpp"
#include "core/zcorrect.hpp"
#include "test_world.hpp"

namespace insalign {
namespace {

constexpr double kInsHeight_m = 0.9;  // INS origin above the ground

/// The LiDAR's downward beams.
struct Beams {
  int count = 16;
  double lowest_deg = -24.0, step_deg = 22.0 / 15.0;
};

/// A small figure-8 (12 m half-width, about 4 m/s) past a wall, a car and a pillar, seen by the
/// downward beams at 1 deg of azimuth with 2 cm range noise; 100 Hz poses with 5 mm and 0.005 deg
/// noise; six fiducials on the ground, one next to the wall, with 5 mm survey noise.
testing::TestDrive make_drive(unsigned seed, double duration_s = 25.0, Beams beams = {}) {
  testing::WorldSpec spec;
  spec.scene = testing::ground_scene();
  spec.drive = {.kind = testing::Drive::kFigure8, .half_width_m = 12.0, .loop_s = 24.5, .sway_rad = 0.015,
                .ins_height_m = kInsHeight_m};
  spec.lidar = {.rings = beams.count, .lowest_deg = beams.lowest_deg,
                .highest_deg = beams.lowest_deg + beams.step_deg * (beams.count - 1), .columns = 360,
                .max_range_m = 60.0, .noise_m = 0.02};
  spec.T_ins_lidar = make_transform(Vec3(0.25, -0.4, 1.1), Vec3(0.8, -1.2, 91.0));
  spec.frames = static_cast<int>(std::lround(duration_s * 10));
  spec.t0_s = 0.0;
  spec.pose_noise_m = 0.005;
  spec.pose_noise_deg = 0.005;
  spec.fiducial_spots = {{4.0, 3.5, 0}, {-6.0, -2.0, 0}, {11.0, -4.0, 0}, {-11.0, 5.0, 0}, {1.0, 8.0, 0}, {7.0, -7.5, 0}};
  spec.seed = seed;
  return testing::make_test_drive(spec);
}

/// What stage 2 leaves: tz 0.3 m off, 0.01 deg and 5 mm elsewhere.
Iso3 stage2_like(const Iso3& T_true) {
  Iso3 T = T_true;
  T.linear() = T.linear() * so3_exp(Vec3(0.01, -0.007, 0.007) * kRadPerDeg);
  T.translation() += Vec3(0.005, -0.004, 0.3);
  return T;
}

double tz_error(const ZResult& r, const Iso3& T_true) {
  return r.T_ins_lidar.translation().z() - T_true.translation().z();
}

TEST(ZCorrect, RecoversTzFromSixFiducials) {
  const testing::TestDrive drive = make_drive(11);
  const Iso3 T_start = stage2_like(drive.T_ins_lidar_true);
  const ZResult r = correct_z(testing::store_of(drive.data), T_start, 0.0, std::nullopt);
  ASSERT_TRUE(r.determined()) << r.outcome.message;
  EXPECT_EQ(r.method, ZMethod::kFiducials);
  EXPECT_LT(std::abs(tz_error(r, drive.T_ins_lidar_true)), 0.02) << r.outcome.message;
  EXPECT_NEAR(r.dz_m, -0.3, 0.02);
  EXPECT_GT(r.tz_stddev_m(), 0.0);
  EXPECT_LT(r.tz_stddev_m(), 0.02);
  // Only tz changes.
  EXPECT_TRUE(r.T_ins_lidar.linear().isApprox(T_start.linear()));
  EXPECT_NEAR((r.T_ins_lidar.translation() - T_start.translation()).head<2>().norm(), 0.0, 1e-12);
  ASSERT_EQ(r.fiducials.size(), 6u);
  for (const FiducialResidual& f : r.fiducials) {
    EXPECT_TRUE(f.used) << f.id << ": " << f.reason_rejected;
    EXPECT_NEAR(f.residual_before_m, -0.3, 0.05) << f.id;
    EXPECT_LT(std::abs(f.residual_after_m), 0.03) << f.id;
    EXPECT_GE(f.map_points, 10u) << f.id;
  }
  EXPECT_LT(r.outcome.wall_time_s, 0.5);
}

// The pipeline measures tz before and after stage 2, whose extrinsic and time offset differ a
// little: the second run reads the raw points the first kept instead of decoding the sweeps
// again, and gets the same answer as a fresh run.
TEST(ZCorrect, SecondRunReusesTheRawPointsTheFirstKept) {
  testing::TestDrive drive = make_drive(11);
  auto decoded = std::make_shared<std::atomic<int>>(0);
  drive.data.frames.load = [load = drive.data.frames.load, decoded](std::size_t i) {
    ++*decoded;
    return load(i);
  };
  const FrameStore store = testing::store_of(drive.data);
  const Iso3 T_early = stage2_like(drive.T_ins_lidar_true);
  Iso3 T_late = T_early;  // what stage 2 changes: a few mm, a few thousandths of a degree, the offset
  T_late.linear() = T_late.linear() * so3_exp(Vec3(0.004, 0.0, -0.003) * kRadPerDeg);
  T_late.translation() += Vec3(0.003, -0.002, 0.0);
  const double offset_late_s = 0.004;
  NearPoints near;
  ASSERT_TRUE(correct_z(store, T_early, 0.0, std::nullopt, {}, &near).determined());
  const int first = decoded->exchange(0);
  EXPECT_GT(first, 10);
  const ZResult kept = correct_z(store, T_late, offset_late_s, std::nullopt, {}, &near);
  EXPECT_EQ(decoded->exchange(0), 0);
  const ZResult fresh = correct_z(store, T_late, offset_late_s, std::nullopt);
  EXPECT_EQ(decoded->load(), first);
  ASSERT_TRUE(fresh.determined()) << fresh.outcome.message;
  EXPECT_EQ(kept.dz_m, fresh.dz_m);
  EXPECT_EQ(kept.tz_stddev_m(), fresh.tz_stddev_m());
  ASSERT_EQ(kept.fiducials.size(), fresh.fiducials.size());
  for (std::size_t f = 0; f < kept.fiducials.size(); ++f) EXPECT_EQ(kept.fiducials[f].map_points, fresh.fiducials[f].map_points);
  // A change beyond the kept margin (a 1 s clock offset moves every point metres) decodes again.
  correct_z(store, T_late, 1.0, std::nullopt, {}, &near);
  EXPECT_GT(decoded->load(), 0);
}

TEST(ZCorrect, NearestNeighbourMatchAlsoWorks) {
  const testing::TestDrive drive = make_drive(12);
  ZConfig config;
  config.match = FiducialMatch::kNearestNeighbour;
  const ZResult r = correct_z(testing::store_of(drive.data), stage2_like(drive.T_ins_lidar_true), 0.0, std::nullopt, config);
  ASSERT_TRUE(r.determined()) << r.outcome.message;
  EXPECT_LT(std::abs(tz_error(r, drive.T_ins_lidar_true)), 0.03) << r.outcome.message;
}

TEST(ZCorrect, FlagsAFiducialOffByHalfAMetre) {
  testing::TestDrive drive = make_drive(13);
  drive.data.fiducials[2].p_world.z() += 0.5;  // mistyped survey
  const ZResult r = correct_z(testing::store_of(drive.data), stage2_like(drive.T_ins_lidar_true), 0.0, std::nullopt);
  ASSERT_TRUE(r.determined()) << r.outcome.message;
  EXPECT_LT(std::abs(tz_error(r, drive.T_ins_lidar_true)), 0.015) << r.outcome.message;
  ASSERT_EQ(r.fiducials.size(), 6u);
  for (const FiducialResidual& f : r.fiducials) {
    if (f.id == "F3") {
      EXPECT_FALSE(f.used);
      EXPECT_NE(f.reason_rejected.find("outlier"), std::string::npos) << f.reason_rejected;
      EXPECT_NEAR(f.residual_after_m, 0.5, 0.05);
    } else {
      EXPECT_TRUE(f.used) << f.id << ": " << f.reason_rejected;
    }
  }
  EXPECT_NE(r.outcome.message.find("F3"), std::string::npos) << r.outcome.message;
}

TEST(ZCorrect, FewerThanThreeUsableFiducialsIsNotDetermined) {
  testing::TestDrive drive = make_drive(14);
  drive.data.fiducials.resize(4);
  drive.data.fiducials[0].p_world = Vec3(500.0, 500.0, 0.0);  // never seen
  drive.data.fiducials[3].p_world = Vec3(-400.0, 20.0, 0.0);
  const Iso3 T_start = stage2_like(drive.T_ins_lidar_true);
  const ZResult r = correct_z(testing::store_of(drive.data), T_start, 0.0, std::nullopt);
  EXPECT_FALSE(r.determined());
  EXPECT_EQ(r.method, ZMethod::kNone);
  EXPECT_TRUE(r.T_ins_lidar.isApprox(T_start));
  EXPECT_EQ(r.dz_m, 0.0);
  EXPECT_NE(r.outcome.message.find("only 2 of 4"), std::string::npos) << r.outcome.message;
  EXPECT_NE(r.outcome.message.find("F1"), std::string::npos) << r.outcome.message;
  EXPECT_NE(r.outcome.message.find("F4"), std::string::npos) << r.outcome.message;
  EXPECT_NE(r.outcome.message.find("initial value"), std::string::npos) << r.outcome.message;
  for (const FiducialResidual& f : r.fiducials) {
    EXPECT_FALSE(f.used);
    EXPECT_FALSE(f.reason_rejected.empty()) << f.id;  // the measured ones too: why they were not used
  }
}

// A LiDAR with 2 deg between rings (VLP-16: the lowest at -15 deg; here 2 m above the ground)
// meets the ground only on circles 7.5 m and farther out, so most of the nearest frames see
// nothing at a fiducial. Stage 3 then takes farther frames for it until enough of them see it.
TEST(ZCorrect, SparseRingsStillSeeTheFiducials) {
  const testing::TestDrive drive = make_drive(17, 25.0, Beams{.count = 8, .lowest_deg = -15.0, .step_deg = 2.0});
  const Iso3 T_start = stage2_like(drive.T_ins_lidar_true);
  ZConfig one_round;  // at most frames_per_fiducial frames, the nearest
  one_round.max_frames_per_fiducial = one_round.frames_per_fiducial;
  const ZResult nearest_only = correct_z(testing::store_of(drive.data), T_start, 0.0, std::nullopt, one_round);
  const ZResult r = correct_z(testing::store_of(drive.data), T_start, 0.0, std::nullopt);
  auto used = [](const ZResult& z) {
    return std::count_if(z.fiducials.begin(), z.fiducials.end(), [](const FiducialResidual& f) { return f.used; });
  };
  std::printf("fiducials used: nearest frames only %d, with farther rounds %d (%zu frames loaded)\n",
              int(used(nearest_only)), int(used(r)), r.frames_loaded);
  ASSERT_TRUE(r.determined()) << r.outcome.message;
  EXPECT_GT(used(r), used(nearest_only));
  EXPECT_LT(std::abs(tz_error(r, drive.T_ins_lidar_true)), 0.02) << r.outcome.message;
  EXPECT_LE(r.frames_loaded, 6 * ZConfig{}.max_frames_per_fiducial);
}

TEST(ZCorrect, HeightPriorRecoversTz) {
  testing::TestDrive drive = make_drive(15);
  drive.data.fiducials.clear();
  const ZResult r = correct_z(testing::store_of(drive.data), stage2_like(drive.T_ins_lidar_true), 0.0, kInsHeight_m + 0.01);
  ASSERT_TRUE(r.determined()) << r.outcome.message;
  EXPECT_EQ(r.method, ZMethod::kInsHeight);
  EXPECT_LT(std::abs(tz_error(r, drive.T_ins_lidar_true)), 0.02) << r.outcome.message;
  EXPECT_GE(r.height_samples_used, 10u) << r.outcome.message;
  EXPECT_LT(r.outcome.wall_time_s, 0.5);
}

// The same sparse LiDAR does not see the ground under the INS from the nearest frames 3 m away
// either: the height prior then stitches in frames from farther along the drive.
TEST(ZCorrect, HeightPriorWithSparseRings) {
  testing::TestDrive drive = make_drive(18, 25.0, Beams{.count = 8, .lowest_deg = -15.0, .step_deg = 2.0});
  drive.data.fiducials.clear();
  const ZResult r = correct_z(testing::store_of(drive.data), stage2_like(drive.T_ins_lidar_true), 0.0, kInsHeight_m);
  ASSERT_TRUE(r.determined()) << r.outcome.message;
  EXPECT_LT(std::abs(tz_error(r, drive.T_ins_lidar_true)), 0.02) << r.outcome.message;
  EXPECT_GE(r.height_samples_used, 8u) << r.outcome.message;
}

TEST(ZCorrect, HeightPriorIsTheFallbackWhenFiducialsAreUnusable) {
  testing::TestDrive drive = make_drive(16);
  for (auto& f : drive.data.fiducials) f.p_world.x() += 1000.0;
  const ZResult r = correct_z(testing::store_of(drive.data), stage2_like(drive.T_ins_lidar_true), 0.0, kInsHeight_m);
  ASSERT_TRUE(r.determined()) << r.outcome.message;
  EXPECT_EQ(r.method, ZMethod::kInsHeight);
  EXPECT_NE(r.outcome.message.find("fiducials"), std::string::npos) << r.outcome.message;
  EXPECT_LT(std::abs(tz_error(r, drive.T_ins_lidar_true)), 0.02) << r.outcome.message;
}

TEST(ZCorrect, NeitherFiducialsNorHeightKeepsTz) {
  testing::TestDrive drive = make_drive(17, 1.0);
  drive.data.fiducials.clear();
  const Iso3 T_start = stage2_like(drive.T_ins_lidar_true);
  const ZResult r = correct_z(testing::store_of(drive.data), T_start, 0.0, std::nullopt);
  EXPECT_FALSE(r.determined());
  EXPECT_EQ(r.method, ZMethod::kNone);
  EXPECT_TRUE(r.T_ins_lidar.isApprox(T_start));
  EXPECT_NE(r.outcome.message.find("no fiducials and no --ins-height-m"), std::string::npos) << r.outcome.message;
  EXPECT_NE(r.outcome.message.find("kept at the initial value"), std::string::npos) << r.outcome.message;
  EXPECT_EQ(r.frames_loaded, 0u);
}

}  // namespace
}  // namespace insalign
