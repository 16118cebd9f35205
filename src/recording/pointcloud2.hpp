// sensor_msgs/PointCloud2 <-> Sweep: any field layout (names, offsets, INT8..FLOAT64, counts,
// padding in point_step, row_step, height > 1), with the per-point time convention of the driver
// detected from the field's name, datatype and values:
//   `timestamp` float64 absolute seconds            Hesai (HesaiLidar_General_ROS), RoboSense (rslidar_sdk)
//   `timestamp` float64 absolute NANOseconds        Livox (livox_ros_driver2): told apart by magnitude
//   `time` float32 seconds relative to header.stamp Velodyne (velodyne_pointcloud; negative when the
//                                                   stamp is the last packet, i.e. the sweep end)
//   `t` uint32 nanoseconds relative to header.stamp Ouster (ouster-ros)
//   `offset_time` uint32 ns relative to header.stamp  Livox CustomMsg converted to PointCloud2
// and, by the same value rules, a relative float64 `timestamp` in seconds or a float `t` in seconds.
// The frame time is the latest point time (CONVENTIONS.md); without a time field it is
// header.stamp and the sweep has no per-point time (the caller warns).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "core/sweep.hpp"
#include "recording/messages.hpp"

namespace insalign::io::bag {

enum class PointTimeConvention {
  kNone,                 ///< no usable per-point time: frame time = header.stamp
  kAbsoluteSeconds,      ///< float64 seconds
  kAbsoluteNanoseconds,  ///< float64 nanoseconds
  kRelativeSeconds,      ///< float seconds after header.stamp (may be negative)
  kRelativeNanoseconds,  ///< integer nanoseconds after header.stamp
};

/// A point earlier than this before the latest point of its cloud is not part of the sweep (a
/// zero or stale time on an invalid return): it is dropped and counted.
constexpr double kMaxSweepSpan_s = 1.0;

/// What decoding a cloud found, for reports and warnings.
struct PointCloudInfo {
  std::size_t points = 0;                ///< width * height
  std::size_t dropped_nonfinite = 0;     ///< x, y, z or the time NaN/Inf
  std::size_t dropped_time_outside = 0;  ///< time over kMaxSweepSpan_s before the latest point
  std::vector<std::string> fields;       ///< "x float32", "normal float32[3]", ...
  std::string time_field;                ///< the field used for per-point time, "" if none
  PointTimeConvention time_convention = PointTimeConvention::kNone;
  std::string time_description;          ///< e.g. "'t' uint32: nanoseconds after header.stamp (Ouster)"
  std::string intensity_field, ring_field;  ///< "" if none
  double header_stamp_s = 0.0;
  std::string frame_id;
};

/// The message's bytes to a sweep: p_lidar, dt_s (<= 0, relative to t_end_s), intensity (from
/// `intensity`, else `reflectivity`), ring (from `ring`, `channel` or `line`). Points with a
/// non-finite coordinate or time are dropped. Throws InputError(where, ...) for a malformed
/// message, a big-endian cloud, a layout that does not fit the data, or a cloud without x, y, z.
Sweep decode_sweep(Bytes bytes, MessageEncoding encoding, const std::string& where, PointCloudInfo* info = nullptr);
/// The same from a decoded layout and its data.
Sweep sweep_from_pointcloud2(const PointCloud2Layout& cloud, Bytes data, const std::string& where,
                             PointCloudInfo* info = nullptr);

/// Point layouts of common drivers, for writing recordings that look like theirs.
enum class DriverLayout {
  kHesai,     ///< x y z (16-byte block), intensity f32, timestamp f64 absolute s, ring u16; step 48
  kVelodyne,  ///< x y z intensity f32, ring u16, time f32 relative to the stamp = sweep end; step 22
  kOuster,    ///< x y z (16), intensity f32, t u32 ns from the stamp = sweep start, ..., ring u16; step 48
  kLivox,     ///< x y z intensity f32, tag u8, line u8, timestamp f64 absolute ns; step 26 (unaligned)
  kNoTime,    ///< x y z intensity f32; stamp = t_end_s
};

/// A cloud of `sweep` in `layout`, header.frame_id = frame_id (a sweep without per-point time
/// gets dt = 0). Throws std::invalid_argument for a sweep whose t_end_s is not finite.
PointCloud2 make_pointcloud2(const Sweep& sweep, DriverLayout layout, const std::string& frame_id);

}  // namespace insalign::io::bag
