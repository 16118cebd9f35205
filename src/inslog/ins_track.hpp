// What every INS source (bag messages, NovAtel logs, SBET, text exports, KITTI oxts, pose files)
// is read into before it becomes the Dataset's PoseStream: records in the source's own frame and
// time base, with what the source says about its own quality, and the facts a person needs to
// trust the reading (format, time base, body frame, height datum). The one conversion to the
// calibration's world (local ENU for geodetic sources) is to_world() below.
#pragma once

#include <cmath>
#include <cstddef>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "core/dataset.hpp"
#include "core/geometry.hpp"
#include "core/geodesy.hpp"

namespace insalign::io {

struct InsRecord {
  double t_s = std::numeric_limits<double>::quiet_NaN();  ///< INS clock, UNIX seconds
  /// Geodetic tracks: WGS-84 latitude, longitude (deg) and ELLIPSOIDAL height (m).
  double lat_deg = 0.0, lon_deg = 0.0, height_m = 0.0;
  /// Cartesian tracks: position of the ins origin in the track's world frame (m).
  Vec3 p_world_m = Vec3::Zero();
  /// Orientation of the ins frame: in the track's world frame (cartesian tracks), or in the local
  /// ENU frame at this record's own position (geodetic tracks; to_world rotates it to the ENU
  /// frame at the origin, which differs by the meridian convergence: 0.005 deg per 500 m).
  Mat3 R_world_ins = Mat3::Identity();
  GnssSolution solution = GnssSolution::kUnknown;
  /// One-sigma position error the source states, east/north/up (geodetic) or world x/y/z; NaN
  /// when it states none.
  Vec3 position_stddev_m = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  /// Where the record was read from ("line 12", "byte 4096", "message 3"), for messages.
  std::string location;
};

struct InsTrack {
  std::string source;        ///< the file or topic read
  std::string format;        ///< "NovAtel OEM7 ASCII (#INSPVAXA)", "nav_msgs/Odometry", ...
  std::string time_base;     ///< "GPS week + seconds, converted to UNIX (18 leap seconds)", ...
  std::string body_frame;    ///< "NovAtel SPAN vehicle frame (x right, y forward, z up)", ...
  std::string height_datum;  ///< "WGS-84 ellipsoid", "mean sea level + undulation -> ellipsoid", ...
  std::string world_frame;   ///< "local ENU at the first fix", "map", ...
  bool geodetic = false;     ///< positions in lat_deg / lon_deg / height_m
  std::vector<InsRecord> records;  ///< strictly increasing t_s
  std::size_t records_skipped = 0; ///< e.g. bad CRC, explained in warnings
  std::vector<std::string> warnings;
};

/// The track in the calibration's world: geodetic tracks in the local ENU frame tangent at
/// `origin` (the first record's position when not given), cartesian tracks as they are.
struct WorldTrack {
  std::vector<StampedPose> poses;        ///< T_world_ins, time order
  std::vector<InsQuality> quality;       ///< one per pose
  std::optional<LocalEnu> enu;           ///< geodetic tracks: the frame, for geodetic fiducials
};
WorldTrack to_world(const InsTrack& track, const std::optional<GeodeticPoint>& origin = std::nullopt);

}  // namespace insalign::io
