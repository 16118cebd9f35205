#include "core/ground_level.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <random>

namespace insalign {
namespace {

double angle_deg(const Vec3& a, const Vec3& b) { return std::acos(std::clamp(a.dot(b), -1.0, 1.0)) * kDegPerRad; }

// Least-squares plane through the points within inlier_m of (n, d), turned towards the sensor
// (d > 0); false if too few.
bool refit_plane(const std::vector<Vec3>& pts, double inlier_m, Vec3& n, double& d, int& inliers) {
  Vec3 mean = Vec3::Zero();
  int n_in = 0;
  for (const Vec3& p : pts)
    if (std::abs(n.dot(p) + d) < inlier_m) mean += p, ++n_in;
  if (n_in < 30) return false;
  mean /= n_in;
  Mat3 cov = Mat3::Zero();
  for (const Vec3& p : pts)
    if (std::abs(n.dot(p) + d) < inlier_m) cov += (p - mean) * (p - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(cov);
  n = eig.eigenvectors().col(0);
  if (n.dot(mean) > 0) n = -n;  // towards the sensor: the origin on the positive side
  d = -n.dot(mean);
  inliers = n_in;
  return true;
}

// The largest plane of `pts` whose normal (towards the sensor) passes the tilt test and whose
// distance from the sensor is a mount height.
GroundPlane largest_plane(const std::vector<Vec3>& pts, const GroundConfig& config, std::mt19937& rng) {
  GroundPlane best;
  if (pts.size() < 50) return best;
  // Score on a subsample: RANSAC only needs the inlier fraction.
  std::vector<Vec3> sample;
  const std::size_t stride = std::max<std::size_t>(1, pts.size() / 4000);
  for (std::size_t i = 0; i < pts.size(); i += stride) sample.push_back(pts[i]);
  std::uniform_int_distribution<std::size_t> pick(0, pts.size() - 1);
  const double cos_tilt = std::cos(config.max_tilt_deg * kRadPerDeg);
  Vec3 n_best = Vec3::UnitZ();
  double d_best = 0.0;
  int best_count = 0;
  for (int it = 0; it < config.ransac_iterations; ++it) {
    const Vec3 a = pts[pick(rng)], b = pts[pick(rng)], c = pts[pick(rng)];
    Vec3 n = (b - a).cross(c - a);
    if (n.norm() < 1e-6) continue;
    n.normalize();
    if (n.dot(a) > 0) n = -n;  // towards the sensor
    if (n.z() < cos_tilt) continue;
    const double d = -n.dot(a);  // n.p + d = 0; d = the origin's distance from the plane
    if (d < 0.3 || d > 6.0) continue;  // the ground is a mount height away
    int count = 0;
    for (const Vec3& p : sample) count += std::abs(n.dot(p) + d) < config.inlier_m;
    if (count > best_count) best_count = count, n_best = n, d_best = d;
  }
  if (best_count < 30) return best;
  // Twice: the refit may gain inliers.
  for (int round = 0; round < 2; ++round)
    if (!refit_plane(pts, config.inlier_m, n_best, d_best, best.inliers)) return best;
  best.normal_lidar = n_best;
  best.height_m = d_best;
  best.valid = d_best > 0.3 && n_best.z() >= cos_tilt;
  return best;
}

// One plane seen from two frames: the ground's normal and height in the LiDAR frame barely move
// (the car's roll and pitch, its springs), a wall's turn and shift with the car.
bool same_plane(const GroundPlane& a, const GroundPlane& b) {
  return angle_deg(a.normal_lidar, b.normal_lidar) <= 5.0 && std::abs(a.height_m - b.height_m) <= 0.3;
}

// How many frames have a candidate like `g`, and their inliers.
std::pair<int, long> support(const GroundPlane& g, const std::vector<InitFrame*>& frames) {
  int n = 0;
  long inliers = 0;
  for (const InitFrame* f : frames) {
    const auto it = std::find_if(f->ground_candidates.begin(), f->ground_candidates.end(),
                                 [&](const GroundPlane& c) { return same_plane(c, g); });
    if (it != f->ground_candidates.end()) ++n, inliers += it->inliers;
  }
  return {n, inliers};
}

// Each frame's ground: its candidate like the one most frames share (none when it has none).
void choose_ground(const std::vector<InitFrame*>& frames) {
  const GroundPlane* best = nullptr;
  std::pair<int, long> best_support{0, 0};
  for (const InitFrame* f : frames)
    for (const GroundPlane& c : f->ground_candidates)
      if (const auto s = support(c, frames); s > best_support) best_support = s, best = &c;
  if (!best) return;
  const GroundPlane chosen = *best;
  for (InitFrame* f : frames) {
    const auto it = std::find_if(f->ground_candidates.begin(), f->ground_candidates.end(),
                                 [&](const GroundPlane& c) { return same_plane(c, chosen); });
    f->ground = it != f->ground_candidates.end() ? *it : GroundPlane{};
  }
}

}  // namespace

std::vector<GroundPlane> ground_candidates(const std::vector<Vec3>& p_lidar, const GroundConfig& config,
                                           unsigned seed) {
  // Points within 25 m of the sensor (the ground nearby is densest and flattest).
  std::vector<Vec3> pts;
  for (const Vec3& p : p_lidar)
    if (p.squaredNorm() < 25.0 * 25.0) pts.push_back(p);
  std::mt19937 rng(seed);
  std::vector<GroundPlane> out;
  for (int k = 0; k < config.candidates; ++k) {
    const GroundPlane g = largest_plane(pts, config, rng);
    if (!g.valid) break;
    out.push_back(g);
    std::erase_if(pts, [&](const Vec3& p) { return std::abs(g.normal_lidar.dot(p) + g.height_m) < config.inlier_m; });
  }
  return out;
}

GroundPlane fit_ground_plane(const std::vector<Vec3>& p_lidar, const GroundConfig& config, unsigned seed) {
  GroundConfig one = config;
  one.candidates = 1;
  const std::vector<GroundPlane> c = ground_candidates(p_lidar, one, seed);
  return c.empty() ? GroundPlane{} : c.front();
}

Mat3 levelling_rotation(const Vec3& normal_lidar) {
  return Eigen::Quaterniond::FromTwoVectors(normal_lidar.normalized(), Vec3::UnitZ()).toRotationMatrix();
}

Iso3 T_ins_lidar_levelled(const Levelling& level, double yaw_rad, const Eigen::Vector2d& t_xy_insl_m,
                          double tz_insl_m) {
  Iso3 T = Iso3::Identity();
  T.linear() = level.R_ins_insl * Eigen::AngleAxisd(yaw_rad, Vec3::UnitZ()).toRotationMatrix() * level.R_lev_lidar;
  T.translation() = level.R_ins_insl * Vec3(t_xy_insl_m.x(), t_xy_insl_m.y(), tz_insl_m);
  return T;
}

Levelling level_lidar(const std::vector<InitFrame*>& frames, const GroundConfig& config) {
  Levelling out;
  choose_ground(frames);
  std::vector<Vec3> normals;
  for (const InitFrame* f : frames)
    if (f->ground.valid) normals.push_back(f->ground.normal_lidar);
  if (normals.size() < 2) {
    out.message = "no ground plane found near the LiDAR in the frames used; roll and pitch of the extrinsic "
                  "cannot be started from the data (give --init)";
    return out;
  }
  Vec3 median_n;
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> v;
    for (const Vec3& n : normals) v.push_back(n[axis]);
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    median_n[axis] = v[v.size() / 2];
  }
  median_n.normalize();
  Vec3 n_sum = Vec3::Zero(), up_ins_sum = Vec3::Zero();
  double height_sum = 0.0;
  for (InitFrame* frame : frames) {
    InitFrame& f = *frame;
    if (!f.ground.valid) continue;
    if (angle_deg(f.ground.normal_lidar, median_n) > 3.0) {
      f.ground.valid = false;
      continue;
    }
    n_sum += f.ground.normal_lidar;
    up_ins_sum += f.T_world_ins.linear().transpose() * Vec3::UnitZ();
    height_sum += f.ground.height_m;
    ++out.planes_used;
  }
  out.normal_lidar = n_sum.normalized();
  out.lidar_height_m = height_sum / out.planes_used;
  double s2 = 0.0;
  for (const InitFrame* f : frames)
    if (f->ground.valid) s2 += std::pow(angle_deg(f->ground.normal_lidar, out.normal_lidar) * kRadPerDeg, 2);
  out.normal_spread_deg = std::sqrt(s2 / out.planes_used) * kDegPerRad;
  out.R_lev_lidar = levelling_rotation(out.normal_lidar);
  out.R_ins_insl = Eigen::Quaterniond::FromTwoVectors(Vec3::UnitZ(), up_ins_sum.normalized()).toRotationMatrix();
  for (InitFrame* frame : frames) {
    InitFrame& f = *frame;
    const Vec3 n = f.ground.valid ? f.ground.normal_lidar : out.normal_lidar;
    const double h = f.ground.valid ? f.ground.height_m : out.lidar_height_m;
    f.off_ground.resize(f.sweep.size());
    for (std::size_t i = 0; i < f.sweep.size(); ++i)
      f.off_ground[i] = n.dot(f.sweep.p_lidar[i].cast<double>()) + h > config.clearance_m;
  }
  out.ok = true;
  return out;
}

}  // namespace insalign
