// insalign simulate --poses-format: the simulated drive's INS written as the logs users have
// (CONVENTIONS.md "INS logs and KITTI raw"), through inslog/ins_log_writer, so that every reader is
// tested end to end against the OpenCalib layout of the same drive.
//
//   format    written into OUT                         `ins` (T_ins_lidar in ground_truth.json)
//   opencalib poses.txt (+ poses_tum.txt), as always     the simulator's INS frame
//   tum       the same files; pass poses_tum.txt         the simulator's INS frame
//   novatel   lidar/ + novatel.log (#INSPVAXA, GPS time)  NovAtel SPAN vehicle frame: x right, y forward, z up
//   sbet      lidar/ + sbet.out (GPS seconds of week)     SBET body frame: x forward, y right, z down
//   csv       lidar/ + ins_export.csv + poses-columns.txt the export's frame: x forward, y right, z down
//   kitti     <date>_drive_0001_sync/{velodyne_points,oxts}/ + calib_imu_to_velo.txt (the initial
//             guess, as T_velo_imu)                      OXTS IMU frame: x forward, y left, z up
//
// Geodetic logs place the simulator's world (x east, y north, z up) in the local ENU frame of
// `log.origin` at the first INS pose, as the recordings do (sim_bag_export.hpp), so that reading
// them back (ENU at the first fix) gives the simulator's world shifted by that pose. Fiducials are
// written geodetic ("# wgs84"); init-extrinsic.json and ground_truth.json in the format's `ins`.
#pragma once

#include <cstddef>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>

#include "core/geometry.hpp"
#include "inslog/ins_log_writer.hpp"
#include "sim/simulate.hpp"

namespace insalign::cli {

enum class PosesFormat { kOpenCalib, kTum, kNovatel, kSbet, kCsv, kKitti };

std::optional<PosesFormat> parse_poses_format(std::string_view name);  ///< "opencalib", "tum", "novatel", ...
const char* poses_format_name(PosesFormat format);
/// novatel, sbet, csv, kitti: the formats this file writes (the others are cmd_simulate's pose files).
bool is_ins_log_format(PosesFormat format);

/// The writers' defaults with the recordings' origin (Munich, as SimBagOptions::origin).
inline io::InsLogWriteOptions sim_log_defaults() {
  io::InsLogWriteOptions o;
  o.origin = {48.137154, 11.576124, 520.25};
  return o;
}

struct SimInsOptions {
  PosesFormat format = PosesFormat::kNovatel;
  double ins_rate_hz = 100.0;
  /// Added to every INS stamp (whole seconds: GPS - UTC, a time zone), so that the log's clock
  /// differs from the LiDAR's as a misconfigured logger's would. Not for KITTI (one clock).
  double ins_clock_offset_s = 0.0;
  /// The ENU origin (the first INS pose), NovAtel record type, undulation, SBET wander angle.
  io::InsLogWriteOptions log = sim_log_defaults();
  /// ground_truth.json as cmd_simulate writes it for the PCD folder; its extrinsic keys are
  /// replaced by those of the format's ins frame and an "ins_log" section is added.
  nlohmann::json ground_truth = nlohmann::json::object();
};

struct SimInsResult {
  std::filesystem::path poses;  ///< what to give calibrate: the --poses FILE, or the --kitti-raw DRIVE_DIR
  std::string poses_columns;    ///< csv: the --poses-columns mapping (also in poses-columns.txt)
  std::size_t records = 0;      ///< INS records written
  std::size_t frames = 0, points = 0;  ///< kitti: sweeps written
  Iso3 T_ins_lidar = Iso3::Identity();  ///< ground truth in the format's ins frame
  std::string ins_frame;                ///< what `ins` is
};

/// T_simins_ins: the format's ins frame in the simulator's INS frame, whatever the simulator's INS
/// axes (NovAtel: T_sim_ins_message of INSPVA; identity for opencalib and tum).
Iso3 T_sim_ins_format(const sim::World& world, PosesFormat format);

/// novatel, sbet, csv: the INS log of a drive whose sweeps cmd_simulate writes into OUT/lidar, and
/// the side files (init-extrinsic.json, fiducials.txt, ground_truth.json, poses-columns.txt).
/// Single LiDAR only. Throws std::invalid_argument for kitti or a pose-file format, InputError for
/// an unwritable output.
SimInsResult write_sim_ins_log(const sim::World& world, const SimInsOptions& options, const std::filesystem::path& out_dir);

/// done / total sweeps written.
using SimInsProgress = std::function<void(std::size_t done, std::size_t total)>;

/// kitti: renders every sweep (in parallel, a few in memory at a time) into a KITTI raw drive in
/// out_dir (the date folder), with fiducials.txt, init-extrinsic.json and ground_truth.json beside
/// it. Single spinning LiDAR; options.ins_clock_offset_s must be 0 (std::invalid_argument).
SimInsResult write_sim_kitti_raw(const sim::World& world, const SimInsOptions& options, const std::filesystem::path& out_dir,
                                 const SimInsProgress& progress = {});

}  // namespace insalign::cli
