#include "core/drive_summary.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace insalign {

DriveSummary summarize_poses(const std::vector<StampedPose>& poses, double speed_window_s) {
  DriveSummary s;
  s.poses = poses.size();
  if (poses.empty()) return s;
  s.duration_s = poses.back().t_s - poses.front().t_s;
  s.bbox_min_m = s.bbox_max_m = poses.front().T_world_ins.translation();
  s.roll_min_deg = s.pitch_min_deg = std::numeric_limits<double>::infinity();
  s.roll_max_deg = s.pitch_max_deg = -std::numeric_limits<double>::infinity();
  double yaw_prev = 0.0, yaw_unwrapped = 0.0, yaw_lo = 0.0, yaw_hi = 0.0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const Vec3 p = poses[i].T_world_ins.translation();
    const Vec3 rpy_deg = rpy_from_rotation(poses[i].T_world_ins.linear()) * kDegPerRad;
    s.bbox_min_m = s.bbox_min_m.cwiseMin(p);
    s.bbox_max_m = s.bbox_max_m.cwiseMax(p);
    s.roll_min_deg = std::min(s.roll_min_deg, rpy_deg.x());
    s.roll_max_deg = std::max(s.roll_max_deg, rpy_deg.x());
    s.pitch_min_deg = std::min(s.pitch_min_deg, rpy_deg.y());
    s.pitch_max_deg = std::max(s.pitch_max_deg, rpy_deg.y());
    const double yaw = rpy_deg.z() * kRadPerDeg;
    if (i > 0) {
      // Unwrap yaw so a turn through +-180 deg counts as the small step it is.
      const double d = wrap_pi(yaw - yaw_prev);
      yaw_unwrapped += d;
      s.heading_change_deg += std::abs(d) * kDegPerRad;
      yaw_lo = std::min(yaw_lo, yaw_unwrapped);
      yaw_hi = std::max(yaw_hi, yaw_unwrapped);
      s.distance_m += (p - poses[i - 1].T_world_ins.translation()).norm();
      s.max_pose_gap_s = std::max(s.max_pose_gap_s, poses[i].t_s - poses[i - 1].t_s);
    }
    yaw_prev = yaw;
  }
  s.heading_range_deg = (yaw_hi - yaw_lo) * kDegPerRad;
  s.speed_mean_mps = s.duration_s > 0 ? s.distance_m / s.duration_s : 0.0;

  // Speeds over windows of at least speed_window_s (the whole drive if it is shorter).
  s.speed_min_mps = std::numeric_limits<double>::infinity();
  s.speed_max_mps = 0.0;
  std::size_t j = 0;
  for (std::size_t i = 0; i + 1 < poses.size(); ++i) {
    j = std::max(j, i + 1);
    while (j + 1 < poses.size() && poses[j].t_s - poses[i].t_s < speed_window_s) ++j;
    const double dt = poses[j].t_s - poses[i].t_s;
    if (dt < speed_window_s && i > 0) break;  // tail shorter than a window: already covered
    double path_m = 0.0;
    for (std::size_t k = i + 1; k <= j; ++k) {
      path_m += (poses[k].T_world_ins.translation() - poses[k - 1].T_world_ins.translation()).norm();
    }
    const double v = dt > 0 ? path_m / dt : 0.0;
    s.speed_min_mps = std::min(s.speed_min_mps, v);
    s.speed_max_mps = std::max(s.speed_max_mps, v);
  }
  if (!std::isfinite(s.speed_min_mps)) s.speed_min_mps = 0.0;
  return s;
}

}  // namespace insalign
