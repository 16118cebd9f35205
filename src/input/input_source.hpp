// The three inputs a command can take, loaded into Datasets with a LoadReport each:
//   a PCD folder + a pose source   (--lidar-dir DIR --poses FILE)         input/dataset.hpp
//   a recording                    (--bag PATH [--lidar-topic T ...])     input/bag_dataset.hpp
//   a KITTI raw drive              (--kitti-raw DRIVE_DIR)                inslog/kitti.hpp
// with the same clock rules for all (input/clock_alignment.hpp): a recording whose clock analysis
// finds a known whole-second gap (ClockGapError with an explanation) is loaded again with the INS
// shifted by it, and the correction is confirmed by the LiDAR motion.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "core/dataset.hpp"
#include "input/bag_dataset.hpp"
#include "input/dataset.hpp"
#include "input/input_config.hpp"

namespace insalign::io {

struct InputSpec {
  /// PCD folders, one per LiDAR (a rig: each folder with the same `poses`), and their pose source.
  std::vector<std::filesystem::path> lidar_dirs;
  std::filesystem::path poses;
  std::filesystem::path bag;               ///< a recording
  std::vector<std::string> lidar_topics;   ///< recordings: --lidar-topic (empty: automatic)
  std::optional<std::string> ins_topic;    ///< recordings: --ins-topic
  std::string world_frame, ins_frame;      ///< recordings with TF
  std::filesystem::path kitti_raw;         ///< a KITTI raw drive folder
  /// Initial guesses (OpenCalib JSON): none, or one per LiDAR in the order of lidar_dirs /
  /// lidar_topics (one LiDAR chosen automatically: one).
  std::vector<std::filesystem::path> inits;
  std::optional<std::filesystem::path> fiducials;
};

enum class InputKind { kPcdFolder, kRecording, kKittiRaw };

/// Which input `spec` names. Throws InputError naming the options when it names none, several,
/// a PCD folder without poses (or poses with another input), recording options without --bag, or
/// a number of --init that is neither 0 nor one per LiDAR.
InputKind input_kind(const InputSpec& spec);

struct LoadedInput {
  InputKind kind = InputKind::kPcdFolder;
  std::vector<std::string> lidar_names;  ///< one per LiDAR (recordings: per topic; else the folder's name)
  std::vector<Dataset> lidars;
  std::vector<LoadReport> reports;       ///< one per LiDAR
  std::optional<BagReport> recording;    ///< recordings: what `info --bag` prints
};

/// Loads whichever input `spec` names. Throws InputError (ClockGapError for clocks nothing
/// explains; also for two LiDARs of the same name, whose outputs would collide).
LoadedInput load_input(const InputSpec& spec, const InputConfig& config = {});

/// A KITTI raw drive: velodyne_points (per-point time from the azimuth), oxts (one clock with the
/// LiDAR), `init` or else ../calib_imu_to_velo.txt as the initial guess.
Dataset load_kitti_raw(const std::filesystem::path& drive_dir, const std::optional<std::filesystem::path>& init,
                       const std::optional<std::filesystem::path>& fiducials, const InputConfig& config,
                       LoadReport* report = nullptr);

/// A recording's INS source as PoseSourceFacts (for info, extrinsic.json, the report).
PoseSourceFacts recording_ins_facts(const InsReport& ins, const std::string& path);

}  // namespace insalign::io
