// The ROS messages insalign reads, as plain structs, with decode (bytes -> struct) and encode
// (struct -> bytes, for the simulator's bag writer) in both ROS 1 serialization and CDR. Field
// names follow the messages. ROS 1 and ROS 2 differ only in std_msgs/Header (ROS 1 has a uint32
// `seq` first, which ROS 2 lacks; `seq` is ignored when writing CDR) and in the time type.
//
// Every decode takes `where` (names the message in errors) and throws InputError(where,
// "byte N", "<type>: what") for bytes that do not hold the message.
//
// The conversions to io::InsRecord at the end apply CONVENTIONS.md ("Recordings: ROS bags").
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/geometry.hpp"
#include "recording/bag_reader.hpp"
#include "recording/ros_serialization.hpp"
#include "inslog/ins_track.hpp"

namespace insalign::io::bag {

using Bytes = std::span<const std::uint8_t>;
using Covariance9 = std::array<double, 9>;    ///< 3x3 row-major
using Covariance36 = std::array<double, 36>;  ///< 6x6 row-major (x, y, z, rot x, rot y, rot z)

struct Header {
  std::uint32_t seq = 0;  ///< ROS 1 only
  Stamp stamp;
  std::string frame_id;
  bool operator==(const Header&) const = default;
};

struct Quaternion {
  double x = 0.0, y = 0.0, z = 0.0, w = 1.0;
  bool operator==(const Quaternion&) const = default;
};

struct Pose {
  Vec3 position = Vec3::Zero();
  Quaternion orientation;
  bool operator==(const Pose&) const = default;
};
struct PoseWithCovariance {
  Pose pose;
  Covariance36 covariance{};
  bool operator==(const PoseWithCovariance&) const = default;
};
struct TwistWithCovariance {
  Vec3 linear = Vec3::Zero(), angular = Vec3::Zero();  ///< geometry_msgs/Twist
  Covariance36 covariance{};
  bool operator==(const TwistWithCovariance&) const = default;
};

/// nav_msgs/Odometry
struct Odometry {
  Header header;
  std::string child_frame_id;
  PoseWithCovariance pose;
  TwistWithCovariance twist;
  bool operator==(const Odometry&) const = default;
};
/// geometry_msgs/PoseStamped
struct PoseStamped {
  Header header;
  Pose pose;
  bool operator==(const PoseStamped&) const = default;
};
/// geometry_msgs/PoseWithCovarianceStamped
struct PoseWithCovarianceStamped {
  Header header;
  PoseWithCovariance pose;
  bool operator==(const PoseWithCovarianceStamped&) const = default;
};
/// geometry_msgs/TransformStamped: T_parent_child with parent = header.frame_id.
struct TransformStamped {
  Header header;
  std::string child_frame_id;
  Vec3 translation = Vec3::Zero();  ///< geometry_msgs/Transform
  Quaternion rotation;
  bool operator==(const TransformStamped&) const = default;
};
/// tf2_msgs/TFMessage and tf/tfMessage (the same layout).
struct TFMessage {
  std::vector<TransformStamped> transforms;
  bool operator==(const TFMessage&) const = default;
};

/// sensor_msgs/NavSatFix (with its sensor_msgs/NavSatStatus).
struct NavSatFix {
  enum Status : std::int8_t { kNoFix = -1, kFix = 0, kSbasFix = 1, kGbasFix = 2 };
  enum CovarianceType : std::uint8_t { kUnknown = 0, kApproximated = 1, kDiagonalKnown = 2, kKnown = 3 };
  Header header;
  std::int8_t status = kNoFix;
  std::uint16_t service = 0;
  double latitude = 0.0, longitude = 0.0, altitude = 0.0;  ///< deg, deg, m above the WGS-84 ellipsoid
  Covariance9 position_covariance{};                        ///< m^2, east/north/up
  std::uint8_t position_covariance_type = kUnknown;
  bool operator==(const NavSatFix&) const = default;
};

/// sensor_msgs/Imu. orientation_covariance[0] == -1 means the IMU gives no orientation.
struct Imu {
  Header header;
  Quaternion orientation;
  Covariance9 orientation_covariance{};
  Vec3 angular_velocity = Vec3::Zero();
  Covariance9 angular_velocity_covariance{};
  Vec3 linear_acceleration = Vec3::Zero();
  Covariance9 linear_acceleration_covariance{};
  bool has_orientation() const { return orientation_covariance[0] != -1.0; }
  bool operator==(const Imu&) const = default;
};

/// sensor_msgs/PointField
struct PointField {
  enum Datatype : std::uint8_t { kInt8 = 1, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };
  std::string name;
  std::uint32_t offset = 0;
  std::uint8_t datatype = kFloat32;
  std::uint32_t count = 1;
  bool operator==(const PointField&) const = default;
};
/// Bytes of one element of a PointField datatype; 0 for a value outside INT8..FLOAT64.
std::size_t point_field_size(std::uint8_t datatype);
/// "float32", "uint16", ... or "datatype 9".
std::string point_field_type_name(std::uint8_t datatype);

/// sensor_msgs/PointCloud2 without its data: what reading the points needs.
struct PointCloud2Layout {
  Header header;
  std::uint32_t height = 1, width = 0;
  std::vector<PointField> fields;
  bool is_bigendian = false;
  std::uint32_t point_step = 0, row_step = 0;
  bool is_dense = true;
  bool operator==(const PointCloud2Layout&) const = default;
};
struct PointCloud2 : PointCloud2Layout {
  std::vector<std::uint8_t> data;
  bool operator==(const PointCloud2&) const = default;
};

// ---------------------------------------------------------------------------- NovAtel messages

/// novatel_oem7_msgs/Oem7Header. Three layouts exist across driver releases; the decoders find
/// which one from the message size (the fields after it are fixed-size).
struct Oem7Header {
  enum class Layout {
    kBase,           ///< ends with gps_week_milliseconds (ROS 1 releases)
    kIdleTime,       ///< + uint8 idle_time
    kReceiverStatus  ///< + uint32 receiver_status + float32 idle_time (ROS 2 Jazzy releases)
  };
  std::string message_name;
  std::uint16_t message_id = 0;
  std::uint8_t message_type = 0;
  std::uint32_t sequence_number = 0;
  std::uint8_t time_status = 0;
  std::uint16_t gps_week_number = 0;
  std::uint32_t gps_week_milliseconds = 0;
  std::uint32_t receiver_status = 0;  ///< kReceiverStatus only
  float idle_time = 0.0f;             ///< kIdleTime (0..255) and kReceiverStatus
  Layout layout = Layout::kBase;
  bool operator==(const Oem7Header&) const = default;
};

/// Roll, pitch, azimuth (deg) and velocities (m/s) common to every INSPVA flavour.
struct NovatelAttitude {
  double north_velocity = 0.0, east_velocity = 0.0, up_velocity = 0.0;
  double roll = 0.0, pitch = 0.0, azimuth = 0.0;
  bool operator==(const NovatelAttitude&) const = default;
};

/// novatel_oem7_msgs/INSPVA. height: above the WGS-84 ellipsoid.
struct Oem7Inspva {
  Header header;
  Oem7Header nov_header;
  double latitude = 0.0, longitude = 0.0, height = 0.0;
  NovatelAttitude pva;
  std::uint32_t status = 0;  ///< InertialSolutionStatus
  bool operator==(const Oem7Inspva&) const = default;
};

/// novatel_oem7_msgs/INSPVAX. height: above mean sea level (ellipsoidal = height + undulation).
struct Oem7Inspvax {
  Header header;
  Oem7Header nov_header;
  std::uint32_t ins_status = 0;  ///< InertialSolutionStatus
  std::uint32_t pos_type = 0;    ///< PositionOrVelocityType
  double latitude = 0.0, longitude = 0.0, height = 0.0;
  float undulation = 0.0f;
  NovatelAttitude pva;
  float latitude_stdev = 0, longitude_stdev = 0, height_stdev = 0;
  float north_velocity_stdev = 0, east_velocity_stdev = 0, up_velocity_stdev = 0;
  float roll_stdev = 0, pitch_stdev = 0, azimuth_stdev = 0;
  std::uint32_t ext_sol_status = 0;  ///< INSExtendedSolutionStatus
  std::uint16_t time_since_update = 0;
  bool operator==(const Oem7Inspvax&) const = default;
};

/// novatel_gps_msgs/NovatelMessageHeader (with its NovatelReceiverStatus).
struct NovatelMessageHeader {
  std::string message_name, port;
  std::uint32_t sequence_num = 0;
  float percent_idle_time = 0.0f;
  std::string gps_time_status;
  std::uint32_t gps_week_num = 0;
  double gps_seconds = 0.0;
  std::uint32_t receiver_status_code = 0;        ///< NovatelReceiverStatus.original_status_code
  std::array<bool, 23> receiver_status_flags{};  ///< its 23 bools, in message order
  std::uint32_t receiver_software_version = 0;
  bool operator==(const NovatelMessageHeader&) const = default;
};

/// novatel_gps_msgs/Inspva. height: above the WGS-84 ellipsoid; status: "INS_SOLUTION_GOOD", ...
struct NovatelGpsInspva {
  Header header;
  NovatelMessageHeader novatel_msg_header;
  std::uint32_t week = 0;
  double seconds = 0.0;
  double latitude = 0.0, longitude = 0.0, height = 0.0;
  NovatelAttitude pva;
  std::string status;
  bool operator==(const NovatelGpsInspva&) const = default;
};

/// novatel_gps_msgs/Inspvax. altitude: above mean sea level. The trailing extended status exists
/// in two layouts (NovatelExtendedSolutionStatus in the released versions, which encode writes;
/// NovatelInsExtendedSolutionStatus in newer sources); insalign reads nothing after azimuth_std.
struct NovatelGpsInspvax {
  Header header;
  NovatelMessageHeader novatel_msg_header;
  std::string ins_status, position_type;  ///< "INS_SOLUTION_GOOD", "INS_RTKFIXED", ...
  double latitude = 0.0, longitude = 0.0, altitude = 0.0;
  float undulation = 0.0f;
  NovatelAttitude pva;
  float latitude_std = 0, longitude_std = 0, altitude_std = 0;
  float north_velocity_std = 0, east_velocity_std = 0, up_velocity_std = 0;
  float roll_std = 0, pitch_std = 0, azimuth_std = 0;
  std::uint32_t extended_status_mask = 0;  ///< original_mask of either layout
  bool advance_rtk_verified = false;
  std::string pseudorange_iono_correction;  ///< the message spells it `psueorange_iono_correction`
  std::uint16_t seconds_since_update = 0;
  bool extended_status_read = false;  ///< false when the tail fits neither layout (then zeros)
  bool operator==(const NovatelGpsInspvax&) const = default;
};

// ------------------------------------------------------------------------------ decode / encode

Header decode_header(Bytes bytes, MessageEncoding encoding, const std::string& where);
PointCloud2 decode_pointcloud2(Bytes bytes, MessageEncoding encoding, const std::string& where);
/// Everything but the data, which is returned as a view into `bytes` (no copy).
PointCloud2Layout decode_pointcloud2_layout(Bytes bytes, MessageEncoding encoding, const std::string& where,
                                            Bytes& data);
/// The layout from the bytes before the data only, so a prefix of the message is enough (e.g.
/// BagReader::read_prefix); `data_bytes` is the length the data claims; is_dense is not read.
PointCloud2Layout decode_pointcloud2_head(Bytes prefix, MessageEncoding encoding, const std::string& where,
                                          std::size_t* data_bytes = nullptr);
NavSatFix decode_navsatfix(Bytes bytes, MessageEncoding encoding, const std::string& where);
Imu decode_imu(Bytes bytes, MessageEncoding encoding, const std::string& where);
Odometry decode_odometry(Bytes bytes, MessageEncoding encoding, const std::string& where);
PoseStamped decode_pose_stamped(Bytes bytes, MessageEncoding encoding, const std::string& where);
PoseWithCovarianceStamped decode_pose_with_covariance_stamped(Bytes bytes, MessageEncoding encoding,
                                                              const std::string& where);
TFMessage decode_tf_message(Bytes bytes, MessageEncoding encoding, const std::string& where);
/// The Oem7Header layout is `layout` when given (from the stored definition, see
/// message_definitions.hpp), else the one the message size fits; where two fit (CDR padding can
/// hide a field), the one whose status values are plausible, then the newest.
Oem7Inspva decode_oem7_inspva(Bytes bytes, MessageEncoding encoding, const std::string& where,
                              std::optional<Oem7Header::Layout> layout = std::nullopt);
Oem7Inspvax decode_oem7_inspvax(Bytes bytes, MessageEncoding encoding, const std::string& where,
                                std::optional<Oem7Header::Layout> layout = std::nullopt);
NovatelGpsInspva decode_novatel_gps_inspva(Bytes bytes, MessageEncoding encoding, const std::string& where);
NovatelGpsInspvax decode_novatel_gps_inspvax(Bytes bytes, MessageEncoding encoding, const std::string& where);

std::vector<std::uint8_t> encode_message(const Header& msg, MessageEncoding encoding);
std::vector<std::uint8_t> encode_message(const PointCloud2& msg, MessageEncoding encoding);
std::vector<std::uint8_t> encode_message(const NavSatFix& msg, MessageEncoding encoding);
std::vector<std::uint8_t> encode_message(const Imu& msg, MessageEncoding encoding);
std::vector<std::uint8_t> encode_message(const Odometry& msg, MessageEncoding encoding);
std::vector<std::uint8_t> encode_message(const PoseStamped& msg, MessageEncoding encoding);
std::vector<std::uint8_t> encode_message(const PoseWithCovarianceStamped& msg, MessageEncoding encoding);
std::vector<std::uint8_t> encode_message(const TFMessage& msg, MessageEncoding encoding);
std::vector<std::uint8_t> encode_message(const Oem7Inspva& msg, MessageEncoding encoding);
std::vector<std::uint8_t> encode_message(const Oem7Inspvax& msg, MessageEncoding encoding);
std::vector<std::uint8_t> encode_message(const NovatelGpsInspva& msg, MessageEncoding encoding);
std::vector<std::uint8_t> encode_message(const NovatelGpsInspvax& msg, MessageEncoding encoding);

/// The pieces, for messages that embed them. read_header also reads the header.stamp of any
/// stamped message from a prefix of it.
Header read_header(MessageReader& in);
void write_header(MessageWriter& out, const Header& header);

// ------------------------------------------------------------------------- to io::InsRecord

/// A NovAtel INS record with what the INS says of itself.
struct NovatelRecord {
  io::InsRecord record;
  bool ins_status_good = false;  ///< INS_SOLUTION_GOOD; anything else deserves a warning
  std::string ins_status;        ///< "INS_SOLUTION_GOOD", "INS_ALIGNING", ... ("status 42" if unknown)
  std::string position_type;     ///< INSPVAX: "NARROW_INT", ...; INSPVA: "" (the log has none)
};

/// Position types (NovAtel OEM7 PositionOrVelocityType), by value or name, to a solution class:
/// NARROW_INT, L1_INT, WIDE_INT, INS_RTKFIXED -> kRtkFixed; L1_FLOAT, IONOFREE_FLOAT, NARROW_FLOAT,
/// INS_RTKFLOAT, RTK_DIRECT_INS -> kRtkFloat; PSRDIFF, WAAS, INS_SBAS, INS_PSRDIFF and every PPP
/// type -> kDifferential; SINGLE, INS_PSRSP -> kSingle; PROPAGATED -> kInsOnly (no fresh GNSS);
/// NONE, DOPPLER_VELOCITY -> kInvalid; FIXEDPOS, FIXEDHEIGHT, OPERATIONAL, WARNING,
/// OUT_OF_BOUNDS and unknown values -> kUnknown (they state no accuracy class).
GnssSolution novatel_solution(std::uint32_t pos_type);
GnssSolution novatel_solution(const std::string& pos_type_name);

/// INS status (InertialSolutionStatus) to its name ("status N" for unknown values).
std::string novatel_ins_status_name(std::uint32_t ins_status);

/// t_s = header.stamp; R_world_ins = R_enu_ins_novatel(roll, pitch, azimuth) (the record's local
/// ENU). INSPVA: ellipsoidal height as given, no position type (solution kUnknown), no stddevs.
/// INSPVAX: height + undulation, solution from the position type, stddevs (east = longitude,
/// north = latitude, up = height). An INS status that is not navigating (INACTIVE, ALIGNING,
/// DETERMINING_ORIENTATION, WAITING_*, INITIALIZING_BIASES, MOTION_DETECT) makes the solution
/// kInvalid; INS_SOLUTION_FREE (no GNSS updates accepted) makes it kInsOnly; HIGH_VARIANCE and
/// ALIGNMENT_COMPLETE keep the position class but are not "good".
NovatelRecord to_ins_record(const Oem7Inspva& msg);
NovatelRecord to_ins_record(const Oem7Inspvax& msg);
NovatelRecord to_ins_record(const NovatelGpsInspva& msg);
NovatelRecord to_ins_record(const NovatelGpsInspvax& msg);

/// Geodetic record (orientation identity: it comes from an Imu). status NO_FIX -> kInvalid, FIX ->
/// kSingle, SBAS_FIX -> kDifferential, GBAS_FIX -> kDifferential (drivers publish RTK fixed and
/// float alike as GBAS, so it cannot say more); stddevs = sqrt of the covariance diagonal unless
/// its type is UNKNOWN.
io::InsRecord to_ins_record(const NavSatFix& msg);

/// Cartesian records in header.frame_id: the pose of the child frame (Odometry) or of the pose's
/// frame. Stddevs from the covariance diagonal (x, y, z); a zero or negative variance counts as
/// not stated (NaN). A quaternion that is not a unit quaternion (norm off by more than 1%) throws
/// InputError(where, "", ...).
io::InsRecord to_ins_record(const Odometry& msg, const std::string& where);
io::InsRecord to_ins_record(const PoseStamped& msg, const std::string& where);
io::InsRecord to_ins_record(const PoseWithCovarianceStamped& msg, const std::string& where);

/// The rotation of a quaternion message (normalised); InputError(where, "", ...) unless its norm
/// is within 1% of one.
Mat3 rotation_from(const Quaternion& q, const std::string& where);
Quaternion quaternion_from(const Mat3& R);
/// T_parent_child of a transform.
Iso3 transform_from(const TransformStamped& tf, const std::string& where);
/// Orientation of the Imu frame, or nullopt when the message has none (covariance[0] == -1, or
/// an all-zero quaternion).
std::optional<Mat3> imu_orientation(const Imu& msg, const std::string& where);

}  // namespace insalign::io::bag
