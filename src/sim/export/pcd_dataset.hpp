// A simulated drive written in the OpenCalib layout (CONVENTIONS.md "Dataset layout"): one PCD per
// sweep (a rig: one folder per LiDAR), the pose files, the initial guesses, the fiducials and
// ground_truth.json. Sweeps are rendered and written in parallel, one per worker in memory.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "pointcloud/pcd.hpp"
#include "sim/export/ground_truth.hpp"
#include "sim/simulate.hpp"

namespace insalign::cli {

/// What was rendered, per LiDAR.
struct Rendered {
  std::vector<std::vector<double>> t_end_s;
  std::vector<std::vector<std::string>> names;
  std::vector<std::size_t> points;
};

using SimPcdProgress = std::function<void(std::size_t done, std::size_t total)>;  ///< called from workers

bool is_rig(const sim::World& w);
/// OUT/lidar for a single LiDAR, OUT/lidar/<name> in a rig (a LiDAR's name is its folder's basename).
std::vector<std::filesystem::path> lidar_dirs(const sim::World& w, const std::filesystem::path& out);
/// Creates the folders. Stale frames from an earlier run would silently join this dataset: false
/// (with a message on stderr) unless `overwrite` removes them.
bool prepare_dirs(const std::vector<std::filesystem::path>& dirs, bool overwrite);
/// Every frame of every LiDAR, as PCDs into `dirs` (one per LiDAR).
Rendered render_all(const sim::World& w, const std::vector<std::filesystem::path>& dirs, io::PcdEncoding encoding,
                    const SimPcdProgress& progress);
/// Pose files, initial guesses, fiducials and the ground truth. A single LiDAR: poses.txt and
/// init-extrinsic.json; a rig: poses-<name>.txt and init-extrinsic-<name>.json each.
void write_metadata(const sim::World& w, const std::filesystem::path& out, const Rendered& r, const GroundTruthLabels& labels);
std::uintmax_t directory_bytes(const std::filesystem::path& dir);

}  // namespace insalign::cli
