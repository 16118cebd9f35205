// ground_truth.json of a simulated drive: the true extrinsic and time offset, the wrong initial
// guess, the simulator's configuration and, where the drive has them, the INS error, the traffic
// and a rig's LiDARs by name. Every exporter (PCD folder, recordings, INS logs) writes this shape.
#pragma once

#include <cstddef>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "sim/simulate.hpp"

namespace insalign::cli {

/// What the command line named, where the configuration alone cannot say it.
struct GroundTruthLabels {
  std::string trajectory;    ///< --trajectory as given (a recorded trajectory's file)
  std::string pcd_encoding;  ///< --pcd-encoding
};

/// `points`: of the first LiDAR (0 when unknown, e.g. before rendering).
nlohmann::json ground_truth_json(const sim::World& w, std::size_t points, const GroundTruthLabels& labels);
/// A rig's LiDARs, by name, with their point counts (ground_truth.json "lidars").
nlohmann::json rig_ground_truth_json(const sim::World& w, const std::vector<std::size_t>& points);

const char* scene_name(sim::SceneKind k);
const char* trajectory_name(sim::TrajectoryKind k);
/// installed-extrinsic.json (a rig: installed-extrinsic-<name>.json): what the car believes, in the
/// extrinsic.json shape `insalign check --extrinsic` reads; the truth unless SimConfig::knock.
void write_installed_extrinsics(const sim::World& w, const std::filesystem::path& out);

}  // namespace insalign::cli
