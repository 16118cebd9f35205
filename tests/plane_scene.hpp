// A tiny seeded ray-cast world for stage-1 tests: a ground plane and axis-aligned boxes, a
// spinning LiDAR with per-point times, and a few analytic drives. Independent of the simulator so
// these tests pin down the stage itself.
#pragma once

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <vector>

#include "core/dataset.hpp"
#include "core/geometry.hpp"
#include "core/pose_stream.hpp"

namespace insalign::testing {

struct Box {
  Vec3 min, max;
};

struct PlaneScene {
  bool ground = true;
  std::vector<Box> boxes;
};

/// Boxes scattered in a ring around the origin, clear of the drives below (|x| < 16, |y| < 9).
inline PlaneScene town_scene(unsigned seed, int n_boxes = 28) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ang(0.0, 2.0 * M_PI), rad(24.0, 40.0), size(2.0, 8.0), height(3.0, 12.0);
  PlaneScene scene;
  for (int i = 0; i < n_boxes; ++i) {
    const double a = ang(rng), r = rad(rng);
    const Vec3 c(r * std::cos(a), 0.6 * r * std::sin(a), 0.0);
    const double sx = size(rng), sy = size(rng);
    scene.boxes.push_back({Vec3(c.x() - sx / 2, c.y() - sy / 2, 0.0), Vec3(c.x() + sx / 2, c.y() + sy / 2, height(rng))});
  }
  return scene;
}

inline double ray_cast(const PlaneScene& scene, const Vec3& o, const Vec3& d, double max_range) {
  double best = max_range;
  if (scene.ground && d.z() < -1e-9) {
    const double t = -o.z() / d.z();
    if (t > 0.0 && t < best) best = t;
  }
  for (const Box& b : scene.boxes) {
    double t0 = 0.0, t1 = best;
    bool hit = true;
    for (int a = 0; a < 3 && hit; ++a) {
      if (std::abs(d(a)) < 1e-12) {
        if (o(a) < b.min(a) || o(a) > b.max(a)) hit = false;
        continue;
      }
      double ta = (b.min(a) - o(a)) / d(a), tb = (b.max(a) - o(a)) / d(a);
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta);
      t1 = std::min(t1, tb);
      if (t0 > t1) hit = false;
    }
    if (hit && t0 > 0.0 && t0 < best) best = t0;
  }
  return best;
}

enum class Drive { kFigure8, kStraight, kStandstill };

/// T_world_ins(t): the INS 1 m above the ground. Figure-8: a lerniscate 30 m x 15 m, ~4 m/s,
/// with +-1 deg roll and pitch sway; straight: 4 m/s along x; standstill: fixed.
inline Iso3 drive_pose(Drive drive, double t_s) {
  Iso3 T = Iso3::Identity();
  if (drive == Drive::kStandstill) {
    T.translation() = Vec3(0, 0, 1.0);
    return T;
  }
  if (drive == Drive::kStraight) {
    T.translation() = Vec3(-15.0 + 4.0 * t_s, 0.0, 1.0);
    T.linear() = rotation_from_rpy(Vec3(0.01 * std::sin(1.3 * t_s), 0.01 * std::sin(0.9 * t_s), 0.0));
    return T;
  }
  const double w = 2.0 * M_PI / 24.0;  // one loop in 24 s
  const double th = w * t_s;
  const Vec3 p(15.0 * std::sin(th), 7.5 * std::sin(2.0 * th), 1.0);
  const Vec3 v(15.0 * w * std::cos(th), 15.0 * w * std::cos(2.0 * th), 0.0);
  const double yaw = std::atan2(v.y(), v.x());
  T.translation() = p;
  T.linear() = rotation_from_rpy(Vec3(0.017 * std::sin(1.7 * t_s), 0.017 * std::sin(1.1 * t_s + 0.5), yaw));
  return T;
}

struct SceneDrive {
  Dataset data;
  Iso3 T_ins_lidar_true = Iso3::Identity();
};

/// n_frames sweeps at 10 Hz (each a full turn of `rings` beams in `columns` firings over 0.1 s,
/// measured from the true pose at its own instant), poses at 100 Hz.
inline SceneDrive make_drive(const PlaneScene& scene, Drive drive, const Iso3& T_ins_lidar, int n_frames,
                             unsigned seed, int rings = 16, int columns = 450, double noise_m = 0.01) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_m);
  SceneDrive out;
  out.T_ins_lidar_true = T_ins_lidar;
  const double t0 = 100.0;
  std::vector<StampedPose> poses;
  for (int k = 0; k <= (n_frames + 2) * 10; ++k) {
    const double t = k * 0.01;
    poses.push_back({t0 + t, drive_pose(drive, t)});
  }
  std::vector<Sweep> sweeps;
  for (int f = 1; f <= n_frames; ++f) {
    Sweep s;
    s.t_end_s = t0 + 0.1 * f;
    s.name = "frame" + std::to_string(f);
    for (int c = 0; c < columns; ++c) {
      const double dt = -0.1 + 0.1 * (c + 1) / columns;
      const Iso3 T_world_lidar = drive_pose(drive, s.t_end_s - t0 + dt) * T_ins_lidar;
      const double az = 2.0 * M_PI * c / columns;
      for (int r = 0; r < rings; ++r) {
        const double el = (-20.0 + 30.0 * r / (rings - 1)) * kRadPerDeg;
        const Vec3 d_lidar(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
        const Vec3 o = T_world_lidar.translation();
        const Vec3 d = T_world_lidar.linear() * d_lidar;
        const double range = ray_cast(scene, o, d, 80.0);
        if (range >= 80.0) continue;
        s.p_lidar.push_back(((range + noise(rng)) * d_lidar).cast<float>());
        s.dt_s.push_back(static_cast<float>(dt));
      }
    }
    sweeps.push_back(std::move(s));
  }
  out.data.frames = frame_source_from(std::move(sweeps));
  out.data.poses = PoseStream(std::move(poses));
  return out;
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
