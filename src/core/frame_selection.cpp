#include "core/frame_selection.hpp"

#include <algorithm>
#include <cmath>

namespace insalign {

std::vector<std::size_t> FrameSelection::all() const {
  std::vector<std::size_t> out;
  for (const auto& g : groups) out.insert(out.end(), g.begin(), g.end());
  return out;
}

FrameSelection select_frames(const Dataset& data, const FrameSelectionConfig& config) {
  FrameSelection sel;
  if (data.poses.empty()) return sel;
  // Frames whose whole sweep the poses cover, with their pose at the frame time.
  std::vector<std::size_t> covered;
  std::vector<Iso3> T_world_ins;
  for (std::size_t i = 0; i < data.frames.frames.size(); ++i) {
    const double t = data.frames.frames[i].t_end_s + config.time_offset_s;
    if (!data.poses.covers(t) || !data.poses.covers(t - config.sweep_span_s)) continue;
    covered.push_back(i);
    T_world_ins.push_back(data.poses.T_world_ins(t));
  }
  sel.frames_covered = covered.size();
  if (covered.size() < 2) return sel;
  // Cumulative motion measure: distance plus weighted turned angle, so that turning on the spot
  // counts as motion (it determines rotation) and standing still does not.
  std::vector<double> s(covered.size(), 0.0);
  for (std::size_t k = 1; k < covered.size(); ++k) {
    const Iso3 T_prev_cur = T_world_ins[k - 1].inverse() * T_world_ins[k];
    const double d = T_prev_cur.translation().norm();
    const double a = Eigen::AngleAxisd(T_prev_cur.linear()).angle();
    sel.distance_m += d;
    sel.turned_rad += a;
    if (d > 1e-3 || a > 1e-4) ++sel.frames_moving;
    s[k] = s[k - 1] + d + config.rotation_weight_m_per_rad * a;
  }
  const double total = s.back();
  const double min_step_rad = config.min_step_deg * kRadPerDeg;
  if (total < config.min_step_m || config.groups == 0 || config.frames_per_group < 2) return sel;

  std::size_t next_free = 0;  // groups never overlap
  for (std::size_t g = 0; g < config.groups; ++g) {
    // Anchor at the start of the g-th equal slice of the motion measure.
    const double anchor = total * static_cast<double>(g) / static_cast<double>(config.groups);
    std::size_t k = static_cast<std::size_t>(std::lower_bound(s.begin(), s.end(), anchor) - s.begin());
    k = std::max(k, next_free);
    if (k >= covered.size()) break;
    std::vector<std::size_t> group{k};
    for (std::size_t j = k + 1; j < covered.size() && group.size() < config.frames_per_group; ++j) {
      const Iso3 T_last_j = T_world_ins[group.back()].inverse() * T_world_ins[j];
      if (T_last_j.translation().norm() >= config.min_step_m ||
          Eigen::AngleAxisd(T_last_j.linear()).angle() >= min_step_rad)
        group.push_back(j);
    }
    if (group.size() < 2) continue;
    next_free = group.back() + 1;
    for (auto& idx : group) idx = covered[idx];
    sel.groups.push_back(std::move(group));
  }
  return sel;
}

}  // namespace insalign
