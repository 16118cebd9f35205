#include "core/z_surface.hpp"

#include <tbb/parallel_for.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <fmt/format.h>

#include "core/deskew.hpp"
#include "core/stats.hpp"

namespace insalign {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The points of one loaded frame that each wanted target gets.
void hand_out(const Sweep& sweep, const std::vector<Vec3f>& p_world, const Vec3& up, const std::vector<Target>& targets,
              const std::vector<std::size_t>& wanted, float min_range_sq, std::vector<LocalMap>& maps) {
  for (std::size_t i = 0; i < p_world.size(); ++i) {
    if (sweep.p_lidar[i].squaredNorm() < min_range_sq || !p_world[i].allFinite()) continue;
    const Vec3 p = p_world[i].cast<double>();
    for (std::size_t t : wanted) {
      if ((p.head<2>() - targets[t].centre_xy).squaredNorm() > targets[t].radius_m * targets[t].radius_m) continue;
      maps[t].p_world.push_back(p);
      maps[t].up_sum += up;
    }
  }
}

// Height of the densest 5 cm bin, smoothed over its neighbours.
double densest_height(const std::vector<Vec3>& pts) {
  double z_lo = pts[0].z(), z_hi = pts[0].z();
  for (const Vec3& p : pts) z_lo = std::min(z_lo, p.z()), z_hi = std::max(z_hi, p.z());
  constexpr double kBin_m = 0.05;
  const std::size_t bins = static_cast<std::size_t>((z_hi - z_lo) / kBin_m) + 1;
  std::vector<int> hist(bins, 0);
  for (const Vec3& p : pts) ++hist[static_cast<std::size_t>((p.z() - z_lo) / kBin_m)];
  std::size_t best = 0;
  int best_count = -1;
  for (std::size_t b = 0; b < bins; ++b) {
    const int c = hist[b] + (b > 0 ? hist[b - 1] : 0) + (b + 1 < bins ? hist[b + 1] : 0);
    if (c > best_count) best_count = c, best = b;
  }
  return z_lo + (static_cast<double>(best) + 0.5) * kBin_m;
}

// z = a dx + b dy + c, refitted on the points within a shrinking window (3 robust sigma).
struct PlaneFit {
  double a = 0, b = 0, c = 0;
  double sigma_r = kNaN;
  std::size_t inliers = 0;
  Eigen::Matrix3d normal_matrix = Eigen::Matrix3d::Zero();
};
PlaneFit robust_plane(const std::vector<Vec3>& pts, const Eigen::Vector2d& centre_xy, double z0, double window,
                      std::size_t min_points) {
  PlaneFit fit;
  fit.c = z0;
  auto residual = [&](const Vec3& p) {
    const Eigen::Vector2d d = p.head<2>() - centre_xy;
    return p.z() - (fit.a * d.x() + fit.b * d.y() + fit.c);
  };
  for (int round = 0; round < 5; ++round) {
    Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
    Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
    std::vector<const Vec3*> in;
    for (const Vec3& p : pts) {
      if (std::abs(residual(p)) > window) continue;
      const Eigen::Vector3d row(p.x() - centre_xy.x(), p.y() - centre_xy.y(), 1.0);
      A += row * row.transpose();
      rhs += row * p.z();
      in.push_back(&p);
    }
    fit.inliers = in.size();
    if (in.size() < std::max<std::size_t>(min_points, 3)) break;
    // Points all in one spot (one ring segment) leave the slope undetermined: damp it weakly.
    A(0, 0) += 1e-3 * double(in.size());
    A(1, 1) += 1e-3 * double(in.size());
    const Eigen::Vector3d x = A.ldlt().solve(rhs);
    fit.a = x(0), fit.b = x(1), fit.c = x(2);
    fit.normal_matrix = A;
    std::vector<double> abs_r;
    abs_r.reserve(in.size());
    for (const Vec3* p : in) abs_r.push_back(std::abs(residual(*p)));
    fit.sigma_r = std::max(1.4826 * median(abs_r), 0.002);  // floor: a perfectly flat sim surface
    window = 3.0 * fit.sigma_r;
  }
  return fit;
}

}  // namespace

void LocalMap::append(const LocalMap& other) {
  p_world.insert(p_world.end(), other.p_world.begin(), other.p_world.end());
  up_sum += other.up_sum;
  frames += other.frames;
}

namespace {

// How far any point of `part` can move between its placements with (a) and (b): the change of
// the LiDAR pose at the sweep's start, middle and end, its rotation acting at the part's farthest
// point, with a half again for the poses between those times.
double placement_change_m(const Sweep& part, const PoseStream& poses, const Iso3& T_a, double offset_a,
                          const Iso3& T_b, double offset_b) {
  float range_m = 0.0f;
  for (const Vec3f& p : part.p_lidar) range_m = std::max(range_m, p.norm());
  const auto [dt_lo, dt_hi] = dt_range(part);
  double change = 0.0;
  for (const double dt : {double(dt_lo), 0.5 * (dt_lo + dt_hi), double(dt_hi)}) {
    const Iso3 A = poses.T_world_ins(part.t_end_s + dt + offset_a) * T_a;
    const Iso3 B = poses.T_world_ins(part.t_end_s + dt + offset_b) * T_b;
    const double turn = Eigen::AngleAxisd(A.linear().transpose() * B.linear()).angle();
    change = std::max(change, (B.translation() - A.translation()).norm() + turn * range_m);
  }
  return 1.5 * change;
}

}  // namespace

