// Which topics of a recording insalign reads: the LiDAR topics (sensor_msgs/PointCloud2) and the
// one INS source. Choices are automatic when unambiguous and otherwise an InputError that lists
// the candidates and the option that settles it (--lidar-topic, --ins-topic).
//
// INS sources, in order of preference (the first kind the bag holds is used; two topics of that
// kind are ambiguous):
//   1. NovAtel INSPVAX  (novatel_oem7_msgs/INSPVAX, novatel_gps_msgs/Inspvax): pose + solution status
//   2. NovAtel INSPVA   (novatel_oem7_msgs/INSPVA, novatel_gps_msgs/Inspva)
//   3. sensor_msgs/NavSatFix + sensor_msgs/Imu (position from the fix, orientation from the Imu)
//   4. nav_msgs/Odometry
//   5. geometry_msgs/PoseWithCovarianceStamped
//   6. geometry_msgs/PoseStamped
//   7. TF: tf2_msgs/TFMessage (or tf/tfMessage) on /tf, with /tf_static
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "recording/bag_reader.hpp"

namespace insalign::io {

enum class InsSourceKind { kInspvax, kInspva, kNavSatFixImu, kOdometry, kPoseWithCovariance, kPose, kTf };

/// "NovAtel INSPVAX", "NavSatFix + Imu", "TF", ...
const char* ins_source_name(InsSourceKind kind);

/// The kind a message type provides, if any (either type spelling; Imu alone gives kNavSatFixImu).
std::optional<InsSourceKind> ins_source_kind(const std::string& type);

struct InsSourceTopics {
  InsSourceKind kind = InsSourceKind::kOdometry;
  std::uint32_t topic = 0;               ///< the messages: INSPVA(X), NavSatFix, Odometry, ..., /tf
  std::optional<std::uint32_t> partner;  ///< kNavSatFixImu: the Imu; kTf: /tf_static when present
  /// INS topics the bag also holds but that were not chosen, "/odom (nav_msgs/Odometry, 3600 msgs)".
  std::vector<std::string> not_used;
};

/// A LiDAR's name (CONVENTIONS "Rigs"): the topic without its leading '/', '/' replaced by '_'.
std::string lidar_name(const std::string& topic);

/// "/a (1200 msgs)" for a topic.
std::string describe_topic(const bag::Topic& topic);

/// The LiDAR topics, in the order requested (`requested` empty: the only PointCloud2 topic with
/// messages). Throws InputError(bag path, "", ...) listing the candidates with their message counts
/// when there are several and none was requested, when there is none, and when a requested topic
/// is missing or not a PointCloud2.
std::vector<std::uint32_t> choose_lidar_topics(const bag::BagReader& reader, const std::vector<std::string>& requested);

/// The INS source, by the order of preference above, or `requested` (--ins-topic): one topic, or
/// for NavSatFix + Imu either of the two (the other found when unique) or both as "FIX,IMU"; /tf
/// selects TF. Throws InputError(bag path, "", ...) listing the candidates when the choice is
/// ambiguous or there is no INS source.
InsSourceTopics choose_ins_source(const bag::BagReader& reader, const std::optional<std::string>& requested);

}  // namespace insalign::io
