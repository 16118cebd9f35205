#include "core/deskew.hpp"

#include <algorithm>
#include <cmath>

namespace insalign {

Iso3 frame_pose(const Sweep& sweep, const PoseStream& poses, double time_offset_s) {
  return poses.T_world_ins(sweep.t_end_s + time_offset_s);
}

SweepMotion sweep_motion(const Sweep& sweep, const PoseStream& poses, double time_offset_s, double max_step_s) {
  const auto [lo_f, hi_f] = dt_range(sweep);
  const double lo = lo_f, hi = hi_f;
  SweepMotion m;
  m.dt0_s = lo;
  const int n = std::max(2, static_cast<int>(std::ceil((hi - lo) / max_step_s)) + 1);
  m.step_s = std::max((hi - lo) / (n - 1), 1e-6);
  const double h = 0.005, t_first = poses.t_begin(), t_last = poses.t_end();
  for (int i = 0; i < n; ++i) {
    const double t = std::clamp(sweep.t_end_s + time_offset_s + lo + i * m.step_s, t_first, t_last);
    const double ta = std::max(t - h, t_first), tb = std::min(t + h, t_last);
    const Iso3 T = poses.T_world_ins(t), Ta = poses.T_world_ins(ta), Tb = poses.T_world_ins(tb);
    m.R_world_ins.push_back(T.linear());
    m.t_world_ins.push_back(T.translation());
    m.v_world.push_back((Tb.translation() - Ta.translation()) / (tb - ta));
    m.w_world.push_back(Ta.linear() * so3_log(Ta.linear().transpose() * Tb.linear()) / (tb - ta));
  }
  return m;
}

std::vector<Vec3f> sweep_to_world(const Sweep& sweep, const PoseStream& poses, const Iso3& T_ins_lidar,
                                  const PlaceOptions& options) {
  std::vector<Vec3f> p_world(sweep.size());
  const double t_end_ins = sweep.t_end_s + options.time_offset_s;
  if (!options.per_point_time || !sweep.has_time()) {
    const Eigen::Isometry3f T_world_lidar = (poses.T_world_ins(t_end_ins) * T_ins_lidar).cast<float>();
    for (std::size_t i = 0; i < sweep.size(); ++i) p_world[i] = T_world_lidar * sweep.p_lidar[i];
    return p_world;
  }
  // Knots over the sweep's time span; each point blends the two knot poses around it, which is
  // exact to second order in the motion between knots and costs two transforms per point.
  const auto [dt_min, dt_max] = dt_range(sweep);
  const double span = std::max<double>(dt_max - dt_min, 1e-9);
  const int n_knots = std::max(2, static_cast<int>(std::ceil(span / options.knot_spacing_s)) + 1);
  const double step = span / (n_knots - 1);
  std::vector<Eigen::Isometry3f> T_world_lidar(n_knots);
  for (int k = 0; k < n_knots; ++k) {
    const double t = t_end_ins + dt_min + k * step;
    T_world_lidar[k] = (poses.T_world_ins(t) * T_ins_lidar).cast<float>();
  }
  for (std::size_t i = 0; i < sweep.size(); ++i) {
    const double u = (sweep.dt_s[i] - dt_min) / step;
    const int k = std::clamp(static_cast<int>(u), 0, n_knots - 2);
    const float s = static_cast<float>(u - k);
    p_world[i] = (1.0f - s) * (T_world_lidar[k] * sweep.p_lidar[i]) + s * (T_world_lidar[k + 1] * sweep.p_lidar[i]);
  }
  return p_world;
}

std::vector<Vec3f> deskew_sweep(const Sweep& sweep, const PoseStream& poses, const Iso3& T_ins_lidar,
                                const PlaceOptions& options) {
  std::vector<Vec3f> p = sweep_to_world(sweep, poses, T_ins_lidar, options);
  const Eigen::Isometry3f T_lidarend_world =
      (frame_pose(sweep, poses, options.time_offset_s) * T_ins_lidar).inverse().cast<float>();
  for (auto& q : p) q = T_lidarend_world * q;
  return p;
}

}  // namespace insalign
