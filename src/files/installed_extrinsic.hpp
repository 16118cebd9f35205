// The extrinsic a car has installed, from any file insalign writes or takes: extrinsic.json,
// the OpenCalib JSON (T_lidar_ins), rig.json, the URDF/xacro (one joint, or a rig's joints), the
// ROS 2 static_transform_publisher script, the Autoware YAML, or KITTI calib_imu_to_velo.txt
// (T_velo_imu). Detected from the content, not the name: a renamed file still reads.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "core/geometry.hpp"

namespace insalign::io {

struct InstalledExtrinsic {
  std::string name;          ///< the LiDAR's name where the file names it (rig.json keys, URDF child links)
  Iso3 T_ins_lidar = Iso3::Identity();
  double time_offset_s = 0.0;  ///< 0 where the format has none
  std::string format;        ///< "extrinsic.json", "opencalib", "rig.json", "urdf", "ros2", "autoware", "kitti"
};

/// One entry per LiDAR the file holds (one for every format but rig.json and a rig URDF).
/// Throws InputError naming the file (and the line or byte) when it is none of the formats.
std::vector<InstalledExtrinsic> parse_installed_extrinsics(std::string_view text, const std::string& file_for_errors);
std::vector<InstalledExtrinsic> read_installed_extrinsics(const std::filesystem::path& path);

/// An `--init` file: any of the formats above holding one extrinsic (a rig's file: one --init per
/// LiDAR instead). Its time offset is not used: the stages estimate it.
Iso3 read_init_extrinsic(const std::filesystem::path& path);

}  // namespace insalign::io
