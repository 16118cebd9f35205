#include "core/global_init.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <numeric>
#include <random>
#include <sstream>
#include <unordered_map>
#include <unordered_set>

#include <Eigen/Eigenvalues>
#include <tbb/parallel_for.h>

#include "core/deskew.hpp"
#include "core/errors.hpp"

namespace insalign {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kSweepSpan_s = 0.12;  // one revolution plus a margin: poses must cover it to deskew

Mat3 rot_z(double yaw_rad) { return Eigen::AngleAxisd(yaw_rad, Vec3::UnitZ()).toRotationMatrix(); }
double rotation_angle_deg(const Mat3& R) { return so3_log(R).norm() * kDegPerRad; }
// Rotation about z of a nearly planar rotation.
double yaw_of(const Mat3& R) { return std::atan2(R(1, 0), R(0, 0)); }
double wrap_pi(double a) { return std::remainder(a, 2.0 * kPi); }

std::string fmt(const char* format, double a, double b = 0, double c = 0, double d = 0) {
  char buf[256];
  std::snprintf(buf, sizeof buf, format, a, b, c, d);
  return buf;
}

// A loaded frame, reduced: one raw point per voxel (keeping its time, so it can still be deskewed).
struct Frame {
  std::size_t index = 0;
  Sweep sweep;           // reduced
  GroundPlane ground;
  Iso3 T_world_ins = Iso3::Identity();  // at the frame time, time offset 0
  std::vector<char> off_ground;         // per reduced point: farther than the clearance from the ground
};

Sweep reduce_sweep(const Sweep& in, const GlobalInitConfig& config) {
  Sweep out;
  out.name = in.name;
  out.t_end_s = in.t_end_s;
  std::unordered_set<std::uint64_t> seen;
  seen.reserve(in.size() / 4);
  const double min2 = config.min_range_m * config.min_range_m, max2 = config.max_range_m * config.max_range_m;
  for (std::size_t i = 0; i < in.size(); ++i) {
    const Vec3f& p = in.p_lidar[i];
    const double r2 = p.squaredNorm();
    if (!(r2 >= min2 && r2 <= max2)) continue;  // also drops NaN
    const auto q = [&](float v) {
      return static_cast<std::uint64_t>(static_cast<std::int64_t>(std::floor(v / config.voxel_m)) + (1 << 20)) & 0x1FFFFF;
    };
    if (!seen.insert((q(p.x()) << 42) | (q(p.y()) << 21) | q(p.z())).second) continue;
    out.p_lidar.push_back(p);
    if (in.has_time()) out.dt_s.push_back(in.dt_s[i]);
  }
  return out;
}

std::vector<Vec3> to_vec3(const std::vector<Vec3f>& points) {
  std::vector<Vec3> out(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) out[i] = points[i].cast<double>();
  return out;
}

// Sum over groups of the occupied voxels of each group's stitched off-ground points.
double score_candidate(const std::vector<Frame>& frames, const std::vector<std::vector<int>>& groups,
                       const PoseStream& poses, const Iso3& T_ins_lidar, double voxel_m) {
  double total = 0.0;
  for (const auto& group : groups) {
    std::vector<Vec3> p_world;
    for (int f : group) {
      const Frame& frame = frames[static_cast<std::size_t>(f)];
      std::vector<Vec3f> placed;
      try {
        placed = sweep_to_world(frame.sweep, poses, T_ins_lidar);
      } catch (const OutOfRangeError&) {
        continue;
      }
      for (std::size_t i = 0; i < placed.size(); ++i)
        if (frame.off_ground[i]) p_world.push_back(placed[i].cast<double>());
    }
    total += occupancy_score(p_world, voxel_m);
  }
  return total;
}

// Indices into `eligible`, n of them, evenly spaced by path length between positions a and b.
std::vector<std::size_t> spread_by_path(const std::vector<double>& path_m, std::size_t a, std::size_t b, int n) {
  std::vector<std::size_t> out;
  if (n <= 0 || b < a) return out;
  const double s0 = path_m[a], s1 = path_m[b];
  for (int k = 0; k < n; ++k) {
    const double target = n == 1 ? 0.5 * (s0 + s1) : s0 + (s1 - s0) * k / (n - 1);
    std::size_t best = a;
    for (std::size_t i = a; i <= b; ++i)
      if (std::abs(path_m[i] - target) < std::abs(path_m[best] - target)) best = i;
    if (out.empty() || out.back() != best) out.push_back(best);
  }
  return out;
}

}  // namespace

