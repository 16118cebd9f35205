#include "core/zcorrect.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fmt/format.h>

#include "core/z_surface.hpp"

namespace insalign {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string fmt_m(double v) { return fmt::format("{:+.3f} m", v); }

// The covered frames of the drive at the time offset, with their INS poses.
DriveFrames covered_frames(const FrameStore& store, double time_offset_s) {
  return drive_frames(store, time_offset_s);
}

// ---- Fiducials ---------------------------------------------------------------------------

// Per fiducial: the covered frames whose LiDAR passes within the view distances of it, nearest first.
std::vector<std::vector<std::size_t>> fiducial_candidates(const FrameStore& store, const DriveFrames& drive,
                                                          const Iso3& T_ins_lidar, const ZConfig& config) {
  const auto& fiducials = store.data().fiducials;
  std::vector<std::vector<std::size_t>> out(fiducials.size());
  for (std::size_t f = 0; f < fiducials.size(); ++f) {
    std::vector<std::pair<double, std::size_t>> by_distance;
    for (std::size_t k = 0; k < drive.size(); ++k) {
      const Vec3 p_lidar_world = drive.T_world_ins[k] * T_ins_lidar.translation();
      const double d = (p_lidar_world.head<2>() - fiducials[f].p_world.head<2>()).norm();
      if (d >= config.min_view_distance_m && d <= config.max_view_distance_m) by_distance.push_back({d, drive.index[k]});
    }
    std::sort(by_distance.begin(), by_distance.end());
    for (const auto& c : by_distance) out[f].push_back(c.second);
  }
  return out;
}

// Rounds of frames_per_fiducial frames each. A fiducial whose local map holds points from fewer
// than half of them gets another round of the candidates left, with half the time separation
// (the car moves on between frames, and a sparse LiDAR sees the ground near a fiducial only from
// the distances where one of its rings meets the ground).
void gather_fiducial_maps(const FrameStore& store, const std::vector<std::vector<std::size_t>>& candidates,
                          const Iso3& T_ins_lidar, double time_offset_s, const ZConfig& config,
                          std::vector<Target>& targets, std::vector<LocalMap>& maps, std::size_t* frames_loaded,
                          NearPoints* near) {
  const auto& fiducials = store.data().fiducials;
  const auto& frames = store.data().frames.frames;
  const std::size_t n = fiducials.size();
  targets.assign(n, Target{});
  maps.assign(n, LocalMap{});
  const std::size_t enough_frames = std::max<std::size_t>(1, config.frames_per_fiducial / 2);
  for (double separation_s = config.min_frame_separation_s;; separation_s *= 0.5) {
    std::vector<Target> batch(n);
    bool any = false;
    for (std::size_t f = 0; f < n; ++f) {
      batch[f].centre_xy = targets[f].centre_xy = fiducials[f].p_world.head<2>();
      batch[f].radius_m = targets[f].radius_m = config.search_radius_m;
      const bool enough = maps[f].frames >= enough_frames && maps[f].p_world.size() >= config.min_points;
      for (const std::size_t i : candidates[f]) {
        if (enough || batch[f].frames.size() >= config.frames_per_fiducial ||
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
    if (!any) return;
    std::size_t loaded = 0;
    const std::vector<LocalMap> more = gather(store, batch, T_ins_lidar, time_offset_s, &loaded, near);
    *frames_loaded += loaded;
    for (std::size_t f = 0; f < n; ++f) maps[f].append(more[f]);
  }
}

// Each fiducial's residual against the map (or why it could not be measured); the usable ones as
// dz samples, with their fiducial index.
std::vector<DzSample> measure_fiducials(const FrameStore& store, const std::vector<Target>& targets,
                                        const std::vector<LocalMap>& maps, const ZConfig& config, ZResult& result,
                                        std::vector<std::size_t>& sample_fiducial, std::vector<double>& gain) {
  const auto& fiducials = store.data().fiducials;
  result.fiducials.resize(fiducials.size());
  gain.assign(fiducials.size(), 1.0);
  std::vector<DzSample> samples;
  for (std::size_t f = 0; f < fiducials.size(); ++f) {
    FiducialResidual& fr = result.fiducials[f];
    fr.id = fiducials[f].id;
    if (targets[f].frames.empty()) {
      fr.reason_rejected = fmt::format("the LiDAR never came within {:.0f}-{:.0f} m of it during the frames",
                                       config.min_view_distance_m, config.max_view_distance_m);
      continue;
    }
    const SurfaceHeight h = fit_surface(maps[f], targets[f].centre_xy, config.match, config.min_points, 45.0, 0.15);
    fr.map_points = h.points;
    if (!h.ok) {
      fr.reason_rejected = h.problem;
      continue;
    }
    fr.residual_before_m = fiducials[f].p_world.z() - h.z_m;
    gain[f] = h.dz_gain;
    // |gain| ~1 unless the vehicle tilts a lot; negative for an `ins` frame whose z points down (SBET).
    const double g = std::copysign(std::max(std::abs(h.dz_gain), 0.5), h.dz_gain);
    samples.push_back({fr.residual_before_m / g, std::hypot(h.sigma_m, config.fiducial_sigma_m) / g});
    sample_fiducial.push_back(f);
  }
  return samples;
}

std::string rejected_list(const ZResult& result) {
  std::string s;
  for (const auto& fr : result.fiducials)
    if (!fr.used) s += (s.empty() ? "" : "; ") + fr.id + ": " + fr.reason_rejected;
  return s;
}

// Combines the samples; false (with the message set) when too few are usable or agree.
bool combine_fiducials(const std::vector<DzSample>& samples, const std::vector<std::size_t>& sample_fiducial,
                       const std::vector<double>& gain, const ZConfig& config, ZResult& result, RobustMean& mean) {
  const std::size_t n = result.fiducials.size();
  if (samples.size() < config.min_fiducials) {
    for (std::size_t f : sample_fiducial) result.fiducials[f].reason_rejected = "measured, but too few other fiducials could be";
    result.outcome.message = "tz not determined from fiducials: only " + std::to_string(samples.size()) + " of " +
                             std::to_string(n) + " fiducials usable (need " + std::to_string(config.min_fiducials) +
                             ")" + (samples.size() < n ? "; unusable: " + rejected_list(result) : "");
    return false;
  }
  mean = robust_mean(samples, config.outlier_threshold_m, config.outlier_mad_factor);
  std::size_t used = 0;
  for (std::size_t s = 0; s < samples.size(); ++s) {
    FiducialResidual& fr = result.fiducials[sample_fiducial[s]];
    fr.residual_after_m = fr.residual_before_m - gain[sample_fiducial[s]] * mean.mean_m;
    fr.used = mean.inlier[s];
    used += fr.used;
    if (!fr.used) {
      fr.reason_rejected = "outlier: its residual " + fmt_m(fr.residual_after_m) + " after the correction exceeds the limit " +
                           fmt_m(mean.threshold_m).substr(1) + " (occluded, moved or mistyped?)";
    }
  }
  if (used >= config.min_fiducials) return true;
  result.outcome.message = "tz not determined from fiducials: only " + std::to_string(used) + " of " +
                           std::to_string(n) + " fiducials agree (need " + std::to_string(config.min_fiducials) +
                           "); " + rejected_list(result);
  for (auto& fr : result.fiducials) {
    if (fr.used) fr.reason_rejected = "agrees with too few others to determine tz";
    fr.residual_after_m = fr.residual_before_m, fr.used = false;
  }
  return false;
}

void set_determined(ZResult& result, ZMethod method, const Iso3& T_ins_lidar, double dz_m, double stddev_m) {
  result.outcome.status = StageStatus::kOk;
  result.outcome.determined[2] = true;
  result.outcome.stddev[2] = stddev_m;
  result.method = method;
  result.dz_m = dz_m;
  result.T_ins_lidar = T_ins_lidar;
  result.T_ins_lidar.translation().z() += dz_m;
}

void from_fiducials(const FrameStore& store, const Iso3& T_ins_lidar, double time_offset_s, const ZConfig& config,
                    NearPoints* near, ZResult& result) {
  const DriveFrames drive = covered_frames(store, time_offset_s);
  std::vector<Target> targets;
  std::vector<LocalMap> maps;
  gather_fiducial_maps(store, fiducial_candidates(store, drive, T_ins_lidar, config), T_ins_lidar, time_offset_s,
                       config, targets, maps, &result.frames_loaded, near);
  std::vector<std::size_t> sample_fiducial;
  std::vector<double> gain;
  const std::vector<DzSample> samples = measure_fiducials(store, targets, maps, config, result, sample_fiducial, gain);
  RobustMean mean;
  if (!combine_fiducials(samples, sample_fiducial, gain, config, result, mean)) return;
  // Fiducials are absolute: the INS's own height error over the drive adds in quadrature.
  const double sd = std::hypot(mean.stddev_m, config.ins_vertical_sigma_m);
  set_determined(result, ZMethod::kFiducials, T_ins_lidar, mean.mean_m, sd);
  const std::size_t used = std::count_if(result.fiducials.begin(), result.fiducials.end(), [](auto& f) { return f.used; });
  result.outcome.message =
      fmt::format("tz from {} of {} fiducials: dz = {:+.3f} m (tz {:.3f} -> {:.3f} m, +- {:.3f} m)", used,
                  result.fiducials.size(), mean.mean_m, T_ins_lidar.translation().z(), result.T_ins_lidar.translation().z(), sd);
  if (used < result.fiducials.size()) result.outcome.message += "; not used: " + rejected_list(result);
}

// ---- Height prior ------------------------------------------------------------------------

// Frames within window_s of position k of `drive`, per direction: the first at each multiple of
// min_view_distance_m from it, at most per_direction of them, not already in `taken`. They saw
// the ground under the car that its own sweep cannot see.
std::vector<std::size_t> ground_neighbours(const DriveFrames& drive, std::size_t k, double window_s,
                                           std::size_t per_direction, double step_m,
                                           const std::vector<std::size_t>& taken) {
  std::vector<std::size_t> out;
  for (int dir : {-1, +1}) {
    std::size_t found = 0;
    for (long j = static_cast<long>(k) + dir; j >= 0 && j < static_cast<long>(drive.size()) && found < per_direction; j += dir) {
      const std::size_t p = static_cast<std::size_t>(j);
      if (std::abs(drive.t_end_s[p] - drive.t_end_s[k]) > window_s) break;
      const double d = (drive.T_world_ins[p].translation() - drive.T_world_ins[k].translation()).head<2>().norm();
      if (d < double(found + 1) * step_m) continue;
      ++found;
      if (std::find(taken.begin(), taken.end(), drive.index[p]) == taken.end()) out.push_back(drive.index[p]);
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

SurfaceHeight ground_at(const LocalMap& map, const Target& target, const ZConfig& config) {
  SurfaceHeight g = fit_surface(map, target.centre_xy, FiducialMatch::kLocalPlane, config.min_points,
                                config.max_ground_slope_deg, 0.3);
  if (g.ok && g.sigma_m > config.max_ground_sigma_m) {
    g.ok = false;
    g.problem = "the ground points near it do not pin down the height under the INS";
  }
  return g;
}

// The ground height under the INS at `sample` places evenly spread over the drive; where it is
// not found (a sparse LiDAR meets the ground only far out), a second round adds frames from twice
// the window.
std::vector<SurfaceHeight> measure_ground(const FrameStore& store, const DriveFrames& drive,
                                          const std::vector<std::size_t>& sample, const Iso3& T_ins_lidar,
                                          double time_offset_s, const ZConfig& config, std::size_t* frames_loaded,
                                          NearPoints* near) {
  const std::size_t n = sample.size();
  std::vector<Target> targets(n);
  for (std::size_t s = 0; s < n; ++s) {
    targets[s].centre_xy = drive.T_world_ins[sample[s]].translation().head<2>();
    targets[s].radius_m = config.ground_radius_m;
    targets[s].frames = ground_neighbours(drive, sample[s], config.ground_window_s, 1, config.min_view_distance_m, {});
    targets[s].frames.resize(std::min(targets[s].frames.size(), config.ground_frames_per_sample - 1));
    const std::size_t own = drive.index[sample[s]];
    targets[s].frames.insert(std::lower_bound(targets[s].frames.begin(), targets[s].frames.end(), own), own);
  }
  std::size_t loaded = 0;
  std::vector<LocalMap> maps = gather(store, targets, T_ins_lidar, time_offset_s, &loaded, near);
  *frames_loaded += loaded;
  std::vector<SurfaceHeight> ground(n);
  std::vector<Target> more(n);
  bool any_more = false;
  for (std::size_t s = 0; s < n; ++s) {
    ground[s] = ground_at(maps[s], targets[s], config);
    more[s].centre_xy = targets[s].centre_xy;
    more[s].radius_m = targets[s].radius_m;
    if (!ground[s].ok) {
      more[s].frames = ground_neighbours(drive, sample[s], 2.0 * config.ground_window_s, 4, config.min_view_distance_m,
                                         targets[s].frames);
    }
    any_more = any_more || !more[s].frames.empty();
  }
  if (!any_more) return ground;
  const std::vector<LocalMap> extra = gather(store, more, T_ins_lidar, time_offset_s, &loaded, near);
  *frames_loaded += loaded;
  for (std::size_t s = 0; s < n; ++s) {
    if (more[s].frames.empty()) continue;
    maps[s].append(extra[s]);
    ground[s] = ground_at(maps[s], targets[s], config);
  }
  return ground;
}

void from_height(const FrameStore& store, const Iso3& T_ins_lidar, double time_offset_s, double ins_height_m,
                 const ZConfig& config, NearPoints* near, ZResult& result) {
  const DriveFrames drive = covered_frames(store, time_offset_s);
  if (drive.size() == 0) {
    result.outcome.message = "tz not determined from --ins-height-m: no frame is covered by the poses";
    return;
  }
  const std::size_t n = std::min(config.height_samples, drive.size());
  std::vector<std::size_t> sample(n);
  for (std::size_t s = 0; s < n; ++s) sample[s] = (2 * s + 1) * drive.size() / (2 * n);
  const std::vector<SurfaceHeight> ground =
      measure_ground(store, drive, sample, T_ins_lidar, time_offset_s, config, &result.frames_loaded, near);
  std::vector<DzSample> samples;
  std::string last_problem;
  for (std::size_t s = 0; s < n; ++s) {
    if (!ground[s].ok) {
      last_problem = ground[s].problem;
      continue;
    }
    const double g = std::copysign(std::max(std::abs(ground[s].dz_gain), 0.5), ground[s].dz_gain);
    // The INS is ins_height_m above the ground: z_ins - (z_ground + gain * dz) = ins_height_m.
    const double z_ins = drive.T_world_ins[sample[s]].translation().z();
    samples.push_back({(z_ins - ground[s].z_m - ins_height_m) / g, std::max(ground[s].sigma_m, 1e-3) / g});
  }
  result.height_samples_used = samples.size();
  if (samples.size() < std::min<std::size_t>(3, n) || samples.empty()) {
    result.outcome.message = "tz not determined from --ins-height-m: the ground was found at only " +
                             std::to_string(samples.size()) + " of " + std::to_string(n) + " places along the drive (" +
                             last_problem + ")";
    return;
  }
  const RobustMean mean = robust_mean(samples, config.outlier_threshold_m, config.outlier_mad_factor);
  result.height_samples_used = std::count(mean.inlier.begin(), mean.inlier.end(), 1);
  set_determined(result, ZMethod::kInsHeight, T_ins_lidar, mean.mean_m, mean.stddev_m);
  result.outcome.message = fmt::format(
      "tz from the INS height above the ground ({:.3f} m as given) measured at {} places along the drive: dz = "
      "{:+.3f} m (tz {:.3f} -> {:.3f} m, +- {:.3f} m, not counting the error of the given height)",
      ins_height_m, result.height_samples_used, mean.mean_m, T_ins_lidar.translation().z(),
      result.T_ins_lidar.translation().z(), mean.stddev_m);
}

}  // namespace

ZResult correct_z(const FrameStore& store, const Iso3& T_ins_lidar, double time_offset_s,
                  std::optional<double> ins_height_m, const ZConfig& config, NearPoints* near) {
  const auto start = std::chrono::steady_clock::now();
  ZResult result;
  result.T_ins_lidar = T_ins_lidar;
  const bool have_fiducials = !store.data().fiducials.empty();
  std::string fiducial_problem;
  if (have_fiducials) {
    from_fiducials(store, T_ins_lidar, time_offset_s, config, near, result);
    if (!result.determined()) fiducial_problem = result.outcome.message;
  }
  if (!result.determined() && ins_height_m) {
    from_height(store, T_ins_lidar, time_offset_s, *ins_height_m, config, near, result);
    if (!fiducial_problem.empty()) result.outcome.message = fiducial_problem + "; " + result.outcome.message;
  }
  if (!result.determined()) {
    const std::string tz = fmt::format("{:.3f} m", T_ins_lidar.translation().z());
    result.T_ins_lidar = T_ins_lidar;
    if (!have_fiducials && !ins_height_m) {
      result.outcome.status = StageStatus::kSkipped;
      result.outcome.message = "tz not determined: no fiducials and no --ins-height-m given; kept at the initial value (" + tz + ")";
    } else {
      result.outcome.status = StageStatus::kUndetermined;
      result.outcome.message += "; tz kept at the initial value (" + tz + ")";
    }
  }
  result.outcome.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace insalign