const Sweep* NearPoints::find(std::size_t index, const Target& t, const PoseStream& poses, const Iso3& T_ins_lidar,
                              double time_offset_s) const {
  const std::lock_guard lock(mutex_);
  const auto it = parts_.find(key(index, t));
  if (it == parts_.end()) return nullptr;
  const Part& p = it->second;
  if (!sweep_covered(poses, p.sweep, time_offset_s)) return nullptr;  // the sweep's time span: not placed
  const double change = placement_change_m(p.sweep, poses, p.T_ins_lidar, p.time_offset_s, T_ins_lidar, time_offset_s);
  return change < margin_m_ ? &p.sweep : nullptr;  // std::map: the part stays where it is
}

void NearPoints::keep(std::size_t index, const Target& t, const Sweep& raw, const std::vector<Vec3f>& p_world,
                      const Iso3& T_ins_lidar, double time_offset_s) {
  Part part{.sweep = {}, .T_ins_lidar = T_ins_lidar, .time_offset_s = time_offset_s};
  part.sweep.name = raw.name;
  part.sweep.t_end_s = raw.t_end_s;
  std::size_t first = 0, last = 0;  // the earliest and latest point: the part's knots are the sweep's
  if (raw.has_time()) {
    first = std::min_element(raw.dt_s.begin(), raw.dt_s.end()) - raw.dt_s.begin();
    last = std::max_element(raw.dt_s.begin(), raw.dt_s.end()) - raw.dt_s.begin();
  }
  const double r = t.radius_m + margin_m_;
  for (std::size_t i = 0; i < raw.size(); ++i) {
    const bool near = p_world[i].allFinite() && (p_world[i].head<2>().cast<double>() - t.centre_xy).squaredNorm() <= r * r;
    if (!near && !(raw.has_time() && (i == first || i == last))) continue;
    part.sweep.p_lidar.push_back(raw.p_lidar[i]);
    if (raw.has_time()) part.sweep.dt_s.push_back(raw.dt_s[i]);
  }
  const std::lock_guard lock(mutex_);
  parts_.insert_or_assign(key(index, t), std::move(part));
}

namespace {

// The wanted targets of frame `index` handed their points from the parts `near` keeps; false (and
// nothing handed) unless it keeps a valid part for every one.
bool hand_out_kept(const FrameStore& store, std::size_t index, const std::vector<Target>& targets,
                   const std::vector<std::size_t>& wanted, const Iso3& T_ins_lidar, double time_offset_s,
                   float min_range_sq, const NearPoints& near, std::vector<LocalMap>& maps) {
  std::vector<const Sweep*> parts;
  for (std::size_t t : wanted) {
    parts.push_back(near.find(index, targets[t], store.poses(), T_ins_lidar, time_offset_s));
    if (!parts.back()) return false;
  }
  for (std::size_t k = 0; k < wanted.size(); ++k) {
    const Sweep& part = *parts[k];
    const std::vector<Vec3f> p_world =
        sweep_to_world(part, store.poses(), T_ins_lidar, PlaceOptions{.time_offset_s = time_offset_s});
    const Vec3 up = frame_pose(part, store.poses(), time_offset_s).linear().col(2);
    hand_out(part, p_world, up, targets, {wanted[k]}, min_range_sq, maps);
  }
  return true;
}

}  // namespace

std::vector<LocalMap> gather(const FrameStore& store, const std::vector<Target>& targets, const Iso3& T_ins_lidar,
                             double time_offset_s, std::size_t* frames_loaded, NearPoints* near) {
  std::vector<std::size_t> frames;
  for (const Target& t : targets) frames.insert(frames.end(), t.frames.begin(), t.frames.end());
  std::sort(frames.begin(), frames.end());
  frames.erase(std::unique(frames.begin(), frames.end()), frames.end());
  *frames_loaded = frames.size();
  const double min_range = store.base_filter().min_range_m;
  const float min_range_sq = static_cast<float>(min_range * min_range);
  // Per loaded frame, per target: the points it contributes.
  std::vector<std::vector<LocalMap>> per_frame(frames.size(), std::vector<LocalMap>(targets.size()));
  tbb::parallel_for(std::size_t{0}, frames.size(), [&](std::size_t f) {
    std::vector<std::size_t> wanted;
    for (std::size_t t = 0; t < targets.size(); ++t)
      if (std::binary_search(targets[t].frames.begin(), targets[t].frames.end(), frames[f])) wanted.push_back(t);
    if (near && hand_out_kept(store, frames[f], targets, wanted, T_ins_lidar, time_offset_s, min_range_sq, *near,
                              per_frame[f]))
      return;
    // Raw: a fiducial's local plane averages every point near it (the store's copies are thinned).
    const Sweep sweep = store.data().frames.load(frames[f]);
    if (!sweep_covered(store.poses(), sweep, time_offset_s)) return;
    const std::vector<Vec3f> p_world =
        sweep_to_world(sweep, store.poses(), T_ins_lidar, PlaceOptions{.time_offset_s = time_offset_s});
    // Not masked: the moving-point mask hid the ground at fiducials on some drives (accuracy gate
    // seed 21: tz undetermined); fiducial surfaces are fitted robustly instead.
    const Vec3 up = frame_pose(sweep, store.poses(), time_offset_s).linear().col(2);
    hand_out(sweep, p_world, up, targets, wanted, min_range_sq, per_frame[f]);
    if (near)
      for (std::size_t t : wanted) near->keep(frames[f], targets[t], sweep, p_world, T_ins_lidar, time_offset_s);
  });
  std::vector<LocalMap> maps(targets.size());
  for (auto& frame_maps : per_frame) {
    for (std::size_t t = 0; t < targets.size(); ++t) {
      if (!frame_maps[t].p_world.empty()) frame_maps[t].frames = 1;
      maps[t].append(frame_maps[t]);
    }
  }
  return maps;
}

