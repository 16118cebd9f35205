#include "sim/export/ground_truth.hpp"

#include <Eigen/Geometry>

#include "core/geometry.hpp"
#include "files/atomic_file.hpp"
#include "files/extrinsic_json.hpp"
#include "sim/simulate_config.hpp"
#include "sim/traffic.hpp"

namespace insalign::cli {

const char* scene_name(sim::SceneKind k) { return k == sim::SceneKind::kFeaturePoor ? "feature-poor" : "intersection"; }
const char* trajectory_name(sim::TrajectoryKind k) {
  return k == sim::TrajectoryKind::kRecorded ? "recorded" : enum_name(k).data();  // the names are literals
}

void write_installed_extrinsics(const sim::World& w, const std::filesystem::path& out) {
  for (const sim::SimLidar& l : w.lidars) {
    const std::string suffix = w.lidars.size() > 1 ? "-" + l.name : "";
    nlohmann::json j;
    j["T_ins_lidar"] = io::transform_to_json(l.T_ins_lidar_installed);
    j["time_offset_s"] = l.time_offset_s;
    j["source"] = "insalign simulate: the installed extrinsic (the truth, knocked back by --knock)";
    io::write_file_atomic(out / ("installed-extrinsic" + suffix + ".json"), j.dump(2) + "\n");
  }
}

namespace {

// The INS error's ground truth; only written when it differs from the default RTK-fixed model
// without events, so a default dataset stays byte for byte what it always was.
bool has_ins_error_truth(const sim::World& w) {
  return w.config.ins_error.model != sim::InsErrorModel::kRtkFixed || !w.ins_events.empty();
}

nlohmann::json ins_error_json(const sim::World& w) {
  const sim::InsErrorConfig& e = w.config.ins_error;
  nlohmann::json j;
  j["model"] = sim::ins_error_model_name(e.model);
  j["drift_horizontal_m_per_sqrt_s"] = e.drift_horizontal_m_per_sqrt_s;
  j["drift_vertical_m_per_sqrt_s"] = e.drift_vertical_m_per_sqrt_s;
  j["drift_heading_deg_per_sqrt_s"] = e.drift_heading_deg_per_sqrt_s;
  j["events"] = nlohmann::json::array();
  for (const sim::InsEvent& ev : w.ins_events) {
    const Vec3 rpy_deg = ev.rpy_error_rad * kDegPerRad;
    j["events"].push_back({{"kind", sim::ins_event_name(ev.kind)},
                           {"t_begin_s", ev.t_begin_s},
                           {"t_end_s", ev.t_end_s},
                           {"error_m", {ev.error_m.x(), ev.error_m.y(), ev.error_m.z()}},
                           {"rpy_error_deg", {rpy_deg.x(), rpy_deg.y(), rpy_deg.z()}}});
  }
  return j;
}

const char* mover_kind_name(sim::MoverKind k) {
  switch (k) {
    case sim::MoverKind::kCar: return "car";
    case sim::MoverKind::kVan: return "van";
    case sim::MoverKind::kCyclist: return "cyclist";
    case sim::MoverKind::kPedestrian: return "pedestrian";
  }
  return "?";
}

// The movers (written only when traffic was asked for): what, how big, how fast, when.
nlohmann::json traffic_json(const sim::World& w) {
  nlohmann::json j;
  j["vehicles_requested"] = w.config.traffic;
  j["people_requested"] = w.config.pedestrians;
  j["movers"] = nlohmann::json::array();
  for (const sim::Mover& m : w.traffic->movers) {
    const Vec3 size = 2.0 * m.half_m;
    j["movers"].push_back({{"kind", mover_kind_name(m.kind)},
                           {"size_m", {size.x(), size.y(), size.z()}},
                           {"speed_mps", m.speed_mps},
                           {"t_begin_s", m.t_start_s},
                           {"t_end_s", m.t_end_s()},
                           {"route_length_m", m.route_s_m.back()}});
  }
  return j;
}

}  // namespace

nlohmann::json ground_truth_json(const sim::World& w, std::size_t points, const GroundTruthLabels& labels) {
  const sim::SimConfig& c = w.config;
  const Iso3& T = w.T_ins_lidar_true;
  const Eigen::Quaterniond q(T.linear());
  const Vec3 rpy = rpy_from_rotation(T.linear()) * kDegPerRad;
  const ExtrinsicError init_err = extrinsic_error(w.T_ins_lidar_init, T);
  nlohmann::json j;
  j["T_ins_lidar"] = io::transform_to_json(T);
  j["translation_m"] = {T.translation().x(), T.translation().y(), T.translation().z()};
  j["rpy_deg"] = {rpy.x(), rpy.y(), rpy.z()};
  j["quaternion_wxyz"] = {q.w(), q.x(), q.y(), q.z()};
  j["time_offset_s"] = w.lidars.front().time_offset_s;  // = c.time_offset_s but in a rig
  j["ins_height_m"] = w.ins_height_m;
  j["T_ins_lidar_init"] = io::transform_to_json(w.T_ins_lidar_init);
  j["T_ins_lidar_installed"] = io::transform_to_json(w.lidars.front().T_ins_lidar_installed);
  j["knock"] = {{"translation_m", {c.knock(0), c.knock(1), c.knock(2)}}, {"rpy_deg", {c.knock(3), c.knock(4), c.knock(5)}}};
  j["init_error"] = {{"angle_deg", init_err.angle_deg}, {"dt_norm_m", init_err.dt_norm_m}};
  j["frames"] = w.frame_count();
  j["points"] = points;
  nlohmann::json cfg;
  cfg["seed"] = c.seed;
  cfg["scene"] = scene_name(c.scene);
  cfg["trajectory"] = c.trajectory == sim::TrajectoryKind::kRecorded ? labels.trajectory : trajectory_name(c.trajectory);
  cfg["figure8_loops"] = c.figure8_loops;
  cfg["speed_kmh"] = c.speed_kmh;
  cfg["duration_s"] = c.duration_s;
  cfg["lidar_model"] = c.lidar_model;
  cfg["azimuth_step_deg"] = c.azimuth_step_deg;
  cfg["frame_rate_hz"] = c.frame_rate_hz;
  cfg["range_noise_m"] = c.range_noise_m;
  cfg["dropout_prob"] = c.dropout_prob;
  cfg["max_range_m"] = c.max_range_m;
  cfg["ins_axes"] = c.ins_axes == sim::InsAxes::kYForward ? "y-forward" : "x-forward";
  cfg["ins_noise_scale"] = c.ins_noise_scale;
  cfg["time_offset_s"] = c.time_offset_s;
  cfg["extrinsic_given"] = c.T_ins_lidar.has_value();
  cfg["init_rot_err_deg"] = c.init_rot_err_deg;
  cfg["init_trans_err_m"] = c.init_trans_err_m;
  cfg["n_fiducials"] = c.n_fiducials;
  cfg["fiducial_noise_m"] = c.fiducial_noise_m;
  cfg["pcd_encoding"] = labels.pcd_encoding;
  j["config"] = cfg;
  if (has_ins_error_truth(w)) j["ins_error"] = ins_error_json(w);
  if (w.config.traffic > 0 || w.config.pedestrians > 0) j["traffic"] = traffic_json(w);
  if (!c.rig.empty()) {
    j["config"]["rig"] = c.rig;
    j["config"]["rig_clock_spread_s"] = c.rig_clock_spread_s;
  }
  return j;
}

// A rig's LiDARs in ground_truth.json, by name (the top-level keys stay those of the first).
nlohmann::json rig_ground_truth_json(const sim::World& w, const std::vector<std::size_t>& points) {
  nlohmann::json j;
  for (std::size_t i = 0; i < w.lidars.size(); ++i) {
    const sim::SimLidar& l = w.lidars[i];
    const Iso3& T = l.T_ins_lidar_true;
    const Vec3 rpy = rpy_from_rotation(T.linear()) * kDegPerRad;
    j[l.name] = {{"T_ins_lidar", io::transform_to_json(T)},
                 {"translation_m", {T.translation().x(), T.translation().y(), T.translation().z()}},
                 {"rpy_deg", {rpy.x(), rpy.y(), rpy.z()}},
                 {"time_offset_s", l.time_offset_s},
                 {"model", l.model.name},
                 {"mount", l.mount},
                 {"frame_rate_hz", l.frame_rate_hz},
                 {"start_azimuth_deg", l.start_azimuth_rad * kDegPerRad},
                 {"frames", l.frame_times_s.size()},
                 {"points", points[i]},
                 {"T_ins_lidar_init", io::transform_to_json(l.T_ins_lidar_init)}};
  }
  return j;
}

}  // namespace insalign::cli
