#include "core/frames.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/frame_store.hpp"
#include "core/voxel_grid.hpp"

namespace insalign {
namespace {

constexpr double kPeriodSlack = 1.1;  // sweeps are a little longer than the nominal period (jitter)

}  // namespace

Sweep thin_sweep(const Sweep& sweep, const SweepFilter& filter) {
  const float r2_min = static_cast<float>(filter.min_range_m * filter.min_range_m);
  const float r2_max = static_cast<float>(filter.max_range_m * filter.max_range_m);
  // Scratch kept per thread: every sweep passes here, and fresh megabytes cost page faults.
  thread_local std::vector<std::uint32_t> in_range;
  thread_local std::vector<Vec3f> points;
  in_range.clear();
  points.clear();
  for (std::size_t i = 0; i < sweep.size(); ++i) {
    const Vec3f& p = sweep.p_lidar[i];
    const float r2 = p.squaredNorm();
    if (!(r2 >= r2_min && r2 <= r2_max)) continue;  // also drops NaN
    in_range.push_back(static_cast<std::uint32_t>(i));
    points.push_back(p);
  }
  std::vector<std::uint32_t> kept = voxel_downsample_indices(points, filter.voxel_m);
  if (filter.max_points > 0 && kept.size() > filter.max_points) {
    std::vector<std::uint32_t> thin(filter.max_points);
    const double stride = static_cast<double>(kept.size()) / static_cast<double>(thin.size());
    for (std::size_t k = 0; k < thin.size(); ++k) thin[k] = kept[static_cast<std::size_t>(k * stride)];
    kept.swap(thin);
  }
  Sweep out;
  out.name = sweep.name;
  out.t_end_s = sweep.t_end_s;
  out.p_lidar.reserve(kept.size());
  for (std::uint32_t k : kept) out.p_lidar.push_back(points[k]);
  if (sweep.has_time()) {
    out.dt_s.reserve(kept.size());
    for (std::uint32_t k : kept) out.dt_s.push_back(sweep.dt_s[in_range[k]]);
  }
  if (!sweep.intensity.empty()) {
    out.intensity.reserve(kept.size());
    for (std::uint32_t k : kept) out.intensity.push_back(sweep.intensity[in_range[k]]);
  }
  return out;
}

double sweep_period_s(const std::vector<FrameInfo>& frames, const FramesConfig& config) {
  if (config.sweep_period_s > 0.0) return config.sweep_period_s;
  if (frames.size() < 2) return 0.1;
  std::vector<double> gaps;
  gaps.reserve(frames.size() - 1);
  for (std::size_t i = 1; i < frames.size(); ++i) gaps.push_back(frames[i].t_end_s - frames[i - 1].t_end_s);
  std::nth_element(gaps.begin(), gaps.begin() + static_cast<std::ptrdiff_t>(gaps.size() / 2), gaps.end());
  return std::clamp(gaps[gaps.size() / 2], 0.02, 0.25);
}

bool sweep_covered(const PoseStream& poses, double t_end_s, double period_s, double time_offset_s, double margin_s) {
  const double t = t_end_s + time_offset_s;
  return poses.covers(t - kPeriodSlack * period_s - margin_s) && poses.covers(t + margin_s);
}

bool sweep_covered(const PoseStream& poses, const Sweep& sweep, double time_offset_s, double margin_s) {
  if (sweep.size() == 0) return false;
  const auto [lo, hi] = dt_range(sweep);
  const double t = sweep.t_end_s + time_offset_s;
  return poses.covers(t + lo - margin_s) && poses.covers(t + hi + margin_s);
}

DriveFrames drive_frames(const FrameStore& store, double time_offset_s, double margin_s) {
  DriveFrames out;
  const PoseStream& poses = store.poses();
  if (poses.empty()) return out;
  const FramesConfig& config = store.frames_config();
  const std::vector<FrameInfo>& infos = store.data().frames.frames;
  const double period = store.sweep_period_s();
  for (std::size_t i = 0; i < infos.size(); ++i) {
    const double t_ins = infos[i].t_end_s + time_offset_s;
    if (!sweep_covered(poses, infos[i].t_end_s, period, time_offset_s, margin_s)) continue;
    if (store.excluded(t_ins - 1.1 * period - margin_s, t_ins + margin_s)) continue;
    out.index.push_back(i);
    out.decoded.push_back(store.is_decoded(i));
    out.t_end_s.push_back(infos[i].t_end_s);
    out.T_world_ins.push_back(poses.T_world_ins(t_ins));
  }
  out.motion_m.assign(out.size(), 0.0);
  for (std::size_t k = 1; k < out.size(); ++k) {
    const Iso3 T_prev_cur = out.T_world_ins[k - 1].inverse() * out.T_world_ins[k];
    const double d = T_prev_cur.translation().norm();
    const double a = Eigen::AngleAxisd(T_prev_cur.linear()).angle();
    out.distance_m += d;
    out.turned_rad += a;
    if (d > 1e-3 || a > 1e-4) ++out.moving;
    out.motion_m[k] = out.motion_m[k - 1] + d + config.turn_weight_m_per_rad * a;
  }
  return out;
}

namespace {

// Within the slice [lo, hi] of the motion measure: the decoded frame nearest `target`, else `k`.
std::size_t prefer_decoded(const DriveFrames& frames, std::size_t k, double target, double lo, double hi,
                           std::size_t first, std::size_t last) {
  if (frames.decoded.empty() || frames.decoded[k]) return k;
  std::size_t best = k;
  double best_d = std::numeric_limits<double>::infinity();
  for (std::size_t j = k; j >= first && frames.motion_m[j] >= lo; --j) {
    if (frames.decoded[j]) best = j, best_d = target - frames.motion_m[j];
    if (frames.decoded[j] || j == 0) break;
  }
  for (std::size_t j = k + 1; j <= last && frames.motion_m[j] <= hi; ++j) {
    if (!frames.decoded[j]) continue;
    if (frames.motion_m[j] - target < best_d) best = j;
    break;
  }
  return best;
}

}  // namespace

std::vector<std::size_t> spread_over_motion(const DriveFrames& frames, std::size_t n, std::size_t first,
                                            std::size_t last) {
  std::vector<std::size_t> out;
  if (frames.size() == 0 || n == 0) return out;
  last = std::min(last, frames.size() - 1);
  if (first > last) return out;
  const double s0 = frames.motion_m[first], span = frames.motion_m[last] - s0;
  const double slice = span / static_cast<double>(n);
  std::size_t k = first;
  for (std::size_t i = 0; i < n; ++i) {
    const double target = s0 + slice * (static_cast<double>(i) + 0.5);
    while (k < last && frames.motion_m[k] < target) ++k;
    const std::size_t pick = prefer_decoded(frames, k, target, target - 0.5 * slice, target + 0.5 * slice, first, last);
    if (out.empty() || out.back() < pick) out.push_back(pick);
  }
  return out;
}

std::vector<std::size_t> fill_between(const DriveFrames& drive, const std::vector<std::size_t>& frames,
                                      std::size_t per_gap) {
  std::vector<std::size_t> position;  // of each of `frames` in the drive
  for (std::size_t f : frames) {
    const auto it = std::lower_bound(drive.index.begin(), drive.index.end(), f);
    if (it != drive.index.end() && *it == f) position.push_back(static_cast<std::size_t>(it - drive.index.begin()));
  }
  std::vector<std::size_t> out;
  auto push = [&](std::size_t k) {
    if (out.empty() || out.back() < drive.index[k]) out.push_back(drive.index[k]);
  };
  for (std::size_t j = 0; j < position.size(); ++j) {
    push(position[j]);
    if (j + 1 == position.size()) break;
    const std::size_t a = position[j], b = position[j + 1];
    std::size_t k = a;
    for (std::size_t step = 1; step <= per_gap; ++step) {
      const double target = drive.motion_m[a] + (drive.motion_m[b] - drive.motion_m[a]) * static_cast<double>(step) /
                                                    static_cast<double>(per_gap + 1);
      while (k + 1 < b && drive.motion_m[k + 1] <= target) ++k;
      const bool next_nearer = k + 1 < b && drive.motion_m[k + 1] - target < target - drive.motion_m[k];
      if (k > a || next_nearer) push(next_nearer ? k + 1 : k);
    }
  }
  return out;
}

std::vector<std::size_t> check_sample(const FrameStore& store, std::size_t n, double time_offset_s) {
  const DriveFrames drive = drive_frames(store, time_offset_s);
  std::vector<std::size_t> decoded;
  for (std::size_t k = 0; k < drive.size(); ++k)
    if (drive.decoded[k]) decoded.push_back(drive.index[k]);
  std::vector<std::size_t> out;
  if (decoded.empty() || decoded.size() < n / 2) {  // too few decoded (nothing before it, a short stage 1): any
    for (std::size_t k : spread_over_motion(drive, n)) out.push_back(drive.index[k]);
    return out;
  }
  if (decoded.size() <= n) return decoded;
  // n of them, evenly in time order (they are spread over the drive already; spreading them
  // again by motion would leave slices between stage 1's groups empty).
  for (std::size_t i = 0; i < n; ++i) out.push_back(decoded[i * decoded.size() / n]);
  return out;
}

std::vector<std::vector<std::size_t>> spread_groups(const DriveFrames& frames, const FramesConfig& config,
                                                    std::size_t n_groups, std::size_t per_group) {
  std::vector<std::vector<std::size_t>> groups;
  if (frames.size() < 2 || n_groups == 0 || per_group < 2) return groups;
  const double total = frames.motion_m.back();
  if (total < config.min_step_m) return groups;
  const double min_step_rad = config.min_step_deg * kRadPerDeg;
  std::size_t next_free = 0;  // groups never overlap
  for (std::size_t g = 0; g < n_groups; ++g) {
    const double anchor = total * static_cast<double>(g) / static_cast<double>(n_groups);
    std::size_t k = static_cast<std::size_t>(
        std::lower_bound(frames.motion_m.begin(), frames.motion_m.end(), anchor) - frames.motion_m.begin());
    k = std::max(k, next_free);
    if (k >= frames.size()) break;
    std::vector<std::size_t> group{k};
    for (std::size_t j = k + 1; j < frames.size() && group.size() < per_group; ++j) {
      const Iso3 T_last_j = frames.T_world_ins[group.back()].inverse() * frames.T_world_ins[j];
      if (T_last_j.translation().norm() >= config.min_step_m ||
          Eigen::AngleAxisd(T_last_j.linear()).angle() >= min_step_rad) {
        group.push_back(j);
      }
    }
    if (group.size() < 2) continue;
    next_free = group.back() + 1;
    for (std::size_t& position : group) position = frames.index[position];
    groups.push_back(std::move(group));
  }
  return groups;
}

}  // namespace insalign
