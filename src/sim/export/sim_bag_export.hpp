// insalign simulate --format ros1|mcap|db3: a simulated drive written as a recording, the way the
// drivers would publish it, so that the bag path is tested end to end against the PCD folder of
// the same drive.
//
// LiDAR (one topic per simulated LiDAR; one LiDAR: the driver's usual topic), per-point time as
// the driver sets it (pointcloud2.hpp DriverLayout):
//   hesai     `timestamp` float64 absolute s, header.stamp = the first point   (/hesai/pandar)
//   velodyne  `time` float32 s relative to header.stamp = the LAST point      (/velodyne_points)
//   ouster    `t` uint32 ns relative to header.stamp = the first point         (/ouster/points)
//   none      no time field, header.stamp = the sweep end                      (/points)
// INS at ins_rate_hz, the reported (noisy) poses of the simulator, header.stamp on the INS clock:
//   inspva         /novatel/oem7/inspva and /novatel/oem7/inspvax (with solution status and
//                  stddevs): ins = NovAtel SPAN vehicle frame (x right, y forward, z up)
//   navsatfix-imu  /gps/fix + /imu/data (orientation): ins = the simulator's INS frame
//   odometry       /odom (odom -> base_link): ins = the simulator's INS frame
//   tf             /tf (map -> odom -> base_link) + /tf_static (base_link -> imu_link): ins = base_link
// Geodetic messages place the simulator's world (x east, y north, z up) in the local ENU frame of
// `origin`, at the first INS pose, so that reading them back (ENU at the first fix) gives the
// simulator's world shifted by that pose, as the PCD folder's poses are once recentred.
//
// Into out_dir: the recording (drive.bag, drive.mcap, or the rosbag2 folder drive/),
// ground_truth.json (T_ins_lidar for the message's ins frame; a rig: "lidars" by name as well),
// init-extrinsic.json (a rig: also init-extrinsic-<name>.json), fiducials.txt (geodetic,
// "# wgs84", for inspva and navsatfix-imu). A rig's LiDARs are topics /<name>.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>

#include "core/geometry.hpp"
#include "recording/bag_writer.hpp"
#include "core/geodesy.hpp"
#include "sim/simulate.hpp"

namespace insalign::cli {

enum class LidarConvention { kHesai, kVelodyne, kOuster, kNone };
enum class InsMessage { kInspva, kNavSatFixImu, kOdometry, kTf };

struct SimBagOptions {
  io::bag::BagFormat format = io::bag::BagFormat::kMcap;
  LidarConvention lidar_convention = LidarConvention::kHesai;
  InsMessage ins_message = InsMessage::kInspva;
  /// Default: ROS 1 lz4, MCAP zstd, db3 none.
  std::optional<io::bag::Compression> compression;
  double ins_rate_hz = 100.0;
  insalign::GeodeticPoint origin{48.137154, 11.576124, 520.25};  ///< geodetic messages: the first INS pose
  std::string name = "drive";                              ///< the recording's file (folder) name
  /// ground_truth.json as the caller writes it for a PCD folder; its extrinsic keys are replaced
  /// by those of the message's ins frame and a "bag" section is added.
  nlohmann::json ground_truth = nlohmann::json::object();
};

struct SimBagResult {
  std::filesystem::path bag;  ///< the .bag / .mcap file or the rosbag2 folder
  std::size_t frames = 0, points = 0, ins_messages = 0;
  Iso3 T_ins_lidar = Iso3::Identity();  ///< ground truth for the message's ins frame (LiDAR 0)
  std::string ins_frame;                ///< what `ins` is
};

/// done / total clouds written.
using SimBagProgress = std::function<void(std::size_t done, std::size_t total)>;

/// Renders every sweep (in parallel batches, a few in memory at a time) and writes the recording
/// and its ground truth into out_dir (created if needed). Throws InputError for an unwritable
/// output, std::invalid_argument for a bad combination (e.g. ros1 with zstd).
SimBagResult write_sim_bag(const sim::World& world, const SimBagOptions& options, const std::filesystem::path& out_dir,
                           const SimBagProgress& progress = {});

/// T_simins_ins: the message's ins frame in the simulator's INS frame (NovAtel: x right, y
/// forward, z up whatever the simulator's INS axes; identity for the others).
Iso3 T_sim_ins_message(const sim::World& world, InsMessage message);

/// The recording's path in out_dir for a format.
std::filesystem::path sim_bag_path(const std::filesystem::path& out_dir, io::bag::BagFormat format,
                                   const std::string& name = "drive");

std::optional<io::bag::BagFormat> parse_bag_format(std::string_view name);  ///< "ros1", "mcap", "db3"
std::optional<LidarConvention> parse_lidar_convention(std::string_view name);  ///< "hesai", ...
std::optional<InsMessage> parse_ins_message(std::string_view name);            ///< "inspva", ...
const char* lidar_convention_name(LidarConvention c);
const char* ins_message_name(InsMessage m);

}  // namespace insalign::cli
