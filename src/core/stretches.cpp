#include "core/stretches.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace insalign {
namespace {

constexpr double kSampleS = 0.5;  // motion sampled at this step: INS noise is no speed at 0.5 s

double wrap_pi(double a) { return std::remainder(a, 2.0 * std::numbers::pi); }

// Per window of the drive: the numbers its score and its `why` come from. Positions only, so the
// INS's axes do not matter: heading is the direction of travel, slope its climb.
struct Window {
  double begin_s = 0.0, end_s = 0.0;
  double turned_rad = 0.0, net_turn_rad = 0.0, rms_accel_mps2 = 0.0, slope_range_rad = 0.0, mean_speed_mps = 0.0;
  double score = 0.0;
};

Window measure_window(const PoseStream& poses, double t0, double t1) {
  Window w{t0, t1};
  std::vector<Vec3> p;
  for (double t = t0; t <= t1 + 1e-9; t += kSampleS) p.push_back(poses.T_world_ins(t).translation());
  if (p.size() < 3) return w;
  double prev_heading = 0.0, prev_speed = 0.0, accel_sq = 0.0, slope_min = 1e9, slope_max = -1e9, distance = 0.0;
  int n_heading = 0, n_accel = 0;
  for (std::size_t i = 1; i < p.size(); ++i) {
    const Vec3 d = p[i] - p[i - 1];
    const double horizontal = d.head<2>().norm(), speed = d.norm() / kSampleS;
    distance += d.norm();
    if (i > 1) {
      accel_sq += std::pow((speed - prev_speed) / kSampleS, 2);
      ++n_accel;
    }
    prev_speed = speed;
    if (horizontal < 0.3 * kSampleS) continue;  // slower than 0.3 m/s: no heading
    const double heading = std::atan2(d.y(), d.x());
    if (horizontal > 2.0 * kSampleS) {  // slower, the INS's height noise would read as a slope
      const double slope = std::atan2(d.z(), horizontal);
      slope_min = std::min(slope_min, slope), slope_max = std::max(slope_max, slope);
    }
    if (n_heading++ > 0) {
      const double dh = wrap_pi(heading - prev_heading);
      w.turned_rad += std::abs(dh);
      w.net_turn_rad += dh;
    }
    prev_heading = heading;
  }
  w.rms_accel_mps2 = n_accel > 0 ? std::sqrt(accel_sq / n_accel) : 0.0;
  w.slope_range_rad = slope_max > slope_min ? slope_max - slope_min : 0.0;
  w.mean_speed_mps = distance / std::max(t1 - t0, 1e-9);
  return w;
}

std::string describe(const Window& w) {
  std::vector<std::string> parts;
  if (w.turned_rad * 180.0 / std::numbers::pi >= 20.0)
    parts.push_back(fmt::format("turn {:.0f} deg {}", std::abs(w.net_turn_rad) * 180.0 / std::numbers::pi,
                                w.net_turn_rad >= 0 ? "left" : "right"));
  if (w.rms_accel_mps2 >= 0.3) parts.push_back(fmt::format("accelerating/braking {:.1f} m/s2 RMS", w.rms_accel_mps2));
  if (w.slope_range_rad * 180.0 / std::numbers::pi >= 1.0)
    parts.push_back(fmt::format("slope change {:.1f} deg", w.slope_range_rad * 180.0 / std::numbers::pi));
  if (parts.empty()) parts.push_back(fmt::format("driving at {:.0f} km/h", 3.6 * w.mean_speed_mps));
  return fmt::format("{}", fmt::join(parts, ", "));
}

std::vector<Stretch> merge(std::vector<Window> picked) {
  std::sort(picked.begin(), picked.end(), [](const Window& a, const Window& b) { return a.begin_s < b.begin_s; });
  std::vector<Stretch> out;
  for (const Window& w : picked) {
    if (!out.empty() && w.begin_s <= out.back().end_s + 1e-6) {
      out.back().end_s = w.end_s;
      out.back().score += w.score;
      const std::string why = describe(w);
      if (out.back().why.find(why) == std::string::npos) out.back().why += "; " + why;
      continue;
    }
    out.push_back({w.begin_s, w.end_s, w.score, describe(w)});
  }
  return out;
}

}  // namespace

std::vector<Stretch> informative_stretches(const PoseStream& poses, double t_begin_s, double t_end_s,
                                           const StretchConfig& config) {
  t_begin_s = std::max(t_begin_s, poses.t_begin());
  t_end_s = std::min(t_end_s, poses.t_end());
  if (!(t_end_s > t_begin_s)) return {};
  if (t_end_s - t_begin_s <= config.budget_s) {
    Window whole = measure_window(poses, t_begin_s, t_end_s);
    Stretch s{t_begin_s, t_end_s, 0.0, "the whole drive (not longer than check.stretches.budget_s): " + describe(whole)};
    return {s};
  }
  std::vector<Window> windows;
  const double step = std::max(config.window_s, 1.0);
  for (double t = t_begin_s; t + 0.5 * step <= t_end_s; t += step) {
    Window w = measure_window(poses, t, std::min(t + step, t_end_s));
    if (w.mean_speed_mps >= config.min_speed_mps)
      w.score = w.turned_rad + config.accel_weight * w.rms_accel_mps2 + config.slope_weight * w.slope_range_rad;
    windows.push_back(w);
  }
  std::vector<char> taken(windows.size(), 0);
  std::vector<Window> picked;
  double used_s = 0.0;
  auto take = [&](std::size_t i) {
    if (taken[i] || windows[i].score <= 0.0 || used_s >= config.budget_s) return;
    taken[i] = 1;
    used_s += windows[i].end_s - windows[i].begin_s;
    picked.push_back(windows[i]);
  };
  // The best turn each way first: one-way turns leave yaw and the lever arm correlated.
  auto best = [&](int sign) {
    std::size_t arg = windows.size();
    for (std::size_t i = 0; i < windows.size(); ++i)
      if (sign * windows[i].net_turn_rad > 0.35 && (arg == windows.size() || windows[i].score > windows[arg].score)) arg = i;
    if (arg < windows.size()) take(arg);
  };
  best(+1), best(-1);
  std::vector<std::size_t> order(windows.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return windows[a].score > windows[b].score; });
  for (std::size_t i : order) take(i);
  return merge(std::move(picked));
}

FrameStore keep_stretches(const FrameStore& store, const std::vector<Stretch>& stretches) {
  if (stretches.empty()) return store;
  std::vector<TimeSpan> left_out = store.excluded();
  const double t0 = store.poses().t_begin() - 1.0, t1 = store.poses().t_end() + 1.0;
  auto leave_out = [&](double begin_s, double end_s) {
    left_out.push_back({begin_s, end_s, "not an informative stretch (check)", SpanKind::kNotChosen, SpanSource::kCheck});
  };
  double from = t0;
  for (const Stretch& s : stretches) {
    if (s.begin_s > from) leave_out(from, s.begin_s);
    from = std::max(from, s.end_s);
  }
  if (t1 > from) leave_out(from, t1);
  return store.with(store.poses(), std::move(left_out));
}

}  // namespace insalign
