// The simulator's configuration as YAML and the command line see it: one name table per enum
// and the field list of SimConfig (src/io/config_file.hpp walks it).
#pragma once

#include <array>
#include <span>
#include <string_view>

#include "core/enum_names.hpp"
#include "sim/simulate.hpp"

namespace insalign::sim {

inline constexpr std::array<std::pair<SceneKind, std::string_view>, 2> kSceneKindNames{
    {{SceneKind::kIntersection, "intersection"}, {SceneKind::kFeaturePoor, "feature-poor"}}};
constexpr auto enum_names(SceneKind) { return std::span(kSceneKindNames); }

/// kRecorded is chosen by giving a pose file (the CLI's --trajectory FILE), not by name.
inline constexpr std::array<std::pair<TrajectoryKind, std::string_view>, 3> kTrajectoryKindNames{
    {{TrajectoryKind::kFigure8, "figure8"}, {TrajectoryKind::kStraight, "straight"},
     {TrajectoryKind::kStandstill, "standstill"}}};
constexpr auto enum_names(TrajectoryKind) { return std::span(kTrajectoryKindNames); }

inline constexpr std::array<std::pair<InsAxes, std::string_view>, 2> kInsAxesNames{
    {{InsAxes::kXForward, "x-forward"}, {InsAxes::kYForward, "y-forward"}}};
constexpr auto enum_names(InsAxes) { return std::span(kInsAxesNames); }

template <class V>
void visit_config(V& v, SimConfig& c) {
  v("seed", c.seed, "random seed of the scene, noise and mount");
  v("scene", c.scene, "scene: intersection (buildings, poles, cars) or feature-poor");
  v("trajectory", c.trajectory, "drive: figure8, straight or standstill (a recorded one: simulate --trajectory FILE)");
  v("figure8_loops", c.figure8_loops, "loops of the figure-8");
  v("speed_kmh", c.speed_kmh, "cruise speed, km/h");
  v("duration_s", c.duration_s, "0: the trajectory's natural length; > 0 truncates, s");
  v("lidar_model", c.lidar_model, "pandar64, hdl32, os1-64 or vlp16");
  v("azimuth_step_deg", c.azimuth_step_deg, "horizontal resolution, deg");
  v("frame_rate_hz", c.frame_rate_hz, "spin rate, one frame per revolution, Hz");
  v("range_noise_m", c.range_noise_m, "range noise sigma along the ray, m");
  v("dropout_prob", c.dropout_prob, "probability that a return is lost");
  v("max_range_m", c.max_range_m, "no return beyond this, m");
  v("ins_axes", c.ins_axes, "INS body axes: x-forward (ROS REP-103) or y-forward (NovAtel)");
  v("ins_noise_scale", c.ins_noise_scale, "INS noise: 1 = NovAtel RTK class, 0 = perfect poses");
  v("time_offset_s", c.time_offset_s, "true LiDAR-to-INS time offset (t_ins = t_lidar + offset), s");
  v("init_rot_err_deg", c.init_rot_err_deg, "rotation error of the written initial guess, deg");
  v("init_trans_err_m", c.init_trans_err_m, "translation error of the written initial guess, m");
  v("n_fiducials", c.n_fiducials, "surveyed ground points");
  v("fiducial_noise_m", c.fiducial_noise_m, "survey noise sigma per axis, m");
}

}  // namespace insalign::sim