double occupancy_score(const std::vector<Vec3>& p_world, double voxel_m) {
  std::unordered_set<std::uint64_t> occupied;
  occupied.reserve(p_world.size());
  for (const Vec3& p : p_world) {
    const auto q = [voxel_m](double v) {
      return static_cast<std::uint64_t>(static_cast<std::int64_t>(std::floor(v / voxel_m)) + (1 << 20)) & 0x1FFFFF;
    };
    occupied.insert((q(p.x()) << 42) | (q(p.y()) << 21) | q(p.z()));
  }
  return static_cast<double>(occupied.size());
}

GroundPlane fit_ground_plane(const std::vector<Vec3>& p_lidar, const GlobalInitConfig& config, unsigned seed) {
  GroundPlane best;
  // Candidates: points within 25 m horizontally (the ground nearby is densest and flattest).
  std::vector<Vec3> pts;
  for (const Vec3& p : p_lidar)
    if (p.head<2>().squaredNorm() < 25.0 * 25.0) pts.push_back(p);
  if (pts.size() < 50) return best;
  std::mt19937 rng(seed);
  // Score on a subsample: RANSAC only needs the inlier fraction.
  std::vector<Vec3> sample;
  const std::size_t stride = std::max<std::size_t>(1, pts.size() / 4000);
  for (std::size_t i = 0; i < pts.size(); i += stride) sample.push_back(pts[i]);
  std::uniform_int_distribution<std::size_t> pick(0, pts.size() - 1);
  const double cos_tilt = std::cos(config.max_tilt_deg * kRadPerDeg);
  Vec3 best_n = Vec3::UnitZ();
  double best_d = 0.0;
  int best_count = 0;
  for (int it = 0; it < config.ground_ransac_iterations; ++it) {
    const Vec3 a = pts[pick(rng)], b = pts[pick(rng)], c = pts[pick(rng)];
    Vec3 n = (b - a).cross(c - a);
    if (n.norm() < 1e-6) continue;
    n.normalize();
    if (n.z() < 0) n = -n;  // up, in the LiDAR frame (tilt is limited)
    if (n.z() < cos_tilt) continue;
    const double d = -n.dot(a);  // n.p + d = 0; d = height of the origin above the plane
    if (d < 0.3 || d > 6.0) continue;  // the ground is below the sensor
    int count = 0;
    for (const Vec3& p : sample) count += std::abs(n.dot(p) + d) < config.ground_inlier_m;
    if (count > best_count) {
      best_count = count;
      best_n = n;
      best_d = d;
    }
  }
  if (best_count < 30) return best;
  // Least-squares refit on all inliers, twice (the refit may gain inliers).
  for (int round = 0; round < 2; ++round) {
    Vec3 mean = Vec3::Zero();
    int n_in = 0;
    for (const Vec3& p : pts)
      if (std::abs(best_n.dot(p) + best_d) < config.ground_inlier_m) {
        mean += p;
        ++n_in;
      }
    if (n_in < 30) return best;
    mean /= n_in;
    Mat3 cov = Mat3::Zero();
    for (const Vec3& p : pts)
      if (std::abs(best_n.dot(p) + best_d) < config.ground_inlier_m) cov += (p - mean) * (p - mean).transpose();
    Eigen::SelfAdjointEigenSolver<Mat3> eig(cov);
    Vec3 n = eig.eigenvectors().col(0);
    if (n.z() < 0) n = -n;
    best_n = n;
    best_d = -n.dot(mean);
    best.inliers = n_in;
  }
  best.normal = best_n;
  best.height_m = best_d;
  best.valid = best_d > 0.3;
  return best;
}

Mat3 levelling_rotation(const Vec3& normal_lidar) {
  return Eigen::Quaterniond::FromTwoVectors(normal_lidar.normalized(), Vec3::UnitZ()).toRotationMatrix();
}

