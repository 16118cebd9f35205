// The calibrated extrinsic in the shapes other stacks read, so nobody retypes numbers:
// a URDF/xacro joint, a ROS 2 static_transform_publisher command, an Autoware-style YAML and a
// KITTI calib_imu_to_velo.txt. Each writer has a reader (used by the round-trip tests and by
// anyone who wants to bring a calibration back). Numbers are printed with 17 significant digits.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "core/geometry.hpp"

namespace insalign::io {

/// Frame (link) names written into the formats: the parent is the INS body frame, the child the
/// LiDAR. The transform written is always T_parent_child = T_ins_lidar.
struct FrameNames {
  std::string parent = "ins";
  std::string child = "lidar";
};

/// A transform read back, with the frame names found in the file (empty where it has none).
struct ReadTransform {
  Iso3 T_parent_child = Iso3::Identity();
  FrameNames names;
};

/// URDF fixed joint `<origin xyz="x y z" rpy="roll pitch yaw"/>` (m, rad). URDF rpy is fixed-axis
/// X-Y-Z, which is the same matrix as our ZYX R = Rz(yaw) Ry(pitch) Rx(roll).
std::string format_urdf(const Iso3& T_ins_lidar, const FrameNames& names);
ReadTransform parse_urdf(std::string_view text, const std::string& file_for_errors);

/// `ros2 run tf2_ros static_transform_publisher --x .. --yaw .. --frame-id P --child-frame-id C`
/// (m, rad; the publisher's transform is the child's pose in the parent frame).
std::string format_ros2_static_tf(const Iso3& T_ins_lidar, const FrameNames& names);
ReadTransform parse_ros2_static_tf(std::string_view text, const std::string& file_for_errors);

/// Autoware sensor-kit calibration style: `parent: child: {x, y, z, roll, pitch, yaw}` (m, rad).
std::string format_autoware_yaml(const Iso3& T_ins_lidar, const FrameNames& names);
ReadTransform parse_autoware_yaml(std::string_view text, const std::string& file_for_errors);

/// KITTI raw calib_imu_to_velo.txt: `R:` 9 numbers row-major and `T:` 3 numbers mapping IMU
/// coordinates into Velodyne coordinates, i.e. T_lidar_ins (the inverse of T_ins_lidar).
/// The reader returns T_ins_lidar (names stay empty: the format has none).
std::string format_kitti_imu_to_velo(const Iso3& T_ins_lidar);
ReadTransform parse_kitti_imu_to_velo(std::string_view text, const std::string& file_for_errors);

/// File names write_all_formats uses inside out_dir.
inline constexpr const char* kUrdfFile = "extrinsic.urdf.xacro";
inline constexpr const char* kRos2File = "static_transform_publisher.sh";
inline constexpr const char* kAutowareFile = "extrinsic_autoware.yaml";
inline constexpr const char* kKittiFile = "calib_imu_to_velo.txt";

/// Writes the four files atomically into out_dir; returns their paths.
std::vector<std::filesystem::path> write_all_formats(const std::filesystem::path& out_dir,
                                                     const Iso3& T_ins_lidar, const FrameNames& names = {});

}  // namespace insalign::io
