// Any --poses input read into one shape: the poses, what the source says of its own quality, and
// the facts a person needs to trust the reading (format, time base, which frame `ins` is, height
// datum). OpenCalib and TUM pose files go through files/poses.hpp; everything else detected by
// inslog/ins_log.hpp (NovAtel ASCII, SBET, text exports, KITTI oxts) is placed in the local ENU
// frame at its first fix (to_world), whose LocalEnu comes along for geodetic fiducials.
#pragma once

#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/dataset.hpp"
#include "core/geodesy.hpp"
#include "inslog/ins_track.hpp"

namespace insalign::io {

struct PoseSourceOptions {
  /// The LiDAR's first frame time (UNIX s): dates SBET and gps-sow exports, which have no week.
  std::optional<double> lidar_time_hint_unix_s;
  std::string columns_spec;                       ///< text exports: the column mapping
  std::string columns_source = "--poses-columns"; ///< where the mapping came from, for errors
};

/// What was read, for `insalign info`, extrinsic.json ("input") and the report.
struct PoseSourceFacts {
  std::string path;
  std::string kind;          ///< short: "opencalib", "tum", "novatel", "sbet", "csv", "kitti", "bag"
  std::string format;        ///< "NovAtel OEM7 ASCII #INSPVAXA", "TUM (t x y z qx qy qz qw)", ...
  std::string time_base, body_frame, height_datum, world_frame;
  std::string columns;       ///< text exports: the mapping used
  std::size_t records = 0, records_skipped = 0;
  double t_begin_s = 0.0, t_end_s = 0.0, rate_hz = 0.0;  ///< as the source stamps them
  std::vector<std::pair<std::string, double>> solution_fractions;  ///< "RTK fixed" 0.97, ... (stated only)
  std::optional<GeodeticPoint> enu_origin;  ///< geodetic sources: the local ENU frame's origin
  std::vector<std::string> warnings;
};

struct SourcePose {
  double t_s = 0.0;        ///< NaN: an OpenCalib frame name that is not a time
  std::string frame_name;  ///< OpenCalib only
  std::string location;    ///< "line 12", "byte 4096", for messages
  Iso3 T_world_ins = Iso3::Identity();
};

struct PoseSource {
  bool per_frame = false;          ///< OpenCalib: poses belong to frames by name
  std::vector<SourcePose> poses;   ///< file order
  std::vector<InsQuality> quality; ///< one per pose when the source states any, else empty
  std::optional<LocalEnu> enu;     ///< geodetic sources: the world frame
  PoseSourceFacts facts;
};

/// Reads `path` (a file, or a KITTI drive / oxts folder), detected from its content. Throws
/// InputError(file, "line N" / "byte N", what).
PoseSource read_pose_source(const std::filesystem::path& path, const PoseSourceOptions& options = {});

/// An InsTrack already read (KITTI raw's oxts, tests) in the same shape; kind as in the facts.
PoseSource pose_source_of(const InsTrack& track, const std::string& kind);

/// "RTK fixed", "RTK float", "differential", "single point", "INS only", "invalid", "not stated".
const char* gnss_solution_name(GnssSolution solution);
/// The fraction of each stated solution; empty when the source states none.
std::vector<std::pair<std::string, double>> solution_fractions(const std::vector<InsQuality>& quality);

}  // namespace insalign::io
