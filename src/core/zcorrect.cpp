#include "core/zcorrect.hpp"

#include <tbb/parallel_for.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numeric>

#include "core/deskew.hpp"

namespace insalign {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
/// Nominal sweep duration used to check that the poses cover a frame before loading it.
constexpr double kSweepDuration_s = 0.1;
/// A height-prior place whose ground height is this uncertain (ground seen on one side only, far
/// from the INS) would only add noise: skipped.
constexpr double kMaxGroundSigma_m = 0.01;

std::string fmt_m(double v, int decimals = 3) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%+.*f m", decimals, v);
  return buf;
}

double median(std::vector<double> v) {
  if (v.empty()) return kNaN;
  const std::size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + mid, v.end());
  const double upper = v[mid];
  if (v.size() % 2 == 1) return upper;
  return 0.5 * (upper + *std::max_element(v.begin(), v.begin() + mid));
}

/// A place where the map surface height is measured: map points within radius_m (horizontal) of
/// centre_xy, from the listed frames.
struct Target {
  Eigen::Vector2d centre_xy = Eigen::Vector2d::Zero();
  double radius_m = 0.0;
  std::vector<std::size_t> frames;  ///< indices into the dataset's frames
};

/// Map points gathered for one target. `up_world` is R_world_ins * e_z of the frame each point came
/// from: the direction a point moves when tz grows (stage-3 model), summed to a mean.
struct LocalMap {
  std::vector<Vec3> p_world;
  Vec3 up_sum = Vec3::Zero();
  std::size_t frames = 0;  ///< frames that contributed points
  Vec3 mean_up() const { return p_world.empty() ? Vec3::UnitZ() : Vec3(up_sum / double(p_world.size())); }
};

bool frame_covered(const Dataset& data, std::size_t i, double time_offset_s) {
  const double t_end = data.frames.frames[i].t_end_s + time_offset_s;
  return data.poses.covers(t_end) && data.poses.covers(t_end - kSweepDuration_s);
}

/// Loads each frame any target needs once (in parallel), places it with per-point deskew and hands
/// every target the points near it. Frames the poses do not cover are skipped.
std::vector<LocalMap> gather(const Dataset& data, const std::vector<Target>& targets, const Iso3& T_ins_lidar,
                             double time_offset_s, double min_range_m, std::size_t* frames_loaded) {
  std::vector<std::size_t> frames;
  for (const Target& t : targets) frames.insert(frames.end(), t.frames.begin(), t.frames.end());
  std::sort(frames.begin(), frames.end());
  frames.erase(std::unique(frames.begin(), frames.end()), frames.end());
  *frames_loaded = frames.size();

  // Per loaded frame, per target: the points it contributes.
  std::vector<std::vector<LocalMap>> per_frame(frames.size(), std::vector<LocalMap>(targets.size()));
  const float min_range_sq = static_cast<float>(min_range_m * min_range_m);
  tbb::parallel_for(std::size_t{0}, frames.size(), [&](std::size_t f) {
    const std::size_t index = frames[f];
    std::vector<std::size_t> wanted;
    for (std::size_t t = 0; t < targets.size(); ++t) {
      if (std::binary_search(targets[t].frames.begin(), targets[t].frames.end(), index)) wanted.push_back(t);
    }
    Sweep sweep = data.frames.load(index);
    std::vector<Vec3f> p_world;
    Vec3 up = Vec3::UnitZ();
    try {
      p_world = sweep_to_world(sweep, data.poses, T_ins_lidar, PlaceOptions{.time_offset_s = time_offset_s});
      up = frame_pose(sweep, data.poses, time_offset_s).linear().col(2);
    } catch (const OutOfRangeError&) {
      return;  // the sweep reaches beyond the poses: not usable
    }
    for (std::size_t i = 0; i < p_world.size(); ++i) {
      if (sweep.p_lidar[i].squaredNorm() < min_range_sq || !p_world[i].allFinite()) continue;
      const Vec3 p = p_world[i].cast<double>();
      for (std::size_t t : wanted) {
        if ((p.head<2>() - targets[t].centre_xy).squaredNorm() > targets[t].radius_m * targets[t].radius_m) continue;
        per_frame[f][t].p_world.push_back(p);
        per_frame[f][t].up_sum += up;
      }
    }
  });
  std::vector<LocalMap> maps(targets.size());
  for (auto& frame_maps : per_frame) {
    for (std::size_t t = 0; t < targets.size(); ++t) {
      auto& src = frame_maps[t];
      if (!src.p_world.empty()) ++maps[t].frames;
      maps[t].p_world.insert(maps[t].p_world.end(), src.p_world.begin(), src.p_world.end());
      maps[t].up_sum += src.up_sum;
    }
  }
  return maps;
}

