// The one in-process test world of the stage tests: a ground plane and axis-aligned boxes, an
// analytic drive (figure-8, straight or standstill) with a little roll and pitch, a spinning
// LiDAR whose every column is cast from its true pose at its own instant, noisy INS poses and
// surveyed fiducials. Seeded and small, so each stage test pins the stage itself down in
// milliseconds; the simulator (src/sim) is for the integration tests and the benchmarks.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "core/dataset.hpp"
#include "core/geometry.hpp"
#include "core/pipeline.hpp"
#include "core/pose_stream.hpp"

namespace insalign::testing {

struct Box {
  Vec3 min, max;
};

struct Scene {
  bool ground = true;
  std::vector<Box> boxes;

  /// Nearest hit of o + s d (d unit) with the ground z = 0 or a box, at most max_range.
  double cast(const Vec3& o, const Vec3& d, double max_range) const {
    double best = max_range;
    if (ground && d.z() < -1e-9) best = std::min(best, -o.z() / d.z());
    for (const Box& b : boxes) {
      double s_in = 0.0, s_out = best;
      for (int a = 0; a < 3 && s_in <= s_out; ++a) {
        if (std::abs(d(a)) < 1e-12) {
          if (o(a) < b.min(a) || o(a) > b.max(a)) s_in = s_out + 1.0;
          continue;
        }
        double s1 = (b.min(a) - o(a)) / d(a), s2 = (b.max(a) - o(a)) / d(a);
        if (s1 > s2) std::swap(s1, s2);
        s_in = std::max(s_in, s1), s_out = std::min(s_out, s2);
      }
      if (s_in <= s_out && s_in > 0.0) best = std::min(best, s_in);
    }
    return best;
  }
};

/// Boxes scattered in a ring around the origin, clear of the drives below (|x| < 16, |y| < 9).
inline Scene town_scene(unsigned seed, int n_boxes = 28) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ang(0.0, 2.0 * M_PI), rad(24.0, 40.0), size(2.0, 8.0), height(3.0, 12.0);
  Scene scene;
  for (int i = 0; i < n_boxes; ++i) {
    const double a = ang(rng), r = rad(rng);
    const Vec3 c(r * std::cos(a), 0.6 * r * std::sin(a), 0.0);
    const double sx = size(rng), sy = size(rng);
    scene.boxes.push_back({Vec3(c.x() - sx / 2, c.y() - sy / 2, 0.0), Vec3(c.x() + sx / 2, c.y() + sy / 2, height(rng))});
  }
  return scene;
}

/// A wall, a parked car and a pillar near a small figure-8: little besides the ground.
inline Scene ground_scene() {
  auto box = [](Vec3 centre, Vec3 half) { return Box{centre - half, centre + half}; };
  Scene scene;
  scene.boxes = {box({0.0, 9.0, 1.5}, {6.0, 0.3, 1.5}), box({-15.0, -4.0, 0.75}, {2.2, 0.9, 0.75}),
                 box({16.0, 3.0, 2.0}, {0.2, 0.2, 2.0})};
  return scene;
}

enum class Drive { kFigure8, kStraight, kStandstill };

struct DriveShape {
  Drive kind = Drive::kFigure8;
  double half_width_m = 15.0;  ///< figure-8: x from -a to a, y from -a/2 to a/2
  double loop_s = 24.0;        ///< figure-8: one loop; straight: 4 m/s along x
  double sway_rad = 0.017;     ///< roll and pitch amplitude
  double ins_height_m = 1.0;   ///< INS origin above the ground
};

/// T_world_ins(t) of the drive.
inline Iso3 drive_pose(const DriveShape& d, double t_s) {
  Iso3 T = Iso3::Identity();
  T.translation() = Vec3(0, 0, d.ins_height_m);
  if (d.kind == Drive::kStandstill) return T;
  const Vec3 sway(d.sway_rad * std::sin(1.7 * t_s), d.sway_rad * std::sin(1.1 * t_s + 0.5), 0.0);
  if (d.kind == Drive::kStraight) {
    T.translation().x() = -15.0 + 4.0 * t_s;
    T.linear() = rotation_from_rpy(0.6 * sway);
    return T;
  }
  const double a = d.half_width_m, w = 2.0 * M_PI / d.loop_s, th = w * t_s;
  const Vec3 v(a * w * std::cos(th), a * w * std::cos(2.0 * th), 0.0);
  T.translation() = Vec3(a * std::sin(th), 0.5 * a * std::sin(2.0 * th), d.ins_height_m);
  T.linear() = rotation_from_rpy(Vec3(sway.x(), sway.y(), std::atan2(v.y(), v.x())));
  return T;
}

struct LidarSpec {
  int rings = 16;
  double lowest_deg = -20.0, highest_deg = 10.0;
  int columns = 450;           ///< firings per 0.1 s turn
  double max_range_m = 80.0;
  double noise_m = 0.01;       ///< range noise sigma
};