PlanarHandEyeResult solve_planar_hand_eye(const std::vector<MotionPair>& pairs, double tz_m,
                                          const GlobalInitConfig& config) {
  PlanarHandEyeResult result;
  result.inlier.assign(pairs.size(), false);
  // Turn angles must agree: a pair whose LiDAR registration failed shows it here first.
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const double turn_a = yaw_of(pairs[i].T_ins0_ins1.linear());
    const double turn_b = yaw_of(pairs[i].T_lev0_lev1.linear());
    result.inlier[i] = std::abs(wrap_pi(turn_a - turn_b)) * kDegPerRad <= config.max_angle_mismatch_deg;
  }
  auto solve = [&](bool with_lever_arm) {
    // Unknowns (tx, ty, cos, sin) or (cos, sin); two rows (x, y) per pair.
    const int n_unknown = with_lever_arm ? 4 : 2;
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(n_unknown, n_unknown);
    Eigen::VectorXd g = Eigen::VectorXd::Zero(n_unknown);
    for (std::size_t i = 0; i < pairs.size(); ++i) {
      if (!result.inlier[i]) continue;
      const Mat3 RA = pairs[i].T_ins0_ins1.linear();
      const Vec3 tA = pairs[i].T_ins0_ins1.translation();
      const Vec3 tB = pairs[i].T_lev0_lev1.translation();
      Eigen::Matrix<double, 2, 4> J;
      J << RA(0, 0) - 1.0, RA(0, 1), -tB.x(), tB.y(),
           RA(1, 0), RA(1, 1) - 1.0, -tB.y(), -tB.x();
      const Eigen::Vector2d rhs(-tA.x() - RA(0, 2) * tz_m, -tA.y() - RA(1, 2) * tz_m);
      const Eigen::MatrixXd Ji = with_lever_arm ? Eigen::MatrixXd(J) : Eigen::MatrixXd(J.rightCols<2>());
      H += Ji.transpose() * Ji;
      g += Ji.transpose() * rhs;
    }
    const Eigen::VectorXd x = H.ldlt().solve(g);
    const Eigen::Vector2d cs = x.tail<2>();
    result.yaw_rad = std::atan2(cs.y(), cs.x());
    result.t_xy_m = with_lever_arm ? Eigen::Vector2d(x.head<2>()) : Eigen::Vector2d::Zero();
    // With the yaw normalised onto the circle, re-solve the lever arm alone.
    if (with_lever_arm) {
      Eigen::Matrix2d H2 = Eigen::Matrix2d::Zero();
      Eigen::Vector2d g2 = Eigen::Vector2d::Zero();
      const Eigen::Matrix2d Rz2 = rot_z(result.yaw_rad).topLeftCorner<2, 2>();
      for (std::size_t i = 0; i < pairs.size(); ++i) {
        if (!result.inlier[i]) continue;
        const Mat3 RA = pairs[i].T_ins0_ins1.linear();
        const Vec3 tA = pairs[i].T_ins0_ins1.translation();
        const Eigen::Matrix2d J2 = RA.topLeftCorner<2, 2>() - Eigen::Matrix2d::Identity();
        const Eigen::Vector2d rhs = Rz2 * pairs[i].T_lev0_lev1.translation().head<2>() - tA.head<2>() -
                                    RA.topRightCorner<2, 1>() * tz_m;
        H2 += J2.transpose() * J2;
        g2 += J2.transpose() * rhs;
      }
      result.t_xy_m = H2.ldlt().solve(g2);
    }
  };
  auto residual = [&](std::size_t i) {
    const Mat3 RA = pairs[i].T_ins0_ins1.linear();
    const Vec3 tX(result.t_xy_m.x(), result.t_xy_m.y(), tz_m);
    const Vec3 lhs = RA * tX + pairs[i].T_ins0_ins1.translation();
    const Vec3 rhs = rot_z(result.yaw_rad) * pairs[i].T_lev0_lev1.translation() + tX;
    return (lhs - rhs).head<2>().norm();
  };
  const double min_turn_rad = config.min_pair_turn_deg * kRadPerDeg;
  for (int round = 0; round < 4; ++round) {
    int n_in = 0, n_turn = 0;
    for (std::size_t i = 0; i < pairs.size(); ++i) {
      if (!result.inlier[i]) continue;
      ++n_in;
      n_turn += std::abs(yaw_of(pairs[i].T_ins0_ins1.linear())) >= min_turn_rad;
    }
    if (n_in < 2) {
      result.valid = false;
      return result;
    }
    result.lever_arm_observed = n_turn >= 2;
    solve(result.lever_arm_observed);
    // Drop pairs far off the consensus (gross registration failures), then solve again.
    std::vector<double> res;
    for (std::size_t i = 0; i < pairs.size(); ++i)
      if (result.inlier[i]) res.push_back(residual(i));
    std::nth_element(res.begin(), res.begin() + static_cast<long>(res.size() / 2), res.end());
    const double gate = std::max(config.max_residual_m, 3.0 * res[res.size() / 2]);
    bool changed = false;
    for (std::size_t i = 0; i < pairs.size(); ++i)
      if (result.inlier[i] && residual(i) > gate) {
        result.inlier[i] = false;
        changed = true;
      }
    if (!changed) break;
  }
  double sum2 = 0.0;
  int n_in = 0;
  for (std::size_t i = 0; i < pairs.size(); ++i)
    if (result.inlier[i]) {
      sum2 += std::pow(residual(i), 2);
      ++n_in;
    }
  result.valid = n_in >= 2;
  result.rms_m = n_in > 0 ? std::sqrt(sum2 / n_in) : 0.0;
  return result;
}

