#include "core/hand_eye.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "core/deskew.hpp"
#include "core/voxel_grid.hpp"

namespace insalign {
namespace {

Mat3 rot_z(double yaw_rad) { return Eigen::AngleAxisd(yaw_rad, Vec3::UnitZ()).toRotationMatrix(); }
// Rotation about z of a nearly planar rotation.
double yaw_of(const Mat3& R) { return std::atan2(R(1, 0), R(0, 0)); }
double angle_deg(const Mat3& R) { return Eigen::AngleAxisd(R).angle() * kDegPerRad; }

std::vector<Vec3> to_vec3(const std::vector<Vec3f>& points) {
  std::vector<Vec3> out(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) out[i] = points[i].cast<double>();
  return out;
}

}  // namespace

std::vector<std::pair<std::size_t, std::size_t>> hand_eye_pairs(const DriveFrames& frames, double period_s,
                                                                const HandEyeConfig& config) {
  const std::size_t n = frames.size();
  const std::size_t gap = std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(config.pair_dt_s / period_s)));
  struct Candidate { std::size_t a, b; double turn_deg, dist_m; };
  std::vector<Candidate> candidates;
  for (std::size_t a = 0; a + gap < n; ++a) {
    const std::size_t b = a + gap;
    const double dt = frames.t_end_s[b] - frames.t_end_s[a];
    if (std::abs(dt - gap * period_s) > 0.5 * gap * period_s) continue;  // a hole in the frames
    const Iso3 T_ins0_ins1 = frames.T_world_ins[a].inverse() * frames.T_world_ins[b];
    candidates.push_back({a, b, angle_deg(T_ins0_ins1.linear()), T_ins0_ins1.translation().norm()});
  }
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  std::vector<char> used(n, 0);
  auto take = [&](const Candidate& c) {
    for (std::size_t k = c.a > gap ? c.a - gap + 1 : 0; k < std::min(n, c.a + gap); ++k)
      if (used[k]) return;
    used[c.a] = 1;
    pairs.push_back({c.a, c.b});
  };
  auto by = [&](auto key) {
    std::vector<Candidate> sorted = candidates;
    std::sort(sorted.begin(), sorted.end(), [&](const Candidate& x, const Candidate& y) { return key(x) > key(y); });
    return sorted;
  };
  const std::size_t turns_wanted = static_cast<std::size_t>(config.pairs * 2 / 3);
  for (const Candidate& c : by([](const Candidate& c) { return c.turn_deg; })) {
    if (pairs.size() >= turns_wanted || c.turn_deg < config.min_pair_turn_deg) break;
    if (c.dist_m > 0.3) take(c);
  }
  for (const Candidate& c : by([](const Candidate& c) { return c.dist_m; })) {
    if (pairs.size() >= static_cast<std::size_t>(config.pairs) || c.dist_m < 0.5) break;
    if (c.turn_deg < config.min_pair_turn_deg) take(c);
  }
  return pairs;
}

void set_ins_motions(std::vector<MotionPair>& pairs, const PoseStream& poses, const Levelling& level,
                     double time_offset_s) {
  Iso3 T_insl_ins = Iso3::Identity();
  T_insl_ins.linear() = level.R_ins_insl.transpose();
  for (MotionPair& m : pairs) {
    const Iso3 T_ins0_ins1 =
        poses.T_world_ins(m.t0_s + time_offset_s).inverse() * poses.T_world_ins(m.t1_s + time_offset_s);
    m.T_insl0_insl1 = T_insl_ins * T_ins0_ins1 * T_insl_ins.inverse();
  }
}