/// Height of the map surface at a horizontal position and how it moves with tz.
struct SurfaceHeight {
  bool ok = false;
  double z_m = kNaN;          ///< surface height at the centre
  double sigma_m = kNaN;      ///< standard error of z_m
  double dz_gain = 1.0;       ///< d(z_m)/d(tz): the vertical move of a tilted surface per tz change
  std::size_t points = 0;     ///< points the estimate used (inliers)
  std::string problem;        ///< why not ok
};

/// Robust plane z = a dx + b dy + c around the centre: start at the densest height (the ground
/// dominates a small disc even next to a wall or a pole), then least squares with points beyond
/// 3 sigma (robust, MAD) dropped, a few rounds. Returns ok = false for too few points or a slope.
SurfaceHeight fit_surface(const LocalMap& map, const Eigen::Vector2d& centre_xy, FiducialMatch match,
                          std::size_t min_points, double max_slope_deg, double init_window_m) {
  SurfaceHeight out;
  const auto& pts = map.p_world;
  if (pts.size() < min_points) {
    out.problem = pts.empty() ? "no map points near it (occluded, or never within LiDAR view)"
                              : std::to_string(pts.size()) + " map points near it (need " +
                                    std::to_string(min_points) + ")";
    out.points = pts.size();
    return out;
  }
  // Densest 5 cm height bin, smoothed over its neighbours.
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
  double a = 0, b = 0, c = z_lo + (best + 0.5) * kBin_m;
  double window = init_window_m;
  std::vector<char> inlier(pts.size(), 0);
  std::size_t n_in = 0;
  double sigma_r = kNaN;
  Eigen::Matrix3d normal_matrix = Eigen::Matrix3d::Zero();
  for (int round = 0; round < 5; ++round) {
    Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
    Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
    n_in = 0;
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const Eigen::Vector2d d = pts[i].head<2>() - centre_xy;
      const double r = pts[i].z() - (a * d.x() + b * d.y() + c);
      inlier[i] = std::abs(r) <= window;
      if (!inlier[i]) continue;
      const Eigen::Vector3d row(d.x(), d.y(), 1.0);
      A += row * row.transpose();
      rhs += row * pts[i].z();
      ++n_in;
    }
    if (n_in < std::max<std::size_t>(min_points, 3)) break;
    // Points all in one spot (one ring segment) leave the slope undetermined: damp it weakly.
    A(0, 0) += 1e-3 * double(n_in);
    A(1, 1) += 1e-3 * double(n_in);
    const Eigen::Vector3d x = A.ldlt().solve(rhs);
    a = x(0), b = x(1), c = x(2);
    normal_matrix = A;
    std::vector<double> abs_r;
    abs_r.reserve(n_in);
    for (std::size_t i = 0; i < pts.size(); ++i) {
      if (!inlier[i]) continue;
      const Eigen::Vector2d d = pts[i].head<2>() - centre_xy;
      abs_r.push_back(std::abs(pts[i].z() - (a * d.x() + b * d.y() + c)));
    }
    sigma_r = std::max(1.4826 * median(abs_r), 0.002);  // floor: a perfectly flat sim surface
    window = 3.0 * sigma_r;
  }
  if (n_in < std::max<std::size_t>(min_points, 3)) {
    out.problem = "only " + std::to_string(n_in) + " map points on a common surface near it (need " +
                  std::to_string(min_points) + ")";
    out.points = n_in;
    return out;
  }
  const double slope_deg = std::atan(std::hypot(a, b)) * kDegPerRad;
  if (slope_deg > max_slope_deg) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "the surface near it slopes %.0f deg (more than %.0f): not ground", slope_deg,
                  max_slope_deg);
    out.problem = buf;
    out.points = n_in;
    return out;
  }
  // A map point moves by up * dz; on the plane with normal ~(-a, -b, 1) that moves the height at a
  // fixed horizontal position by (up_z - a up_x - b up_y) * dz.
  const Vec3 up = map.mean_up();
  out.dz_gain = up.z() - a * up.x() - b * up.y();
  out.ok = true;
  out.points = n_in;
  if (match == FiducialMatch::kLocalPlane) {
    out.z_m = c;
    out.sigma_m = sigma_r * std::sqrt(std::max(normal_matrix.inverse()(2, 2), 0.0));
  } else {
    // The paper: the height of the nearest map point (horizontally), with one point's noise.
    std::size_t nearest = 0;
    double best_d = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const double d = (pts[i].head<2>() - centre_xy).squaredNorm();
      if (d < best_d) best_d = d, nearest = i;
    }
    out.z_m = pts[nearest].z();
    out.sigma_m = sigma_r;
  }
  return out;
}