SurfaceHeight fit_surface(const LocalMap& map, const Eigen::Vector2d& centre_xy, FiducialMatch match,
                          std::size_t min_points, double max_slope_deg, double init_window_m) {
  SurfaceHeight out;
  const auto& pts = map.p_world;
  if (pts.size() < min_points) {
    out.problem = pts.empty() ? "no map points near it (occluded, or never within LiDAR view)"
                              : std::to_string(pts.size()) + " map points near it (need " + std::to_string(min_points) + ")";
    out.points = pts.size();
    return out;
  }
  const PlaneFit fit = robust_plane(pts, centre_xy, densest_height(pts), init_window_m, min_points);
  out.points = fit.inliers;
  if (fit.inliers < std::max<std::size_t>(min_points, 3)) {
    out.problem = "only " + std::to_string(fit.inliers) + " map points on a common surface near it (need " +
                  std::to_string(min_points) + ")";
    return out;
  }
  const double slope_deg = std::atan(std::hypot(fit.a, fit.b)) * kDegPerRad;
  if (slope_deg > max_slope_deg) {
    out.problem = fmt::format("the surface near it slopes {:.0f} deg (more than {:.0f}): not ground", slope_deg, max_slope_deg);
    return out;
  }
  // A map point moves by up * dz; on the plane with normal ~(-a, -b, 1) that moves the height at a
  // fixed horizontal position by (up_z - a up_x - b up_y) * dz.
  const Vec3 up = map.mean_up();
  out.dz_gain = up.z() - fit.a * up.x() - fit.b * up.y();
  out.ok = true;
  if (match == FiducialMatch::kLocalPlane) {
    out.z_m = fit.c;
    out.sigma_m = fit.sigma_r * std::sqrt(std::max(fit.normal_matrix.inverse()(2, 2), 0.0));
    return out;
  }
  // The paper: the height of the nearest map point (horizontally), with one point's noise.
  const auto nearest = std::min_element(pts.begin(), pts.end(), [&](const Vec3& p, const Vec3& q) {
    return (p.head<2>() - centre_xy).squaredNorm() < (q.head<2>() - centre_xy).squaredNorm();
  });
  out.z_m = nearest->z();
  out.sigma_m = fit.sigma_r;
  return out;
}

RobustMean robust_mean(const std::vector<DzSample>& s, double floor_m, double mad_factor) {
  RobustMean out;
  std::vector<double> v;
  for (const auto& x : s) v.push_back(x.dz_m);
  const double med = median(v);
  out.threshold_m = std::max(floor_m, mad_factor * robust_sigma(v));
  out.inlier.assign(s.size(), 0);
  double centre = med;
  for (int pass = 0; pass < 2; ++pass) {
    double sw = 0, swx = 0;
    for (std::size_t i = 0; i < s.size(); ++i) {
      out.inlier[i] = std::abs(s[i].dz_m - centre) <= out.threshold_m;
      if (!out.inlier[i]) continue;
      const double w = 1.0 / (s[i].sigma_m * s[i].sigma_m);
      sw += w, swx += w * s[i].dz_m;
    }
    if (sw <= 0) break;
    centre = swx / sw;
  }
  // Standard error: the formal one from the weights, or the scatter if that is larger (the
  // weights do not know about INS drift or a surface that is not quite where it was surveyed).
  double sw = 0, swr = 0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (!out.inlier[i]) continue;
    const double w = 1.0 / (s[i].sigma_m * s[i].sigma_m);
    sw += w, swr += w * (s[i].dz_m - centre) * (s[i].dz_m - centre), ++n;
  }
  out.mean_m = centre;
  const double formal = sw > 0 ? 1.0 / std::sqrt(sw) : kNaN;
  const double scatter = (n > 1 && sw > 0) ? std::sqrt(swr / sw / double(n - 1)) : kNaN;
  out.stddev_m = std::isfinite(scatter) ? std::max(formal, scatter) : formal;
  return out;
}

}  // namespace insalign