std::vector<MotionPair> register_pairs(const std::vector<std::pair<const InitFrame*, const InitFrame*>>& pairs,
                                       const PoseStream& poses, const Iso3& T_ins_lidar_coarse,
                                       const Levelling& level, const HandEyeConfig& config) {
  std::vector<MotionPair> motions(pairs.size());
  std::vector<char> converged(pairs.size(), 0);
  Iso3 T_lidar_lev = Iso3::Identity();
  T_lidar_lev.linear() = level.R_lev_lidar.transpose();
  tbb::parallel_for(std::size_t{0}, pairs.size(), [&](std::size_t k) {
    const InitFrame& f0 = *pairs[k].first;
    const InitFrame& f1 = *pairs[k].second;
    if (!sweep_covered(poses, f0.sweep, 0.0) || !sweep_covered(poses, f1.sweep, 0.0)) return;
    const std::vector<Vec3> target =
        voxel_centroids(to_vec3(deskew_sweep(f0.sweep, poses, T_ins_lidar_coarse)), config.target_voxel_m);
    const std::vector<Vec3> source =
        voxel_centroids(to_vec3(deskew_sweep(f1.sweep, poses, T_ins_lidar_coarse)), config.source_voxel_m);
    const Iso3 T_ins0_ins1 = f0.T_world_ins.inverse() * f1.T_world_ins;
    const Iso3 T_lidar0_lidar1_predicted = T_ins_lidar_coarse.inverse() * T_ins0_ins1 * T_ins_lidar_coarse;
    const ScanRegistrationResult reg = register_scans(target, source, T_lidar0_lidar1_predicted, config.icp);
    if (!reg.converged) return;
    motions[k].T_lev0_lev1 = T_lidar_lev.inverse() * reg.T_target_source * T_lidar_lev;
    motions[k].t0_s = f0.sweep.t_end_s;
    motions[k].t1_s = f1.sweep.t_end_s;
    converged[k] = 1;
  });
  std::vector<MotionPair> out;
  for (std::size_t k = 0; k < pairs.size(); ++k)
    if (converged[k]) out.push_back(motions[k]);
  set_ins_motions(out, poses, level, 0.0);
  return out;
}

namespace {

// (yaw, t_xy) by linear least squares in (tx, ty, cos, sin) over the inlier pairs, or (cos, sin)
// alone without the lever arm; then, with the yaw on the circle, the lever arm again alone.
void solve_inliers(const std::vector<MotionPair>& pairs, double tz_m, bool with_lever_arm, PlanarHandEyeResult& r) {
  const int n_unknown = with_lever_arm ? 4 : 2;
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(n_unknown, n_unknown);
  Eigen::VectorXd g = Eigen::VectorXd::Zero(n_unknown);
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    if (!r.inlier[i]) continue;
    const Mat3 R_a = pairs[i].T_insl0_insl1.linear();
    const Vec3 t_a = pairs[i].T_insl0_insl1.translation();
    const Vec3 t_b = pairs[i].T_lev0_lev1.translation();
    Eigen::Matrix<double, 2, 4> J;  // two rows (x, y) per pair
    J << R_a(0, 0) - 1.0, R_a(0, 1), -t_b.x(), t_b.y(), R_a(1, 0), R_a(1, 1) - 1.0, -t_b.y(), -t_b.x();
    const Eigen::Vector2d rhs(-t_a.x() - R_a(0, 2) * tz_m, -t_a.y() - R_a(1, 2) * tz_m);
    const Eigen::MatrixXd Ji = with_lever_arm ? Eigen::MatrixXd(J) : Eigen::MatrixXd(J.rightCols<2>());
    H += Ji.transpose() * Ji;
    g += Ji.transpose() * rhs;
  }
  const Eigen::VectorXd x = H.ldlt().solve(g);
  r.yaw_rad = std::atan2(x(n_unknown - 1), x(n_unknown - 2));
  r.t_xy_m = Eigen::Vector2d::Zero();
  if (!with_lever_arm) return;
  Eigen::Matrix2d H2 = Eigen::Matrix2d::Zero();
  Eigen::Vector2d g2 = Eigen::Vector2d::Zero();
  const Eigen::Matrix2d Rz2 = rot_z(r.yaw_rad).topLeftCorner<2, 2>();
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    if (!r.inlier[i]) continue;
    const Mat3 R_a = pairs[i].T_insl0_insl1.linear();
    const Eigen::Matrix2d J2 = R_a.topLeftCorner<2, 2>() - Eigen::Matrix2d::Identity();
    const Eigen::Vector2d rhs = Rz2 * pairs[i].T_lev0_lev1.translation().head<2>() -
                                pairs[i].T_insl0_insl1.translation().head<2>() - R_a.topRightCorner<2, 1>() * tz_m;
    H2 += J2.transpose() * J2;
    g2 += J2.transpose() * rhs;
  }
  r.t_xy_m = H2.ldlt().solve(g2);
}

