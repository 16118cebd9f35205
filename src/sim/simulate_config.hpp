// The simulator's configuration as YAML and the command line see it: one name table per enum
// and the field list of SimConfig (src/files/config_file.hpp walks it).
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
inline constexpr std::array<std::pair<TrajectoryKind, std::string_view>, 7> kTrajectoryKindNames{
    {{TrajectoryKind::kFigure8, "figure8"}, {TrajectoryKind::kStraight, "straight"},
     {TrajectoryKind::kStandstill, "standstill"}, {TrajectoryKind::kCityLoop, "city-loop"},
     {TrajectoryKind::kUrbanGrid, "urban-grid"}, {TrajectoryKind::kHighway, "highway"},
     {TrajectoryKind::kParkingLot, "parking-lot"}}};
constexpr auto enum_names(TrajectoryKind) { return std::span(kTrajectoryKindNames); }

inline constexpr std::array<std::pair<InsAxes, std::string_view>, 2> kInsAxesNames{
    {{InsAxes::kXForward, "x-forward"}, {InsAxes::kYForward, "y-forward"}}};
constexpr auto enum_names(InsAxes) { return std::span(kInsAxesNames); }

inline constexpr std::array<std::pair<InsErrorModel, std::string_view>, 2> kInsErrorModelNames{
    {{InsErrorModel::kRtkFixed, "rtk-fixed"}, {InsErrorModel::kDrift, "drift"}}};
constexpr auto enum_names(InsErrorModel) { return std::span(kInsErrorModelNames); }

template <class V>
void visit_config(V& v, InsErrorConfig& c) {
  v("model", c.model, "slow INS error: rtk-fixed (bounded, the default) or drift (random walk)");
  v("drift_horizontal_m_per_sqrt_s", c.drift_horizontal_m_per_sqrt_s, "drift: position random walk per horizontal axis, m/sqrt(s)");
  v("drift_vertical_m_per_sqrt_s", c.drift_vertical_m_per_sqrt_s, "drift: vertical random walk, m/sqrt(s)");
  v("drift_heading_deg_per_sqrt_s", c.drift_heading_deg_per_sqrt_s, "drift: heading random walk, deg/sqrt(s)");
  v("float_episodes", c.float_episodes, "RTK float episodes (error ramping up and back)");
  v("float_peak_m", c.float_peak_m, "float episode: peak position error, m");
  v("float_duration_s", c.float_duration_s, "float episode: length, s");
  v("wrong_fixes", c.wrong_fixes, "wrong RTK fixes (a jump, reported as a normal fix)");
  v("wrong_fix_jump_m", c.wrong_fix_jump_m, "wrong fix: position jump, m");
  v("wrong_fix_duration_s", c.wrong_fix_duration_s, "wrong fix: length, s");
  v("outages", c.outages, "GNSS outages (the INS coasts)");
  v("outage_duration_s", c.outage_duration_s, "outage: length, s");
  v("outage_error_m", c.outage_error_m, "outage: position error at its end (grows quadratically), m");
  v("outage_tilt_deg", c.outage_tilt_deg, "outage: roll and pitch error at its end, deg");
  v("outage_heading_deg", c.outage_heading_deg, "outage: heading error at its end, deg");
}

template <class V>
void visit_config(V& v, SimConfig& c) {
  v("seed", c.seed, "random seed of the scene, noise and mount");
  v("scene", c.scene, "scene: intersection (buildings, poles, cars) or feature-poor");
  v("trajectory", c.trajectory,
    "drive: figure8, straight, standstill, or an ordinary drive city-loop, urban-grid, highway, parking-lot (a recorded one: simulate --trajectory FILE)");
  v("ordinary_speed_kmh", c.ordinary_speed_kmh, "ordinary drives' cruise speed (0: the kind's own: city 30, highway 90, parking 10), km/h");
  v("figure8_loops", c.figure8_loops, "loops of the figure-8");
  v("speed_kmh", c.speed_kmh, "cruise speed, km/h");
  v("duration_s", c.duration_s, "0: the trajectory's natural length; > 0 truncates, s");
  v("lidar_model", c.lidar_model, "pandar64, hdl32, os1-64, vlp16 or livox-avia");
  v("azimuth_step_deg", c.azimuth_step_deg, "horizontal resolution, deg");
  v("frame_rate_hz", c.frame_rate_hz, "spin rate, one frame per revolution, Hz");
  v("range_noise_m", c.range_noise_m, "range noise sigma along the ray, m");
  v("dropout_prob", c.dropout_prob, "probability that a return is lost");
  v("max_range_m", c.max_range_m, "no return beyond this, m");
  v("ins_axes", c.ins_axes, "INS body axes: x-forward (ROS REP-103) or y-forward (NovAtel)");
  v("ins_noise_scale", c.ins_noise_scale, "INS white noise (and the rtk-fixed bounded error): 1 = NovAtel RTK class, 0 = none");
  v.section("ins_error", c.ins_error);
  v("time_offset_s", c.time_offset_s, "true LiDAR-to-INS time offset (t_ins = t_lidar + offset), s");
  v("init_rot_err_deg", c.init_rot_err_deg, "rotation error of the written initial guess, deg");
  v("init_trans_err_m", c.init_trans_err_m, "translation error of the written initial guess, m");
  v("n_fiducials", c.n_fiducials, "surveyed ground points");
  v("fiducial_noise_m", c.fiducial_noise_m, "survey noise sigma per axis, m");
  v("traffic", c.traffic, "moving cars and vans in the lanes beside the path");
  v("pedestrians", c.pedestrians, "moving people (cyclists, walkers, joggers) on bike lanes and sidewalks");
}

}  // namespace insalign::sim