namespace {

GlobalInitResult initialise_from_data(const Dataset& data, const std::optional<Iso3>& T_ins_lidar_init,
                                      const GlobalInitConfig& config) {
  const auto t_start = std::chrono::steady_clock::now();
  GlobalInitResult result;
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count(); };
  if (T_ins_lidar_init && config.trust_init) {
    result.T_ins_lidar = *T_ins_lidar_init;
    result.source = "init";
    result.explanation = "init trusted as given (trust_init): not checked against the data";
    result.candidates.push_back({*T_ins_lidar_init, 0.0, "init"});
    result.wall_time_s = elapsed();
    return result;
  }

  // --- Frames the poses cover (with the whole sweep, so they can be deskewed), and their path length.
  const auto& infos = data.frames.frames;
  std::vector<std::size_t> eligible;
  std::vector<Iso3> T_world_ins_e;
  for (std::size_t i = 0; i < infos.size(); ++i) {
    const double t = infos[i].t_end_s;
    if (data.poses.covers(t) && data.poses.covers(t - kSweepSpan_s)) {
      eligible.push_back(i);
      T_world_ins_e.push_back(data.poses.T_world_ins(t));
    }
  }
  if (eligible.size() < 4)
    throw UnobservableError("global initialisation: fewer than 4 LiDAR frames lie inside the pose file's time span; "
                            "no degree of freedom of the extrinsic can be determined");
  std::vector<double> path_m(eligible.size(), 0.0);
  for (std::size_t k = 1; k < eligible.size(); ++k)
    path_m[k] = path_m[k - 1] + (T_world_ins_e[k].translation() - T_world_ins_e[k - 1].translation()).norm();
  if (path_m.back() < 2.0)
    throw UnobservableError(fmt("global initialisation: the vehicle moves only %.2f m over the drive; yaw and the "
                                "horizontal lever arm of the extrinsic need motion (drive and turn)",
                                path_m.back()));
  std::vector<double> t_e(eligible.size());
  for (std::size_t k = 0; k < eligible.size(); ++k) t_e[k] = infos[eligible[k]].t_end_s;
  const double frame_period_s = (t_e.back() - t_e.front()) / static_cast<double>(eligible.size() - 1);

  // --- Coarse window: the straightest stretch of coarse_stretch_m (least heading change).
  std::size_t win_a = 0, win_b = eligible.size() - 1;
  if (path_m.back() > config.coarse_stretch_m) {
    double best_cost = 1e9;
    for (std::size_t a = 0; a < eligible.size(); a += 2) {
      std::size_t b = a;
      double cost = 0.0;
      while (b + 1 < eligible.size() && path_m[b] - path_m[a] < config.coarse_stretch_m) {
        ++b;
        cost = std::max(cost, rotation_angle_deg(T_world_ins_e[a].linear().transpose() * T_world_ins_e[b].linear()));
      }
      if (path_m[b] - path_m[a] < config.coarse_stretch_m) break;
      if (cost < best_cost) {
        best_cost = cost;
        win_a = a;
        win_b = b;
      }
    }
  }
  const std::vector<std::size_t> coarse_pos = spread_by_path(path_m, win_a, win_b, config.coarse_frames);

