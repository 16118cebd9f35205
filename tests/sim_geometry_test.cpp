// The simulator's geometry is right: stitching a short drive with the TRUE extrinsic and per-point
// deskew gives ground and walls as thin as the range noise; the perturbed initial guess, a wrong
// time offset or skipping the deskew make them measurably thicker.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <vector>

#include "core/deskew.hpp"
#include "sim/scene.hpp"
#include "sim/simulate.hpp"

namespace insalign::sim {
namespace {

constexpr double kRangeNoiseM = 0.02;

// RMS distance of points to their least-squares plane.
double plane_rms(const std::vector<Vec3>& pts) {
  if (pts.size() < 10) return std::numeric_limits<double>::quiet_NaN();
  Vec3 mean = Vec3::Zero();
  for (const Vec3& p : pts) mean += p;
  mean /= static_cast<double>(pts.size());
  Mat3 cov = Mat3::Zero();
  for (const Vec3& p : pts) cov += (p - mean) * (p - mean).transpose();
  cov /= static_cast<double>(pts.size());
  Eigen::SelfAdjointEigenSolver<Mat3> eig(cov);
  return std::sqrt(std::max(0.0, eig.eigenvalues()(0)));
}

struct Patch {
  // Ground: a disc on the driven path behind the start. Wall: the outside slab of one face.
  Vec2 ground_center = Vec2::Zero();
  double ground_radius_m = 1.5;
  const Box* wall = nullptr;
  double wall_side = 1.0;
};

struct Drive {
  World world;
  std::vector<Sweep> sweeps;
  PoseStream poses;  // reported per-frame poses, as a calibrator sees them
};

Drive make_drive(double time_offset_s = 0.0) {
  SimConfig cfg;
  cfg.seed = 5;
  cfg.speed_kmh = 20.0;
  cfg.duration_s = 10.0;  // into the first turn: views from many headings
  cfg.azimuth_step_deg = 0.4;
  cfg.range_noise_m = kRangeNoiseM;
  cfg.ins_noise_scale = 0.0;  // isolate the LiDAR geometry from INS noise
  cfg.time_offset_s = time_offset_s;
  Drive d{build_world(cfg), {}, {}};
  // Every 3rd frame is enough geometry; the poses are those of every frame, as in a pose file.
  for (std::size_t k = 0; k < d.world.frame_count(); k += 3) d.sweeps.push_back(render_sweep(d.world, k));
  d.poses = PoseStream(frame_poses(d.world, d.world.frame_times_s));
  return d;
}

// Points of the stitched drive, world frame; only frames the poses fully cover.
std::vector<Vec3> stitch(const Drive& d, const Iso3& T_ins_lidar, const PlaceOptions& opt) {
  std::vector<Vec3> out;
  for (const Sweep& s : d.sweeps) {
    // The same frames whatever the options, so point i is the same measurement in every cloud.
    const double off = d.world.config.time_offset_s;
    if (!d.poses.covers(s.t_end_s - 0.1 + std::min(0.0, off)) || !d.poses.covers(s.t_end_s + std::max(0.0, off)))
      continue;
    for (const Vec3f& p : sweep_to_world(s, d.poses, T_ins_lidar, opt)) out.push_back(p.cast<double>());
  }
  return out;
}

std::vector<std::size_t> ground_points(const Drive& d, const std::vector<Vec3>& cloud, const Patch& patch) {
  const GroundPlane& g = d.world.scene->ground;
  std::vector<std::size_t> sel;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vec3& p = cloud[i];
    if ((p.head<2>() - patch.ground_center).norm() > patch.ground_radius_m) continue;
    if (std::abs(p.z() - g.z_at(p.x(), p.y())) > 0.3) continue;
    sel.push_back(i);
  }
  return sel;
}

// Indices of the points in the face's extent, from just inside the face to 0.3 m outside it.
std::vector<std::size_t> wall_points(const Drive& d, const std::vector<Vec3>& cloud, const Box& b, double side) {
  const GroundPlane& g = d.world.scene->ground;
  const double c = std::cos(b.yaw_rad), s = std::sin(b.yaw_rad);
  std::vector<std::size_t> sel;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vec3& p = cloud[i];
    const Vec3 q = p - b.center_m;
    const double lx = c * q.x() + s * q.y(), ly = -s * q.x() + c * q.y();
    const double out = side * ly - b.half_m.y();
    const double zg = g.z_at(p.x(), p.y());
    if (std::abs(lx) > b.half_m.x() - 0.5 || out < -0.1 || out > 0.3) continue;
    if (p.z() < zg + 0.5 || p.z() > std::min(zg + 2.5, b.center_m.z() + b.half_m.z() - 0.2)) continue;
    sel.push_back(i);
  }
  return sel;
}

// Thickness of the points `idx` (selected on the true stitching) as another stitching places them.
double thickness(const std::vector<Vec3>& cloud, const std::vector<std::size_t>& idx) {
  std::vector<Vec3> pts;
  for (std::size_t i : idx) pts.push_back(cloud.at(i));
  return plane_rms(pts);
}

