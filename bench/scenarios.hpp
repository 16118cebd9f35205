// The simulated scenarios the accuracy benchmarks share (paper_tables, uncertainty): one name,
// one set of simulator settings on top of whatever --set gave.
#pragma once

#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "files/poses.hpp"
#include "sim/simulate.hpp"

namespace insalign::bench {

inline const std::vector<std::string>& scenario_names() {
  static const std::vector<std::string> names = {
      "default", "recorded", "drift", "drift-position", "float", "wrong-fix", "outage", "traffic", "no-fiducials",
      "no-fiducials-perfect", "hdl32", "os1-64", "vlp16", "livox-avia", "feature-poor", "time-offset", "no-init"};
  return names;
}

/// What a scenario changes besides the simulator: whether the drive comes with an initial guess.
struct ScenarioRun {
  sim::SimConfig sim;
  bool use_init = true;
  bool recorded = false;  ///< along the recorded trajectory (its events are placed over its length)
};

inline void follow_recorded(const std::string& trajectory_file, sim::SimConfig& config) {
  const io::PoseFile file = io::read_pose_file(trajectory_file);
  config.trajectory = sim::TrajectoryKind::kRecorded;
  config.ins_axes = sim::InsAxes::kYForward;
  config.recorded_trajectory.clear();
  for (std::size_t i = 0; i < file.T_world_ins.size(); ++i)
    config.recorded_trajectory.push_back({std::isfinite(file.t_s[i]) ? file.t_s[i] : 0.1 * i, file.T_world_ins[i]});
}

/// The scenario's drive for one seed. Throws std::invalid_argument for an unknown name.
///   recorded: the real NovAtel trajectory (y-forward INS); drift: along it, the INS position
///   walking 5 mm/sqrt(s) per axis and its heading 0.002 deg/sqrt(s) (simulator defaults);
///   drift-position: the position walk alone; float: two 8 s RTK-float episodes (0.3 m peak);
///   wrong-fix: one 5 s wrong fix (0.5 m); outage: one 10 s GNSS outage (the INS coasts to
///   0.3 m); traffic: 20 vehicles and 30 people; no-fiducials: the recorded trajectory without
///   fiducials (tz undetermined); no-fiducials-perfect: the same with perfect poses (no INS error
///   at all: issue 17's x 7.8 mm off against a stddev of 1.1 mm).
inline ScenarioRun make_scenario(const std::string& name, const sim::SimConfig& base, std::uint64_t seed,
                                 const std::string& trajectory_file) {
  ScenarioRun run{base, true};
  sim::SimConfig& c = run.sim;
  c.seed = seed;
  std::mt19937_64 rng(seed * 7919);
  const bool recorded = name == "recorded" || name == "drift" || name == "drift-position" || name == "float" ||
                        name == "wrong-fix" || name == "outage" || name == "no-fiducials" ||
                        name == "no-fiducials-perfect";
  if (recorded) follow_recorded(trajectory_file, c);
  run.recorded = recorded;
  if (name == "drift" || name == "drift-position") c.ins_error.model = sim::InsErrorModel::kDrift;
  if (name == "drift-position") c.ins_error.drift_heading_deg_per_sqrt_s = 0.0;
  if (name == "float") c.ins_error.float_episodes = 2;
  if (name == "wrong-fix") c.ins_error.wrong_fixes = 1;
  if (name == "traffic") c.traffic = 20, c.pedestrians = 30;
  if (name == "outage") c.ins_error.outages = 1;
  if (name == "no-fiducials" || name == "no-fiducials-perfect") c.n_fiducials = 0;
  if (name == "no-fiducials-perfect") c.ins_noise_scale = 0.0;
  if (name == "feature-poor") c.scene = sim::SceneKind::kFeaturePoor;
  if (name == "hdl32" || name == "os1-64" || name == "vlp16" || name == "livox-avia") c.lidar_model = name;
  if (name == "time-offset") c.time_offset_s = std::uniform_real_distribution<double>(-0.05, 0.05)(rng);
  if (name == "no-init") run.use_init = false;
  bool known = false;
  for (const std::string& n : scenario_names()) known = known || n == name;
  if (!known) throw std::invalid_argument("unknown scenario '" + name + "'");
  return run;
}

/// The INS's drive-mean heading error over the given INS times (rad): a constant heading error
/// is an extrinsic yaw error, so an estimate's yaw is off by about minus this, whatever the method.
inline double mean_heading_error_rad(const sim::World& world, const std::vector<double>& t_ins_s) {
  double sum = 0.0;
  for (double t : t_ins_s) sum += sim::ins_slow_error(world, t).rpy_world_rad.z();
  return t_ins_s.empty() ? 0.0 : sum / static_cast<double>(t_ins_s.size());
}

}  // namespace insalign::bench