/// One measurement of dz: dz_i = value, with its standard error.
struct DzSample {
  double dz_m = kNaN, sigma_m = kNaN;
};

/// Robust combination: reject samples farther than max(floor, k * 1.4826 * MAD) from the median,
/// weighted mean of the rest, then once more against that mean. Returns the inlier flags.
std::vector<char> robust_mean(const std::vector<DzSample>& s, double floor_m, double mad_factor, double* mean_m,
                              double* stddev_m, double* threshold_m) {
  std::vector<double> v;
  for (const auto& x : s) v.push_back(x.dz_m);
  const double med = median(v);
  std::vector<double> dev;
  for (double x : v) dev.push_back(std::abs(x - med));
  const double thr = std::max(floor_m, mad_factor * 1.4826 * median(dev));
  *threshold_m = thr;
  std::vector<char> in(s.size());
  double centre = med;
  for (int pass = 0; pass < 2; ++pass) {
    double sw = 0, swx = 0;
    for (std::size_t i = 0; i < s.size(); ++i) {
      in[i] = std::abs(s[i].dz_m - centre) <= thr;
      if (!in[i]) continue;
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
    if (!in[i]) continue;
    const double w = 1.0 / (s[i].sigma_m * s[i].sigma_m);
    sw += w, swr += w * (s[i].dz_m - centre) * (s[i].dz_m - centre), ++n;
  }
  *mean_m = centre;
  const double formal = sw > 0 ? 1.0 / std::sqrt(sw) : kNaN;
  const double scatter = (n > 1 && sw > 0) ? std::sqrt(swr / sw / double(n - 1)) : kNaN;
  *stddev_m = std::isfinite(scatter) ? std::max(formal, scatter) : formal;
  return in;
}

Iso3 with_dz(const Iso3& T, double dz_m) {
  Iso3 out = T;
  out.translation().z() += dz_m;
  return out;
}

/// Stage 3 from fiducials. Fills result fields; determined stays false with an explanation if fewer
/// than min_fiducials are usable.
void from_fiducials(const Dataset& data, const Iso3& T_ins_lidar, double time_offset_s, const ZConfig& config,
                    ZResult& result) {
  const std::size_t n_fid = data.fiducials.size();
  // LiDAR position at each covered frame's time.
  const auto& frames = data.frames.frames;
  std::vector<Vec3> p_lidar_world(frames.size(), Vec3::Constant(kNaN));
  for (std::size_t i = 0; i < frames.size(); ++i) {
    if (!frame_covered(data, i, time_offset_s)) continue;
    p_lidar_world[i] = data.poses.T_world_ins(frames[i].t_end_s + time_offset_s) * T_ins_lidar.translation();
  }
  // Candidate frames per fiducial, nearest first.
  std::vector<std::vector<std::size_t>> candidates(n_fid);
  for (std::size_t f = 0; f < n_fid; ++f) {
    const Vec3& fid = data.fiducials[f].p_world;
    std::vector<std::pair<double, std::size_t>> by_distance;
    for (std::size_t i = 0; i < frames.size(); ++i) {
      if (!p_lidar_world[i].allFinite()) continue;
      const double d = (p_lidar_world[i].head<2>() - fid.head<2>()).norm();
      if (d >= config.min_view_distance_m && d <= config.max_view_distance_m) by_distance.push_back({d, i});
    }
    std::sort(by_distance.begin(), by_distance.end());
    for (const auto& candidate : by_distance) candidates[f].push_back(candidate.second);
  }
  // Rounds of frames_per_fiducial frames each. A fiducial whose local map holds points from fewer
  // than half of them gets another round, of the candidates left, with half the time separation
  // (the car moves on between frames, and a sparse LiDAR sees the ground near a fiducial only
  // from the distances where one of its rings meets the ground).
  std::vector<Target> targets(n_fid);  // every frame chosen per fiducial, over all rounds
  std::vector<LocalMap> maps(n_fid);
  const std::size_t enough_frames = std::max<std::size_t>(1, config.frames_per_fiducial / 2);
  for (double separation_s = config.min_frame_separation_s;; separation_s *= 0.5) {
    std::vector<Target> batch(n_fid);
    bool any = false;
    for (std::size_t f = 0; f < n_fid; ++f) {
      batch[f].centre_xy = targets[f].centre_xy = data.fiducials[f].p_world.head<2>();
      batch[f].radius_m = targets[f].radius_m = config.search_radius_m;
      const bool enough = maps[f].frames >= enough_frames && maps[f].p_world.size() >= config.min_points;
      if (enough || targets[f].frames.size() >= config.max_frames_per_fiducial) continue;
      for (const std::size_t i : candidates[f]) {
        if (batch[f].frames.size() >= config.frames_per_fiducial ||
            targets[f].frames.size() >= config.max_frames_per_fiducial) {
          break;
        }
        const bool too_close = std::any_of(targets[f].frames.begin(), targets[f].frames.end(), [&](std::size_t j) {
          return std::abs(frames[j].t_end_s - frames[i].t_end_s) < separation_s;
        });
        if (too_close) continue;
        targets[f].frames.push_back(i);
        batch[f].frames.push_back(i);
      }
      std::sort(batch[f].frames.begin(), batch[f].frames.end());
      any = any || !batch[f].frames.empty();
    }
    if (!any) break;
    std::size_t loaded = 0;
    std::vector<LocalMap> more = gather(data, batch, T_ins_lidar, time_offset_s, config.min_range_m, &loaded);
    result.frames_loaded += loaded;
    for (std::size_t f = 0; f < n_fid; ++f) {
      maps[f].p_world.insert(maps[f].p_world.end(), more[f].p_world.begin(), more[f].p_world.end());
      maps[f].up_sum += more[f].up_sum;
      maps[f].frames += more[f].frames;
    }
  }

  result.fiducials.resize(n_fid);
  std::vector<DzSample> samples;
  std::vector<std::size_t> sample_fid;
  std::vector<SurfaceHeight> heights(n_fid);
  for (std::size_t f = 0; f < n_fid; ++f) {
    FiducialResidual& fr = result.fiducials[f];
    fr.id = data.fiducials[f].id;
    if (targets[f].frames.empty()) {
      char buf[160];
      std::snprintf(buf, sizeof buf, "the LiDAR never came within %.0f-%.0f m of it during the frames",
                    config.min_view_distance_m, config.max_view_distance_m);
      fr.reason_rejected = buf;
      continue;
    }
    heights[f] = fit_surface(maps[f], targets[f].centre_xy, config.match, config.min_points, 45.0, 0.15);
    fr.map_points = heights[f].points;
    if (!heights[f].ok) {
      fr.reason_rejected = heights[f].problem;
      continue;
    }
    fr.residual_before_m = data.fiducials[f].p_world.z() - heights[f].z_m;
    const double gain = std::max(heights[f].dz_gain, 0.5);  // ~1 unless the vehicle tilts a lot
    const double sigma = std::hypot(heights[f].sigma_m, config.fiducial_sigma_m) / gain;
    samples.push_back({fr.residual_before_m / gain, sigma});
    sample_fid.push_back(f);
  }

  auto rejected_list = [&]() {
    std::string s;
    for (const auto& fr : result.fiducials) {
      if (fr.used) continue;
      s += (s.empty() ? "" : "; ") + fr.id + ": " + fr.reason_rejected;
    }
    return s;
  };

  if (samples.size() < config.min_fiducials) {
    for (std::size_t f : sample_fid) {
      result.fiducials[f].reason_rejected = "measured, but too few other fiducials could be";
    }
    result.explanation = "tz not determined from fiducials: only " + std::to_string(samples.size()) + " of " +
                         std::to_string(n_fid) + " fiducials usable (need " + std::to_string(config.min_fiducials) +
                         ")" + (samples.size() < n_fid ? "; unusable: " + rejected_list() : "");
    return;
  }
  double dz = 0, sd = kNaN, thr = 0;
  const std::vector<char> inlier =
      robust_mean(samples, config.outlier_threshold_m, config.outlier_mad_factor, &dz, &sd, &thr);
  std::size_t used = 0;
  for (std::size_t s = 0; s < samples.size(); ++s) {
    FiducialResidual& fr = result.fiducials[sample_fid[s]];
    fr.residual_after_m = fr.residual_before_m - heights[sample_fid[s]].dz_gain * dz;
    if (inlier[s]) {
      fr.used = true;
      ++used;
    } else {
      fr.reason_rejected = "outlier: its residual " + fmt_m(fr.residual_after_m) +
                           " after the correction exceeds the limit " + fmt_m(thr).substr(1) +
                           " (occluded, moved or mistyped?)";
    }
  }
  if (used < config.min_fiducials) {
    result.explanation = "tz not determined from fiducials: only " + std::to_string(used) + " of " +
                         std::to_string(n_fid) + " fiducials agree (need " + std::to_string(config.min_fiducials) +
                         "); " + rejected_list();
    for (auto& fr : result.fiducials) {
      if (fr.used) fr.reason_rejected = "agrees with too few others to determine tz";
      fr.residual_after_m = fr.residual_before_m, fr.used = false;
    }
    return;
  }
  result.determined = true;
  result.method = "fiducials";
  result.dz_m = dz;
  result.tz_stddev_m = sd = std::hypot(sd, config.ins_vertical_sigma_m);
  result.T_ins_lidar = with_dz(T_ins_lidar, dz);
  char buf[200];
  std::snprintf(buf, sizeof buf, "tz from %zu of %zu fiducials: dz = %+.3f m (tz %.3f -> %.3f m, +- %.3f m)", used,
                n_fid, dz, T_ins_lidar.translation().z(), result.T_ins_lidar.translation().z(), sd);
  result.explanation = buf;
  if (used < n_fid) result.explanation += "; not used: " + rejected_list();
}

/// Stage 3 from the height of the INS origin above the ground.
void from_height(const Dataset& data, const Iso3& T_ins_lidar, double time_offset_s, double ins_height_m,
                 const ZConfig& config, ZResult& result) {
  const auto& frames = data.frames.frames;
  std::vector<std::size_t> covered;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    if (frame_covered(data, i, time_offset_s)) covered.push_back(i);
  }
  if (covered.empty()) {
    result.explanation = "tz not determined from --ins-height-m: no frame is covered by the poses";
    return;
  }
  auto ins_position = [&](std::size_t i) {
    return Vec3(data.poses.T_world_ins(frames[i].t_end_s + time_offset_s).translation());
  };
  // Samples evenly spread over the covered frames; each stitches in the nearest frames in time
  // (before and after) that were at least min_view_distance_m away, so they saw the ground under
  // the car that its own sweep cannot see. Where that ground is not found (a sparse LiDAR meets
  // the ground only far out), a second round adds frames from twice the window, one each time the
  // car is another min_view_distance_m farther away.
  const std::size_t n_samples = std::min(config.height_samples, covered.size());
  std::vector<Target> targets(n_samples);
  std::vector<Vec3> centre(n_samples);
  // Frames within window_s of sample frame k, per direction: the first at each multiple of
  // min_view_distance_m from it, at most per_direction of them, not already in `taken`.
  auto neighbours = [&](std::size_t k, double window_s, std::size_t per_direction,
                        const std::vector<std::size_t>& taken) {
    std::vector<std::size_t> out;
    const auto pos = std::lower_bound(covered.begin(), covered.end(), k);
    for (int dir : {-1, +1}) {
      std::size_t found = 0;
      for (auto it = pos; found < per_direction;) {
        if (dir < 0 && it == covered.begin()) break;
        it += dir;
        if (it == covered.end()) break;
        if (std::abs(frames[*it].t_end_s - frames[k].t_end_s) > window_s) break;
        const double d = (ins_position(*it).head<2>() - ins_position(k).head<2>()).norm();
        if (d < double(found + 1) * config.min_view_distance_m) continue;
        ++found;
        if (std::find(taken.begin(), taken.end(), *it) == taken.end()) out.push_back(*it);
      }
    }
    std::sort(out.begin(), out.end());
    return out;
  };
  std::vector<std::size_t> sample_frame(n_samples);
  for (std::size_t s = 0; s < n_samples; ++s) {
    const std::size_t k = sample_frame[s] = covered[(2 * s + 1) * covered.size() / (2 * n_samples)];
    centre[s] = ins_position(k);
    targets[s].centre_xy = centre[s].head<2>();
    targets[s].radius_m = config.ground_radius_m;
    targets[s].frames = neighbours(k, config.ground_window_s, 1, {});
    targets[s].frames.resize(std::min(targets[s].frames.size(), config.ground_frames_per_sample - 1));
    targets[s].frames.insert(std::lower_bound(targets[s].frames.begin(), targets[s].frames.end(), k), k);
  }
  std::size_t loaded = 0;
  std::vector<LocalMap> maps = gather(data, targets, T_ins_lidar, time_offset_s, config.min_range_m, &loaded);
  result.frames_loaded += loaded;

  auto ground_at = [&](std::size_t s) {
    SurfaceHeight g = fit_surface(maps[s], targets[s].centre_xy, FiducialMatch::kLocalPlane, config.min_points,
                                  config.max_ground_slope_deg, 0.3);
    if (g.ok && g.sigma_m > kMaxGroundSigma_m) {
      g.ok = false;
      g.problem = "the ground points near it do not pin down the height under the INS";
    }
    return g;
  };
  std::vector<SurfaceHeight> ground(n_samples);
  std::vector<Target> more(n_samples);
  bool any_more = false;
  for (std::size_t s = 0; s < n_samples; ++s) {
    ground[s] = ground_at(s);
    more[s].centre_xy = targets[s].centre_xy;
    more[s].radius_m = targets[s].radius_m;
    if (!ground[s].ok) more[s].frames = neighbours(sample_frame[s], 2.0 * config.ground_window_s, 4, targets[s].frames);
    any_more = any_more || !more[s].frames.empty();
  }
  if (any_more) {
    const std::vector<LocalMap> extra = gather(data, more, T_ins_lidar, time_offset_s, config.min_range_m, &loaded);
    result.frames_loaded += loaded;
    for (std::size_t s = 0; s < n_samples; ++s) {
      if (more[s].frames.empty()) continue;
      maps[s].p_world.insert(maps[s].p_world.end(), extra[s].p_world.begin(), extra[s].p_world.end());
      maps[s].up_sum += extra[s].up_sum;
      maps[s].frames += extra[s].frames;
      ground[s] = ground_at(s);
    }
  }

  std::vector<DzSample> samples;
  std::string last_problem;
  for (std::size_t s = 0; s < n_samples; ++s) {
    const SurfaceHeight& g = ground[s];
    if (!g.ok) {
      last_problem = g.problem;
      continue;
    }
    const double gain = std::max(g.dz_gain, 0.5);
    // The INS is ins_height_m above the ground: centre.z - (g.z + gain * dz) = ins_height_m.
    samples.push_back({(centre[s].z() - g.z_m - ins_height_m) / gain, std::max(g.sigma_m, 1e-3) / gain});
  }
  result.height_samples_used = samples.size();
  const std::size_t need = std::min<std::size_t>(3, n_samples);
  if (samples.size() < need || samples.empty()) {
    result.explanation = "tz not determined from --ins-height-m: the ground was found at only " +
                         std::to_string(samples.size()) + " of " + std::to_string(n_samples) +
                         " places along the drive (" + last_problem + ")";
    return;
  }
  double dz = 0, sd = kNaN, thr = 0;
  const std::vector<char> inlier = robust_mean(samples, config.outlier_threshold_m, config.outlier_mad_factor, &dz,
                                               &sd, &thr);
  const std::size_t used = std::count(inlier.begin(), inlier.end(), 1);
  result.height_samples_used = used;
  result.determined = true;
  result.method = "ins-height";
  result.dz_m = dz;
  result.tz_stddev_m = sd;
  result.T_ins_lidar = with_dz(T_ins_lidar, dz);
  char buf[300];
  std::snprintf(buf, sizeof buf,
                "tz from the INS height above the ground (%.3f m as given) measured at %zu places along the "
                "drive: dz = %+.3f m (tz %.3f -> %.3f m, +- %.3f m, not counting the error of the given height)",
                ins_height_m, used, dz, T_ins_lidar.translation().z(), result.T_ins_lidar.translation().z(), sd);
  result.explanation = buf;
}

}  // namespace

