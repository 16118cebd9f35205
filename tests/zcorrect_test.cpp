// Stage 3 on small in-process drives: a flat ground with a few boxes (walls, a parked car), a
// spinning LiDAR ray-cast from its true pose at every firing instant, INS poses with a little noise,
// surveyed fiducials with 5 mm noise. Every test starts from the true extrinsic with tz off by
// 0.3 m plus the small rotation and xy errors that stage 2 leaves (0.01 deg, 5 mm).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/zcorrect.hpp"

namespace insalign {
namespace {

struct Box {
  Vec3 centre_m, half_m;
};

struct GroundScene {
  std::vector<Box> boxes;
  /// Nearest hit of the ray o + s d (d unit) with the ground z = 0 or a box; infinity if none.
  double cast(const Vec3& o, const Vec3& d) const {
    double best = std::numeric_limits<double>::infinity();
    if (d.z() < -1e-9) best = -o.z() / d.z();
    for (const Box& b : boxes) {
      double s_in = 0.0, s_out = best;
      for (int a = 0; a < 3 && s_in <= s_out; ++a) {
        const double lo = b.centre_m(a) - b.half_m(a), hi = b.centre_m(a) + b.half_m(a);
        if (std::abs(d(a)) < 1e-12) {
          if (o(a) < lo || o(a) > hi) s_in = s_out + 1.0;
          continue;
        }
        double s1 = (lo - o(a)) / d(a), s2 = (hi - o(a)) / d(a);
        if (s1 > s2) std::swap(s1, s2);
        s_in = std::max(s_in, s1), s_out = std::min(s_out, s2);
      }
      if (s_in <= s_out && s_in > 0.0) best = std::min(best, s_in);
    }
    return best;
  }
};

constexpr double kInsHeight_m = 0.9;  // INS origin above the ground

/// A figure-8 (Gerono lemniscate, 12 m half-width) at 4 m/s with a little roll and pitch.
Iso3 true_T_world_ins(double t_s) {
  const double a = 12.0, w = 4.0 / (1.3 * a), u = w * t_s;
  const Vec3 v(a * w * std::cos(u), a * w * std::cos(2.0 * u), 0.0);
  Iso3 T = Iso3::Identity();
  T.linear() = rotation_from_rpy(Vec3(0.015 * std::sin(2.1 * u), 0.012 * std::cos(1.7 * u), std::atan2(v.y(), v.x())));
  T.translation() = Vec3(a * std::sin(u), a * std::sin(u) * std::cos(u), kInsHeight_m);
  return T;
}

struct GroundDrive {
  Dataset data;
  Iso3 T_ins_lidar_true = Iso3::Identity();
};

/// The LiDAR's downward beams.
struct Beams {
  int count = 16;
  double lowest_deg = -24.0, step_deg = 22.0 / 15.0;
};

/// duration_s of frames at 10 Hz; by default 16 beams from -24 to -2 deg every 1 deg of azimuth,
/// 2 cm range noise. Poses at 100 Hz with 5 mm position and 0.005 deg attitude noise.
GroundDrive make_drive(std::uint64_t seed, double duration_s = 25.0, Beams beams = {}) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  GroundDrive drive;
  drive.T_ins_lidar_true = make_transform(Vec3(0.25, -0.4, 1.1), Vec3(0.8, -1.2, 91.0));
  GroundScene scene;
  scene.boxes = {{Vec3(0.0, 9.0, 1.5), Vec3(6.0, 0.3, 1.5)},     // a wall
                 {Vec3(-15.0, -4.0, 0.75), Vec3(2.2, 0.9, 0.75)},  // a parked car
                 {Vec3(16.0, 3.0, 2.0), Vec3(0.2, 0.2, 2.0)}};    // a pillar
  std::vector<StampedPose> poses;
  for (double t = -0.5; t <= duration_s + 0.5; t += 0.01) {
    Iso3 T = true_T_world_ins(t);
    T.translation() += 0.005 * Vec3(n01(rng), n01(rng), n01(rng));
    T.linear() = T.linear() * so3_exp(0.005 * kRadPerDeg * Vec3(n01(rng), n01(rng), n01(rng)));
    poses.push_back({t, T});
  }
  drive.data.poses = PoseStream(std::move(poses));
  const int n_columns = 360;
  std::vector<Sweep> sweeps;
  for (double t_end = 0.1; t_end <= duration_s + 1e-9; t_end += 0.1) {
    Sweep sweep;
    sweep.name = std::to_string(sweeps.size());
    sweep.t_end_s = t_end;
    for (int c = 0; c < n_columns; ++c) {
      const double dt = -0.1 + 0.1 * (c + 1) / n_columns;
      const Iso3 T_world_lidar = true_T_world_ins(t_end + dt) * drive.T_ins_lidar_true;
      const double az = 2.0 * M_PI * c / n_columns;
      for (int b = 0; b < beams.count; ++b) {
        const double el = (beams.lowest_deg + beams.step_deg * b) * kRadPerDeg;
        const Vec3 d_lidar(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
        const double s = scene.cast(T_world_lidar.translation(), T_world_lidar.linear() * d_lidar);
        if (!(s < 60.0)) continue;
        sweep.p_lidar.push_back(((s + 0.02 * n01(rng)) * d_lidar).cast<float>());
        sweep.dt_s.push_back(static_cast<float>(dt));
      }
    }
    sweeps.push_back(std::move(sweep));
  }
  drive.data.frames = frame_source_from(std::move(sweeps));
  // Fiducials on the ground along the path, one next to the wall, with 5 mm survey noise.
  const std::vector<Vec3> spots = {{4.0, 3.5, 0}, {-6.0, -2.0, 0}, {11.0, -4.0, 0},
                                   {-11.0, 5.0, 0}, {1.0, 8.0, 0},  {7.0, -7.5, 0}};
  for (std::size_t i = 0; i < spots.size(); ++i) {
    drive.data.fiducials.push_back(
        {"F" + std::to_string(i + 1), spots[i] + 0.005 * Vec3(n01(rng), n01(rng), n01(rng))});
  }
  return drive;
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
  const GroundDrive drive = make_drive(11);
  const Iso3 T_start = stage2_like(drive.T_ins_lidar_true);
  const ZResult r = correct_z(drive.data, T_start, 0.0, std::nullopt);
  ASSERT_TRUE(r.determined) << r.explanation;
  EXPECT_EQ(r.method, "fiducials");
  EXPECT_LT(std::abs(tz_error(r, drive.T_ins_lidar_true)), 0.02) << r.explanation;
  EXPECT_NEAR(r.dz_m, -0.3, 0.02);
  EXPECT_GT(r.tz_stddev_m, 0.0);
  EXPECT_LT(r.tz_stddev_m, 0.02);
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
  EXPECT_LT(r.wall_time_s, 0.5);
}

TEST(ZCorrect, NearestNeighbourMatchAlsoWorks) {
  const GroundDrive drive = make_drive(12);
  ZConfig config;
  config.match = FiducialMatch::kNearestNeighbour;
  const ZResult r = correct_z(drive.data, stage2_like(drive.T_ins_lidar_true), 0.0, std::nullopt, config);
  ASSERT_TRUE(r.determined) << r.explanation;
  EXPECT_LT(std::abs(tz_error(r, drive.T_ins_lidar_true)), 0.03) << r.explanation;
}

TEST(ZCorrect, FlagsAFiducialOffByHalfAMetre) {
  GroundDrive drive = make_drive(13);
  drive.data.fiducials[2].p_world.z() += 0.5;  // mistyped survey
  const ZResult r = correct_z(drive.data, stage2_like(drive.T_ins_lidar_true), 0.0, std::nullopt);
  ASSERT_TRUE(r.determined) << r.explanation;
  EXPECT_LT(std::abs(tz_error(r, drive.T_ins_lidar_true)), 0.015) << r.explanation;
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
  EXPECT_NE(r.explanation.find("F3"), std::string::npos) << r.explanation;
}

TEST(ZCorrect, FewerThanThreeUsableFiducialsIsNotDetermined) {
  GroundDrive drive = make_drive(14);
  drive.data.fiducials.resize(4);
  drive.data.fiducials[0].p_world = Vec3(500.0, 500.0, 0.0);  // never seen
  drive.data.fiducials[3].p_world = Vec3(-400.0, 20.0, 0.0);
  const Iso3 T_start = stage2_like(drive.T_ins_lidar_true);
  const ZResult r = correct_z(drive.data, T_start, 0.0, std::nullopt);
  EXPECT_FALSE(r.determined);
  EXPECT_EQ(r.method, "none");
  EXPECT_TRUE(r.T_ins_lidar.isApprox(T_start));
  EXPECT_EQ(r.dz_m, 0.0);
  EXPECT_NE(r.explanation.find("only 2 of 4"), std::string::npos) << r.explanation;
  EXPECT_NE(r.explanation.find("F1"), std::string::npos) << r.explanation;
  EXPECT_NE(r.explanation.find("F4"), std::string::npos) << r.explanation;
  EXPECT_NE(r.explanation.find("initial value"), std::string::npos) << r.explanation;
  for (const FiducialResidual& f : r.fiducials) {
    EXPECT_FALSE(f.used);
    EXPECT_FALSE(f.reason_rejected.empty()) << f.id;  // the measured ones too: why they were not used
  }
}

// A LiDAR with 2 deg between rings (VLP-16: the lowest at -15 deg; here 2 m above the ground)
// meets the ground only on circles 7.5 m and farther out, so most of the nearest frames see
// nothing at a fiducial. Stage 3 then takes farther frames for it until enough of them see it.
TEST(ZCorrect, SparseRingsStillSeeTheFiducials) {
  const GroundDrive drive = make_drive(17, 25.0, Beams{.count = 8, .lowest_deg = -15.0, .step_deg = 2.0});
  const Iso3 T_start = stage2_like(drive.T_ins_lidar_true);
  ZConfig one_round;  // at most frames_per_fiducial frames, the nearest
  one_round.max_frames_per_fiducial = one_round.frames_per_fiducial;
  const ZResult nearest_only = correct_z(drive.data, T_start, 0.0, std::nullopt, one_round);
  const ZResult r = correct_z(drive.data, T_start, 0.0, std::nullopt);
  auto used = [](const ZResult& z) {
    return std::count_if(z.fiducials.begin(), z.fiducials.end(), [](const FiducialResidual& f) { return f.used; });
  };
  std::printf("fiducials used: nearest frames only %d, with farther rounds %d (%zu frames loaded)\n",
              int(used(nearest_only)), int(used(r)), r.frames_loaded);
  ASSERT_TRUE(r.determined) << r.explanation;
  EXPECT_GT(used(r), used(nearest_only));
  EXPECT_LT(std::abs(tz_error(r, drive.T_ins_lidar_true)), 0.02) << r.explanation;
  EXPECT_LE(r.frames_loaded, 6 * ZConfig{}.max_frames_per_fiducial);
}

TEST(ZCorrect, HeightPriorRecoversTz) {
  GroundDrive drive = make_drive(15);
  drive.data.fiducials.clear();
  const ZResult r = correct_z(drive.data, stage2_like(drive.T_ins_lidar_true), 0.0, kInsHeight_m + 0.01);
  ASSERT_TRUE(r.determined) << r.explanation;
  EXPECT_EQ(r.method, "ins-height");
  EXPECT_LT(std::abs(tz_error(r, drive.T_ins_lidar_true)), 0.02) << r.explanation;
  EXPECT_GE(r.height_samples_used, 10u) << r.explanation;
  EXPECT_LT(r.wall_time_s, 0.5);
}

// The same sparse LiDAR does not see the ground under the INS from the nearest frames 3 m away
// either: the height prior then stitches in frames from farther along the drive.
TEST(ZCorrect, HeightPriorWithSparseRings) {
  GroundDrive drive = make_drive(18, 25.0, Beams{.count = 8, .lowest_deg = -15.0, .step_deg = 2.0});
  drive.data.fiducials.clear();
  const ZResult r = correct_z(drive.data, stage2_like(drive.T_ins_lidar_true), 0.0, kInsHeight_m);
  ASSERT_TRUE(r.determined) << r.explanation;
  EXPECT_LT(std::abs(tz_error(r, drive.T_ins_lidar_true)), 0.02) << r.explanation;
  EXPECT_GE(r.height_samples_used, 8u) << r.explanation;
}

TEST(ZCorrect, HeightPriorIsTheFallbackWhenFiducialsAreUnusable) {
  GroundDrive drive = make_drive(16);
  for (auto& f : drive.data.fiducials) f.p_world.x() += 1000.0;
  const ZResult r = correct_z(drive.data, stage2_like(drive.T_ins_lidar_true), 0.0, kInsHeight_m);
  ASSERT_TRUE(r.determined) << r.explanation;
  EXPECT_EQ(r.method, "ins-height");
  EXPECT_NE(r.explanation.find("fiducials"), std::string::npos) << r.explanation;
  EXPECT_LT(std::abs(tz_error(r, drive.T_ins_lidar_true)), 0.02) << r.explanation;
}

TEST(ZCorrect, NeitherFiducialsNorHeightKeepsTz) {
  GroundDrive drive = make_drive(17, 1.0);
  drive.data.fiducials.clear();
  const Iso3 T_start = stage2_like(drive.T_ins_lidar_true);
  const ZResult r = correct_z(drive.data, T_start, 0.0, std::nullopt);
  EXPECT_FALSE(r.determined);
  EXPECT_EQ(r.method, "none");
  EXPECT_TRUE(r.T_ins_lidar.isApprox(T_start));
  EXPECT_NE(r.explanation.find("no fiducials and no --ins-height-m"), std::string::npos) << r.explanation;
  EXPECT_NE(r.explanation.find("kept at the initial value"), std::string::npos) << r.explanation;
  EXPECT_EQ(r.frames_loaded, 0u);
}

}  // namespace
}  // namespace insalign