  // --- Hand-eye pairs: the sharpest turns first, then the longest straight motions (yaw), no overlap.
  const std::size_t gap = std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(config.pair_dt_s / frame_period_s)));
  struct PairCand { std::size_t a, b; double turn_deg, dist_m; };
  std::vector<PairCand> cands;
  for (std::size_t a = 0; a + gap < eligible.size(); ++a) {
    const std::size_t b = a + gap;
    if (std::abs((t_e[b] - t_e[a]) - gap * frame_period_s) > 0.5 * gap * frame_period_s) continue;  // a hole
    const Iso3 A = T_world_ins_e[a].inverse() * T_world_ins_e[b];
    cands.push_back({a, b, rotation_angle_deg(A.linear()), A.translation().norm()});
  }
  std::vector<std::pair<std::size_t, std::size_t>> pair_pos;
  {
    std::vector<char> used(eligible.size(), 0);
    auto take = [&](const PairCand& c) {
      for (std::size_t k = c.a > gap ? c.a - gap + 1 : 0; k < std::min(eligible.size(), c.a + gap); ++k)
        if (used[k]) return false;
      used[c.a] = 1;
      pair_pos.push_back({c.a, c.b});
      return true;
    };
    std::vector<PairCand> by_turn = cands;
    std::sort(by_turn.begin(), by_turn.end(), [](const PairCand& x, const PairCand& y) { return x.turn_deg > y.turn_deg; });
    const int n_turn_wanted = config.hand_eye_pairs * 2 / 3;
    for (const PairCand& c : by_turn) {
      if (static_cast<int>(pair_pos.size()) >= n_turn_wanted || c.turn_deg < config.min_pair_turn_deg) break;
      if (c.dist_m > 0.3) take(c);
    }
    std::vector<PairCand> by_dist = cands;
    std::sort(by_dist.begin(), by_dist.end(), [](const PairCand& x, const PairCand& y) { return x.dist_m > y.dist_m; });
    for (const PairCand& c : by_dist) {
      if (static_cast<int>(pair_pos.size()) >= config.hand_eye_pairs || c.dist_m < 0.5) break;
      if (c.turn_deg < config.min_pair_turn_deg) take(c);
    }
  }
  const std::vector<std::size_t> level_pos = spread_by_path(path_m, 0, eligible.size() - 1, config.level_frames);

  // --- Load every frame needed once, in parallel.
  std::vector<std::size_t> need(level_pos.begin(), level_pos.end());
  need.insert(need.end(), coarse_pos.begin(), coarse_pos.end());
  for (const auto& [a, b] : pair_pos) {
    need.push_back(a);
    need.push_back(b);
  }
  std::sort(need.begin(), need.end());
  need.erase(std::unique(need.begin(), need.end()), need.end());
  std::vector<Frame> frames(need.size());
  std::unordered_map<std::size_t, int> slot_of;  // position in `eligible` -> frames[]
  for (std::size_t f = 0; f < need.size(); ++f) slot_of[need[f]] = static_cast<int>(f);
  tbb::parallel_for(std::size_t{0}, need.size(), [&](std::size_t f) {
    Frame& frame = frames[f];
    frame.index = eligible[need[f]];
    frame.T_world_ins = T_world_ins_e[need[f]];
    frame.sweep = reduce_sweep(data.frames.load(frame.index), config);
    frame.ground = fit_ground_plane(to_vec3(frame.sweep.p_lidar), config, static_cast<unsigned>(frame.index + 1));
  });
  result.frames_loaded = static_cast<int>(frames.size());
  result.load_s = elapsed();

  // --- 1. Levelling: mean ground normal in the LiDAR frame vs the mean INS vertical.
  std::vector<Vec3> normals;
  Vec3 up_ins_sum = Vec3::Zero();
  double height_sum = 0.0;
  for (const Frame& frame : frames)
    if (frame.ground.valid) normals.push_back(frame.ground.normal);
  if (normals.size() < 2)
    throw UnobservableError("global initialisation: no ground plane found below the LiDAR in the frames used; roll "
                            "and pitch of the extrinsic cannot be started from the data (give --init)");
  // Robust mean: drop normals far from the component-wise median (a ramp, a wall taken for ground).
  Vec3 median_n;
  for (int ax = 0; ax < 3; ++ax) {
    std::vector<double> v;
    for (const Vec3& n : normals) v.push_back(n[ax]);
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    median_n[ax] = v[v.size() / 2];
  }
  median_n.normalize();
  Vec3 n_sum = Vec3::Zero();
  int n_used = 0;
  for (Frame& frame : frames) {
    if (!frame.ground.valid) continue;
    if (std::acos(std::clamp(frame.ground.normal.dot(median_n), -1.0, 1.0)) * kDegPerRad > 3.0) {
      frame.ground.valid = false;
      continue;
    }
    n_sum += frame.ground.normal;
    up_ins_sum += frame.T_world_ins.linear().transpose() * Vec3::UnitZ();
    height_sum += frame.ground.height_m;
    ++n_used;
  }
  const Vec3 n_lidar = n_sum.normalized();
  const Vec3 up_ins = up_ins_sum.normalized();
  result.ground_normal_lidar = n_lidar;
  result.lidar_height_m = height_sum / n_used;
  {
    double s2 = 0.0;
    for (const Frame& frame : frames)
      if (frame.ground.valid) s2 += std::pow(std::acos(std::clamp(frame.ground.normal.dot(n_lidar), -1.0, 1.0)), 2);
    result.ground_normal_spread_deg = std::sqrt(s2 / n_used) * kDegPerRad;
  }
  const Mat3 R_lev_lidar = levelling_rotation(n_lidar);
  // The INS may itself be tilted on the vehicle: work in a levelled INS frame ins' (R_ins_insl).
  const Mat3 R_ins_insl = Eigen::Quaterniond::FromTwoVectors(Vec3::UnitZ(), up_ins).toRotationMatrix();
  // Mark off-ground points (scores leave the ground out: it is crisp under any yaw).
  for (Frame& frame : frames) {
    const Vec3 n = frame.ground.valid ? frame.ground.normal : n_lidar;
    const double h = frame.ground.valid ? frame.ground.height_m : result.lidar_height_m;
    frame.off_ground.resize(frame.sweep.size());
    for (std::size_t i = 0; i < frame.sweep.size(); ++i)
      frame.off_ground[i] = n.dot(frame.sweep.p_lidar[i].cast<double>()) + h > config.ground_clearance_m;
  }

  // --- z: LiDAR height above ground minus INS height above ground (fiducials, else a typical mount).
  double ins_height_m = config.ins_height_guess_m;
  std::string z_how = fmt("INS assumed %.2f m above the ground (no fiducials; stage 3 fixes z)", ins_height_m);
  if (!data.fiducials.empty()) {
    double sum = 0.0;
    int count = 0;
    for (const Frame& frame : frames) {
      const Vec3 p_ins = frame.T_world_ins.translation();
      const Fiducial* nearest = nullptr;
      for (const Fiducial& f : data.fiducials)
        if (!nearest || (f.p_world - p_ins).head<2>().norm() < (nearest->p_world - p_ins).head<2>().norm()) nearest = &f;
      if ((nearest->p_world - p_ins).head<2>().norm() < 30.0) {
        sum += p_ins.z() - nearest->p_world.z();
        ++count;
      }
    }
    if (count > 0) {
      ins_height_m = sum / count;
      z_how = fmt("INS %.2f m above the ground (nearest fiducials)", ins_height_m);
    }
  }
  const double tz_insl_m = result.lidar_height_m - ins_height_m;
  auto make_X = [&](double yaw_rad, const Eigen::Vector2d& t_xy_insl) {
    Iso3 X = Iso3::Identity();
    X.linear() = R_ins_insl * rot_z(yaw_rad) * R_lev_lidar;
    X.translation() = R_ins_insl * Vec3(t_xy_insl.x(), t_xy_insl.y(), tz_insl_m);
    return X;
  };

  // --- 2. Coarse yaw: crispness of the straight stretch's frames (lever arm irrelevant there).
  std::vector<std::vector<int>> coarse_group(1);
  for (std::size_t p : coarse_pos) coarse_group[0].push_back(slot_of.at(p));
  std::vector<std::vector<Vec3>> coarse_lev(coarse_pos.size());  // off-ground points, levelled LiDAR frame
  for (std::size_t c = 0; c < coarse_pos.size(); ++c) {
    const Frame& frame = frames[static_cast<std::size_t>(coarse_group[0][c])];
    for (std::size_t i = 0; i < frame.sweep.size(); ++i)
      if (frame.off_ground[i]) coarse_lev[c].push_back(R_lev_lidar * frame.sweep.p_lidar[i].cast<double>());
    coarse_lev[c] = voxel_centroids(coarse_lev[c], config.coarse_voxel_m);
  }
  auto coarse_score = [&](double yaw_rad) {
    std::vector<Vec3> p_world;
    const Mat3 R = rot_z(yaw_rad);
    for (std::size_t c = 0; c < coarse_pos.size(); ++c) {
      const Iso3& T_world_ins = frames[static_cast<std::size_t>(coarse_group[0][c])].T_world_ins;
      const Mat3 R_w = T_world_ins.linear() * R_ins_insl;
      const Vec3 t_w = T_world_ins.translation() + R_w * Vec3(0, 0, tz_insl_m);
      for (const Vec3& q : coarse_lev[c]) p_world.push_back(R_w * (R * q) + t_w);
    }
    return occupancy_score(p_world, config.crispness_voxel_m);
  };
  const int n_yaw = std::max(4, static_cast<int>(std::lround(360.0 / config.coarse_yaw_step_deg)));
  std::vector<double> yaw_scores(static_cast<std::size_t>(n_yaw));
  tbb::parallel_for(0, n_yaw, [&](int k) { yaw_scores[static_cast<std::size_t>(k)] = coarse_score(2.0 * kPi * k / n_yaw); });
  const int best_k = static_cast<int>(std::min_element(yaw_scores.begin(), yaw_scores.end()) - yaw_scores.begin());
  double coarse_yaw = 2.0 * kPi * best_k / n_yaw;
  {  // refine to 1 deg around the best step
    const double step = 2.0 * kPi / n_yaw;
    const int n_fine = std::max(1, static_cast<int>(std::lround(step * kDegPerRad)));
    std::vector<double> fine(static_cast<std::size_t>(2 * n_fine + 1));
    tbb::parallel_for(0, 2 * n_fine + 1, [&](int k) {
      fine[static_cast<std::size_t>(k)] = coarse_score(coarse_yaw + (k - n_fine) * step / n_fine);
    });
    const int best_f = static_cast<int>(std::min_element(fine.begin(), fine.end()) - fine.begin());
    coarse_yaw = wrap_pi(coarse_yaw + (best_f - n_fine) * step / n_fine);
  }
  result.coarse_yaw_deg = coarse_yaw * kDegPerRad;
  result.coarse_s = elapsed() - result.load_s;
  const Iso3 X_coarse = make_X(coarse_yaw, Eigen::Vector2d::Zero());

  // --- 3. Planar hand-eye: register pairs (deskewed with the coarse extrinsic) from the INS prediction.
  std::vector<MotionPair> motions(pair_pos.size());
  std::vector<char> registered(pair_pos.size(), 0);
  Iso3 T_insl_ins = Iso3::Identity();
  T_insl_ins.linear() = R_ins_insl.transpose();
  Iso3 T_lidar_lev = Iso3::Identity();
  T_lidar_lev.linear() = R_lev_lidar.transpose();
  tbb::parallel_for(std::size_t{0}, pair_pos.size(), [&](std::size_t k) {
    const Frame& fa = frames[static_cast<std::size_t>(slot_of.at(pair_pos[k].first))];
    const Frame& fb = frames[static_cast<std::size_t>(slot_of.at(pair_pos[k].second))];
    std::vector<Vec3> target, source;
    try {
      target = voxel_centroids(to_vec3(deskew_sweep(fa.sweep, data.poses, X_coarse)), config.icp_target_voxel_m);
      source = voxel_centroids(to_vec3(deskew_sweep(fb.sweep, data.poses, X_coarse)), config.icp_source_voxel_m);
    } catch (const OutOfRangeError&) {
      return;
    }
    const Iso3 A = fa.T_world_ins.inverse() * fb.T_world_ins;
    const Iso3 B_pred = X_coarse.inverse() * A * X_coarse;
    const ScanRegistrationResult reg = register_scans(target, source, B_pred, config.icp);
    if (!reg.converged) return;
    motions[k].T_ins0_ins1 = T_insl_ins * A * T_insl_ins.inverse();
    motions[k].T_lev0_lev1 = T_lidar_lev.inverse() * reg.T_target_source * T_lidar_lev;
    registered[k] = 1;
  });
  std::vector<MotionPair> good;
  for (std::size_t k = 0; k < motions.size(); ++k)
    if (registered[k]) good.push_back(motions[k]);
  const PlanarHandEyeResult he = solve_planar_hand_eye(good, tz_insl_m, config);
  result.hand_eye_s = elapsed() - result.load_s - result.coarse_s;
  Iso3 X_data = X_coarse;
  std::string data_how;
  if (he.valid) {
    X_data = make_X(he.yaw_rad, he.t_xy_m);
    result.hand_eye_pairs_used = static_cast<int>(std::count(he.inlier.begin(), he.inlier.end(), true));
    result.hand_eye_rms_m = he.rms_m;
    result.lever_arm_observed = he.lever_arm_observed;
    data_how = fmt("hand-eye over %.0f of %.0f registered pairs (%.0f selected), residual rms %.3f m", result.hand_eye_pairs_used,
                   static_cast<double>(good.size()), static_cast<double>(pair_pos.size()), he.rms_m);
    if (!he.lever_arm_observed) data_how += "; no turns: horizontal lever arm not observed, set to 0";
  } else {
    data_how = fmt("hand-eye failed (%.0f of %.0f pairs registered): coarse yaw, horizontal lever arm 0",
                   static_cast<double>(good.size()), static_cast<double>(pair_pos.size()));
  }

  // --- 4. Scores of the candidates: crispness of the coarse stretch and of every pair.
  std::vector<std::vector<int>> groups = coarse_group;
  for (const auto& [a, b] : pair_pos) groups.push_back({slot_of.at(a), slot_of.at(b)});
  auto rotated = [&](const Iso3& X, double deg) {  // the INS axes turned about the vertical
    Iso3 Rz = Iso3::Identity();
    Rz.linear() = R_ins_insl * rot_z(deg * kRadPerDeg) * R_ins_insl.transpose();
    return Rz * X;
  };
  std::vector<InitCandidate> cand = {{X_data, 0, "data"},
                                     {rotated(X_data, 90), 0, "data-yaw+90"},
                                     {rotated(X_data, 180), 0, "data-yaw+180"},
                                     {rotated(X_data, -90), 0, "data-yaw-90"}};
  if (he.valid) cand.push_back({X_coarse, 0, "data-coarse"});
  if (T_ins_lidar_init) cand.push_back({*T_ins_lidar_init, 0, "init"});
  tbb::parallel_for(std::size_t{0}, cand.size(), [&](std::size_t k) {
    cand[k].score = score_candidate(frames, groups, data.poses, cand[k].T_ins_lidar, config.crispness_voxel_m);
  });
  result.candidates = cand;
  result.score_s = elapsed() - result.load_s - result.coarse_s - result.hand_eye_s;
  // The best of the data's candidates (normally "data" itself).
  std::size_t best = 0;
  for (std::size_t k = 0; k < cand.size(); ++k)
    if (cand[k].label != "init" && cand[k].score < cand[best].score) best = k;

  std::ostringstream why;
  why << fmt("levelled from %.0f ground planes (normal spread %.2f deg, LiDAR %.2f m above ground); ", n_used,
             result.ground_normal_spread_deg, result.lidar_height_m)
      << fmt("coarse yaw %.1f deg by crispness of %.0f frames over %.1f m; ", result.coarse_yaw_deg,
             static_cast<double>(coarse_pos.size()), path_m[win_b] - path_m[win_a])
      << data_how << "; z: " << z_how << ". Scores (occupied " << config.crispness_voxel_m
      << " m voxels, lower is crisper):";
  for (const InitCandidate& c : cand) why << " " << c.label << " " << c.score;
  why << ".";

  if (!T_ins_lidar_init) {
    result.T_ins_lidar = cand[best].T_ins_lidar;
    result.source = "data";
    why << " No init given: chose " << cand[best].label << ".";
  } else {
    const InitCandidate& init = cand.back();
    const ExtrinsicError diff = extrinsic_error(init.T_ins_lidar, cand[best].T_ins_lidar);
    const bool same_basin = diff.angle_deg < config.same_basin_rot_deg && diff.dt_norm_m < config.same_basin_trans_m;
    why << " Init differs from " << cand[best].label << fmt(" by %.1f deg and %.2f m", diff.angle_deg, diff.dt_norm_m);
    if (same_basin) {
      result.T_ins_lidar = *T_ins_lidar_init;
      result.source = "init";
      why << ": same basin, init confirmed.";
    } else if (init.score > config.override_score_ratio * cand[best].score) {
      result.T_ins_lidar = cand[best].T_ins_lidar;
      result.source = "data-overrides-init";
      why << ": the data clearly prefers " << cand[best].label
          << fmt(" (init scores %.3f times worse, threshold %.3f); continuing from the data.",
                 init.score / cand[best].score, config.override_score_ratio);
    } else {
      result.T_ins_lidar = *T_ins_lidar_init;
      result.source = "init";
      why << fmt(": the data does not clearly prefer another basin (score ratio init/data %.3f <= %.3f); init kept.",
                 init.score / cand[best].score, config.override_score_ratio);
    }
  }
  result.explanation = why.str();
  result.wall_time_s = elapsed();
  return result;
}

}  // namespace

GlobalInitResult initialise_extrinsic(const Dataset& data, const std::optional<Iso3>& T_ins_lidar_init,
                                      const GlobalInitConfig& config) {
  const auto t_start = std::chrono::steady_clock::now();
  try {
    return initialise_from_data(data, T_ins_lidar_init, config);
  } catch (const UnobservableError& e) {
    if (!T_ins_lidar_init) throw;
    // The data cannot check the init; later stages judge observability themselves.
    GlobalInitResult result;
    result.T_ins_lidar = *T_ins_lidar_init;
    result.source = "init";
    result.explanation = std::string("init kept unchecked: ") + e.what();
    result.candidates.push_back({*T_ins_lidar_init, 0.0, "init"});
    result.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
    return result;
  }
}

}  // namespace insalign