ZResult correct_z(const Dataset& data, const Iso3& T_ins_lidar, double time_offset_s,
                  std::optional<double> ins_height_m, const ZConfig& config) {
  const auto start = std::chrono::steady_clock::now();
  ZResult result;
  result.T_ins_lidar = T_ins_lidar;
  std::string fiducial_problem;
  if (!data.fiducials.empty()) {
    from_fiducials(data, T_ins_lidar, time_offset_s, config, result);
    if (!result.determined) fiducial_problem = result.explanation;
  }
  if (!result.determined && ins_height_m) {
    from_height(data, T_ins_lidar, time_offset_s, *ins_height_m, config, result);
    if (!fiducial_problem.empty()) result.explanation = fiducial_problem + "; " + result.explanation;
  }
  if (!result.determined) {
    result.method = "none";
    result.T_ins_lidar = T_ins_lidar;
    result.dz_m = 0.0;
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.3f m", T_ins_lidar.translation().z());
    if (data.fiducials.empty() && !ins_height_m) {
      result.explanation = "tz not determined: no fiducials and no --ins-height-m given; kept at the initial value (" +
                           std::string(buf) + ")";
    } else {
      result.explanation += "; tz kept at the initial value (" + std::string(buf) + ")";
    }
  }
  result.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace insalign
