// Loads and validates a dataset in the OpenCalib layout (CONVENTIONS.md): a folder of PCD frames,
// a pose source (OpenCalib, TUM or any INS log inslog/pose_source.hpp reads), optionally an initial
// extrinsic and fiducials (world frame or geodetic).
#pragma once

#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "core/dataset.hpp"
#include "core/drive_summary.hpp"
#include "input/clock_alignment.hpp"
#include "input/input_config.hpp"
#include "inslog/pose_source.hpp"

namespace insalign::io {

using insalign::DriveSummary;  // lives in core (pose-only); re-exported for io users

struct DatasetPaths {
  std::filesystem::path lidar_dir{}, poses{};
  std::optional<std::filesystem::path> init{}, fiducials{};  ///< --init (OpenCalib JSON), --fiducials
};

/// What load_dataset found and decided; every skipped item is counted and explained in warnings.
struct LoadReport {
  std::size_t frames_total = 0;          ///< *.pcd files in lidar_dir
  std::size_t frames_used = 0;           ///< frames in the returned dataset
  std::size_t frames_without_pose = 0;   ///< OpenCalib: no pose line with the frame's name
  std::size_t frames_outside_poses = 0;  ///< frame time outside the pose time range (skipped)
  std::size_t frames_bad = 0;            ///< unreadable header or wrong file size (skipped)
  std::size_t poses_without_frame = 0;   ///< OpenCalib pose lines with no PCD of that name
  std::size_t poses_unplaced = 0;        ///< OpenCalib poses whose time is unknown (dropped)
  std::size_t skipped_files = 0;         ///< non-PCD files in lidar_dir
  std::string time_field;                ///< of the sampled PCDs: "timestamp", "time", "t" or ""
  std::string frame_time_source;         ///< how frame times were found (human readable)
  std::string pose_format;               ///< short: "opencalib", "tum", "novatel", "sbet", "csv", "kitti", "bag: ..."
  double name_to_lidar_clock_s = 0.0;    ///< added to frame-name times to get LiDAR time
  std::vector<std::string> warnings;
  // What was read, for info, extrinsic.json "input" and the report (input/input_report.hpp).
  std::string input_kind;                ///< "PCD folder", "recording", "KITTI raw drive"
  std::string source;                    ///< the LiDAR input: folder, recording + topic, drive
  PoseSourceFacts ins;                   ///< the pose source
  std::optional<ClockAlignment> clock;   ///< the LiDAR-INS clock decision
  std::string fiducials;                 ///< "6 in the world frame (FILE)", "6 geodetic (# wgs84) ...", ""
  std::string init;                      ///< where the initial guess came from, "" for none
};

/// Validates everything it can without decoding every sweep (headers and file sizes of all PCDs,
/// full decode of a few to align clocks) and returns a dataset whose frames load lazily and
/// thread-safely. Decisions (documented here because tests rely on them):
/// - non-PCD files are ignored (counted, one warning); no PCD at all is an InputError;
/// - frames with a broken header or size are skipped with a warning; all broken is an InputError;
/// - frame times come from the names when they encode times, aligned to the PCD clock by the
///   median of (PCD t_end_s - name time) over the sampled frames (warning if inconsistent);
///   otherwise from every PCD's absolute timestamps (slow: each sweep is decoded once);
/// - the pose source is read after the frames (SBET and gps-sow exports are dated by the first
///   frame time); two frames or two poses at the same time are an InputError (the data is
///   ambiguous); unsorted pose lines are sorted, with a warning;
/// - the LiDAR and INS clocks are compared (input/clock_alignment.hpp): a whole-second offset is found
///   from the data and the INS times shifted onto the LiDAR clock, reported in `clock`; a gap
///   nothing explains is a ClockGapError (an InputError) with both ranges;
/// - frames outside the pose time range are skipped with a warning; all of them is an InputError;
/// - the world is recentred on the first pose position (world_origin_m), fiducials too (geodetic
///   ones through the pose source's local ENU frame: an InputError for a cartesian source).
/// Throws InputError(file, "line N"/"byte N"/"", what).
Dataset load_dataset(const DatasetPaths& paths, LoadReport* report = nullptr);
Dataset load_dataset(const DatasetPaths& paths, const InputConfig& config, LoadReport* report = nullptr);

/// Pose figures plus points per frame from up to frames_to_sample evenly spaced frames.
DriveSummary summarize_drive(const Dataset& dataset, std::size_t frames_to_sample = 5);

/// A dataset from timed frames and a timed pose source (not OpenCalib: that needs the frames'
/// names): poses sorted and recentred, the clock decided by `config` (align_clocks) or, when
/// `one_clock` says why, taken as one clock; frames the poses do not reach left out.
Dataset timed_dataset(FrameSource frames, const PoseSource& source, const InputConfig& config, LoadReport& report,
                      const std::string& one_clock = "");

/// The dataset's poses (and INS quality) moved onto the LiDAR clock by `clock` (t - offset), the
/// frames the shifted poses do not reach left out and counted in `report` with warnings. Throws
/// InputError(file, "", ...) naming both ranges when no frame is left.
void apply_clock(Dataset& dataset, const ClockAlignment& clock, const std::string& file, LoadReport& report);

}  // namespace insalign::io