Patch find_patches(const Drive& d, const std::vector<Vec3>& truth_cloud) {
  Patch patch;
  // Ground 6 m behind the start pose, on the path: free and seen throughout the drive.
  const Iso3 T0 = d.world.poses_true.T_world_ins(d.world.poses_true.t_begin() + 1.0);
  patch.ground_center = (T0.translation() - 6.0 * T0.linear().col(0)).head<2>();
  // Wall: the free-standing wall face with the most points.
  std::size_t best = 0;
  for (const Box& b : d.world.scene->boxes) {
    if (b.kind != BoxKind::kWall || b.half_m.x() < 3.0) continue;
    for (double side : {-1.0, 1.0}) {
      const std::size_t n = wall_points(d, truth_cloud, b, side).size();
      if (n > best) {
        best = n;
        patch.wall = &b;
        patch.wall_side = side;
      }
    }
  }
  return patch;
}

TEST(SimGeometry, TrueExtrinsicGivesThinSurfacesAndTheInitialGuessDoesNot) {
  const Drive d = make_drive();
  const std::vector<Vec3> truth = stitch(d, d.world.T_ins_lidar_true, {});
  ASSERT_GT(truth.size(), 100000u);
  const Patch patch = find_patches(d, truth);
  ASSERT_NE(patch.wall, nullptr);
  const std::vector<std::size_t> wall = wall_points(d, truth, *patch.wall, patch.wall_side);
  const std::vector<std::size_t> ground = ground_points(d, truth, patch);
  ASSERT_GT(wall.size(), 200u);
  ASSERT_GT(ground.size(), 200u);

  // Range noise along oblique rays: the ground's normal component is only sin(elevation) of it.
  const double ground_true = thickness(truth, ground);
  const double wall_true = thickness(truth, wall);
  EXPECT_LT(ground_true, 1.5 * kRangeNoiseM);
  EXPECT_LT(wall_true, 1.5 * kRangeNoiseM) << "wall at " << patch.wall->center_m.transpose() << ", " << wall.size() << " points";

  const std::vector<Vec3> init = stitch(d, d.world.T_ins_lidar_init, {});
  const double ground_init = thickness(init, ground);
  const double wall_init = thickness(init, wall);
  EXPECT_GT(ground_init, 3.0 * ground_true);
  EXPECT_GT(wall_init, 3.0 * wall_true);
  RecordProperty("ground_true_m", std::to_string(ground_true));
  RecordProperty("wall_true_m", std::to_string(wall_true));
  RecordProperty("ground_init_m", std::to_string(ground_init));
  RecordProperty("wall_init_m", std::to_string(wall_init));
}

// A surface facing the direction of travel: sensor motion during the sweep shows up across it.
TEST(SimGeometry, DeskewMattersWhileMoving) {
  const Drive d = make_drive();
  const std::vector<Vec3> truth = stitch(d, d.world.T_ins_lidar_true, {});
  PlaceOptions no_deskew;
  no_deskew.per_point_time = false;
  const std::vector<Vec3> skewed = stitch(d, d.world.T_ins_lidar_true, no_deskew);
  const Iso3 T_mid = d.world.poses_true.T_world_ins(d.world.frame_times_s[d.world.frame_count() / 4]);
  const Vec3 forward = T_mid.linear().col(0);
  // Among all box faces seen by >= 300 points and facing the motion (within 45 deg), compare.
  int compared = 0;
  for (const Box& b : d.world.scene->boxes) {
    if (b.half_m.z() < 0.6 || b.half_m.x() < 2.0) continue;
    const Vec3 n_face(-std::sin(b.yaw_rad), std::cos(b.yaw_rad), 0.0);
    if (std::abs(n_face.dot(forward)) < std::cos(45.0 * kRadPerDeg)) continue;
    for (double side : {-1.0, 1.0}) {
      const auto sel_true = wall_points(d, truth, b, side);
      if (sel_true.size() < 300) continue;
      const double thin = thickness(truth, sel_true);
      if (thin > 1.5 * kRangeNoiseM) continue;  // a face with recessed segments in front of it
      const double thick = thickness(skewed, sel_true);
      EXPECT_GT(thick, 1.5 * thin) << "face of box at " << b.center_m.transpose();
      ++compared;
    }
  }
  EXPECT_GT(compared, 0);
}

TEST(SimGeometry, TimeOffsetShowsInTheSweepsNotThePoses) {
  const double offset_s = 0.05;
  const Drive d = make_drive(offset_s);
  PlaceOptions right;
  right.time_offset_s = offset_s;
  const std::vector<Vec3> good = stitch(d, d.world.T_ins_lidar_true, right);
  const std::vector<Vec3> bad = stitch(d, d.world.T_ins_lidar_true, {});
  const Patch patch = find_patches(d, good);
  ASSERT_NE(patch.wall, nullptr);
  const double wall_good = thickness(good, wall_points(d, good, *patch.wall, patch.wall_side));
  EXPECT_LT(wall_good, 1.5 * kRangeNoiseM);
  EXPECT_LT(thickness(good, ground_points(d, good, patch)), 1.5 * kRangeNoiseM);
  // Ignoring the offset places every point where the sensor was `offset` earlier: about
  // speed * offset away (the drive starts from rest, so at least half of that on average).
  ASSERT_EQ(good.size(), bad.size());
  double shift = 0.0;
  for (std::size_t i = 0; i < good.size(); ++i) shift += (good[i] - bad[i]).norm();
  shift /= static_cast<double>(good.size());
  EXPECT_GT(shift, 0.5 * (20.0 / 3.6) * offset_s * 0.5);
  RecordProperty("offset_shift_m", std::to_string(shift));
}

}  // namespace
}  // namespace insalign::sim