// Horizontal residual of pair i under the current solution.
double pair_residual(const MotionPair& pair, double tz_m, const PlanarHandEyeResult& r) {
  const Vec3 t_insl_lev(r.t_xy_m.x(), r.t_xy_m.y(), tz_m);
  const Vec3 lhs = pair.T_insl0_insl1.linear() * t_insl_lev + pair.T_insl0_insl1.translation();
  const Vec3 rhs = rot_z(r.yaw_rad) * pair.T_lev0_lev1.translation() + t_insl_lev;
  return (lhs - rhs).head<2>().norm();
}

// Drops pairs far off the consensus (gross registration failures); true if any was dropped.
bool drop_outliers(const std::vector<MotionPair>& pairs, double tz_m, double floor_m, PlanarHandEyeResult& r) {
  std::vector<double> res;
  for (std::size_t i = 0; i < pairs.size(); ++i)
    if (r.inlier[i]) res.push_back(pair_residual(pairs[i], tz_m, r));
  std::nth_element(res.begin(), res.begin() + static_cast<long>(res.size() / 2), res.end());
  const double gate = std::max(floor_m, 3.0 * res[res.size() / 2]);
  bool changed = false;
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    if (r.inlier[i] && pair_residual(pairs[i], tz_m, r) > gate) r.inlier[i] = false, changed = true;
  }
  return changed;
}

}  // namespace

PlanarHandEyeResult solve_planar_hand_eye(const std::vector<MotionPair>& pairs, double tz_m,
                                          const HandEyeConfig& config) {
  PlanarHandEyeResult result;
  result.inlier.assign(pairs.size(), false);
  // Turn angles must agree: a pair whose LiDAR registration failed shows it here first.
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const double turn_a = yaw_of(pairs[i].T_insl0_insl1.linear());
    const double turn_b = yaw_of(pairs[i].T_lev0_lev1.linear());
    result.inlier[i] = std::abs(wrap_pi(turn_a - turn_b)) * kDegPerRad <= config.max_angle_mismatch_deg;
  }
  const double min_turn_rad = config.min_pair_turn_deg * kRadPerDeg;
  for (int round = 0; round < 4; ++round) {
    int n_in = 0, n_turn = 0;
    for (std::size_t i = 0; i < pairs.size(); ++i) {
      if (!result.inlier[i]) continue;
      ++n_in;
      n_turn += std::abs(yaw_of(pairs[i].T_insl0_insl1.linear())) >= min_turn_rad;
    }
    if (n_in < 2) return result;  // valid = false
    result.lever_arm_observed = n_turn >= 2;
    solve_inliers(pairs, tz_m, result.lever_arm_observed, result);
    if (!drop_outliers(pairs, tz_m, config.max_residual_m, result)) break;
  }
  double sum2 = 0.0;
  int n_in = 0;
  for (std::size_t i = 0; i < pairs.size(); ++i)
    if (result.inlier[i]) sum2 += std::pow(pair_residual(pairs[i], tz_m, result), 2), ++n_in;
  result.valid = n_in >= 2;
  result.rms_m = n_in > 0 ? std::sqrt(sum2 / n_in) : 0.0;
  return result;
}

}  // namespace insalign