struct WorldSpec {
  Scene scene = town_scene(1);
  DriveShape drive;
  LidarSpec lidar;
  Iso3 T_ins_lidar = Iso3::Identity();
  int frames = 100;            ///< at 10 Hz
  double t0_s = 100.0;         ///< time of the drive's start (frame times are t0 + 0.1 k)
  double time_offset_s = 0.0;  ///< true t_ins = t_lidar + offset: the LiDAR at t sees the world at t + offset
  double pose_noise_m = 0.0;   ///< INS position noise sigma per 100 Hz pose
  double pose_noise_deg = 0.0; ///< INS attitude noise sigma
  std::vector<Vec3> fiducial_spots;  ///< ground points surveyed (z from the ground, 0)
  double fiducial_noise_m = 0.005;
  unsigned seed = 1;
};

struct TestDrive {
  Dataset data;
  Iso3 T_ins_lidar_true = Iso3::Identity();
  WorldSpec spec;
};

inline Sweep cast_sweep(const WorldSpec& w, double t_end_s, std::mt19937& rng) {
  std::normal_distribution<double> noise(0.0, w.lidar.noise_m);
  Sweep s;
  s.t_end_s = t_end_s;
  const int n = w.lidar.columns;
  for (int c = 0; c < n; ++c) {
    const double dt = -0.1 + 0.1 * (c + 1) / n;
    const Iso3 T_world_lidar = drive_pose(w.drive, t_end_s + dt + w.time_offset_s - w.t0_s) * w.T_ins_lidar;
    const double az = 2.0 * M_PI * c / n;
    for (int r = 0; r < w.lidar.rings; ++r) {
      const double el =
          (w.lidar.lowest_deg + (w.lidar.highest_deg - w.lidar.lowest_deg) * r / std::max(1, w.lidar.rings - 1)) * kRadPerDeg;
      const Vec3 d_lidar(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
      const double range =
          w.scene.cast(T_world_lidar.translation(), T_world_lidar.linear() * d_lidar, w.lidar.max_range_m);
      if (range >= w.lidar.max_range_m) continue;
      s.p_lidar.push_back(((range + noise(rng)) * d_lidar).cast<float>());
      s.dt_s.push_back(static_cast<float>(dt));
    }
  }
  return s;
}

/// The drive's sweeps (in memory), 100 Hz INS poses covering them with margin, the fiducials.
inline TestDrive make_test_drive(const WorldSpec& spec) {
  std::mt19937 rng(spec.seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  TestDrive out;
  out.spec = spec;
  out.T_ins_lidar_true = spec.T_ins_lidar;
  std::vector<StampedPose> poses;
  for (int k = -50; k <= (spec.frames + 5) * 10; ++k) {
    const double t = k * 0.01;
    Iso3 T = drive_pose(spec.drive, t);
    T.translation() += spec.pose_noise_m * Vec3(n01(rng), n01(rng), n01(rng));
    T.linear() = T.linear() * so3_exp(spec.pose_noise_deg * kRadPerDeg * Vec3(n01(rng), n01(rng), n01(rng)));
    poses.push_back({spec.t0_s + t, T});
  }
  std::vector<Sweep> sweeps;
  for (int f = 1; f <= spec.frames; ++f) {
    sweeps.push_back(cast_sweep(spec, spec.t0_s + 0.1 * f, rng));
    sweeps.back().name = "frame" + std::to_string(f);
  }
  out.data.frames = frame_source_from(std::move(sweeps));
  out.data.poses = PoseStream(std::move(poses));
  for (std::size_t i = 0; i < spec.fiducial_spots.size(); ++i) {
    out.data.fiducials.push_back(
        {"F" + std::to_string(i + 1), spec.fiducial_spots[i] + spec.fiducial_noise_m * Vec3(n01(rng), n01(rng), n01(rng))});
  }
  return out;
}

/// The stage tests' usual drive: the town scene, `frames` at 10 Hz, a 16-ring LiDAR, exact poses.
inline TestDrive town_drive(Drive kind, const Iso3& T_ins_lidar, int frames, unsigned seed, Scene scene = town_scene(1)) {
  WorldSpec spec;
  spec.scene = std::move(scene);
  spec.drive.kind = kind;
  spec.T_ins_lidar = T_ins_lidar;
  spec.frames = frames;
  spec.seed = seed;
  return make_test_drive(spec);
}

/// The frame store of a dataset with the pipeline's default filters (what every stage reads).
inline FrameStore store_of(const Dataset& data, const PipelineConfig& config = {}) {
  return make_frame_store(data, config);
}

/// A roof mount: LiDAR ~1 m above and behind the INS, any yaw.
inline Iso3 roof_mount(double yaw_deg) { return make_transform(Vec3(-0.4, 0.2, 0.9), Vec3(1.5, -2.0, yaw_deg)); }

/// The truth with a rotation error of rot_deg about a random axis and a translation error of
/// trans_m in a random direction.
inline Iso3 perturbed(const Iso3& T, double rot_deg, double trans_m, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  const Vec3 axis = Vec3(n(rng), n(rng), n(rng)).normalized();
  const Vec3 dir = Vec3(n(rng), n(rng), n(rng)).normalized();
  Iso3 out = T;
  out.linear() = so3_exp(axis * rot_deg * kRadPerDeg) * T.linear();
  out.translation() += dir * trans_m;
  return out;
}

}  // namespace insalign::testing
