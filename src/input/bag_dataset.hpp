// A recording (ROS 1 bag, MCAP, rosbag2) as what the calibration consumes: one Dataset per LiDAR
// topic, all on the same INS trajectory, and a report of every decision a person must see.
//
// Opening reads the container's index, every INS message (small), the first bytes of every cloud
// (header.stamp only: BagReader::read_prefix) and fully decodes a few clouds per topic (first,
// quartiles, last) to learn the per-point time convention and the offset from header.stamp to the
// sweep end. Frame time = header.stamp + that offset (CONVENTIONS: the latest point time); the
// sweeps themselves are decoded by FrameSource::load(i), lazily and thread-safely, and carry
// their exact latest point time. Nothing else is kept: memory is the index plus what is loaded.
//
// Clocks: the recorder received both sensors' messages on one clock, so header.stamp - record
// time, compared between the LiDAR and the INS, tells a clock difference from a late start. When
// the two differ by more than 2 s the clocks disagree: ClockGapError (an InputError) says by how
// much, whether that is a known whole-second offset (GPS-UTC 18 s, TAI-UTC 37 s, TAI-GPS 19 s,
// time zones), and both ranges. Record times copied from the stamps (converted data sets) cannot
// tell: then fewer than half the frames inside the INS range, or both ends of the ranges shifted
// alike by more than 2 s, is the error. LiDAR frames outside the INS range are skipped with a
// warning; none inside is an InputError.
#pragma once

#include <cstddef>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/dataset.hpp"
#include "core/errors.hpp"
#include "recording/bag_reader.hpp"
#include "recording/pointcloud2.hpp"
#include "recording/bag_frames.hpp"
#include "recording/bag_ins.hpp"
#include "input/dataset.hpp"
#include "core/geodesy.hpp"

namespace insalign::io {

struct BagOptions {
  std::filesystem::path path;                 ///< .bag, .mcap, .db3 or a rosbag2 folder
  std::vector<std::string> lidar_topics;      ///< --lidar-topic (repeatable); empty: automatic
  std::optional<std::string> ins_topic;       ///< --ins-topic; "FIX,IMU" for a NavSatFix + Imu pair
  std::string world_frame, ins_frame;         ///< --world-frame, --ins-frame (TF sources)
  std::optional<std::filesystem::path> init;       ///< --init (OpenCalib JSON), given to every LiDAR
  std::optional<std::filesystem::path> fiducials;  ///< --fiducials ("# wgs84" first line: geodetic)
  double ins_time_shift_s = 0.0;              ///< added to every INS stamp (a clock offset already known)
  bool read_cut_off = false;                  ///< input.read_cut_off (bag::OpenOptions)
};

/// What is known of a whole-second clock difference.
struct ClockGapExplanation {
  double gap_s = 0.0;           ///< the measured difference
  double whole_s = 0.0;         ///< the known offset it is close to
  std::string meaning;          ///< "GPS - UTC (18 leap seconds): one clock is GPS time, the other UTC"
};

/// A known offset within tolerance_s of gap_s (either sign), or nullopt: GPS-UTC 18 s, TAI-UTC
/// 37 s, TAI-GPS 19 s, whole quarter hours up to 14 h (time zones; also +-18 s on top), the GPS
/// epoch (315964800 s, +-18 s).
std::optional<ClockGapExplanation> explain_clock_gap(double gap_s, double tolerance_s = 0.05);

struct ClockReport {
  double lidar_begin_s = 0.0, lidar_end_s = 0.0;  ///< frame times of all LiDAR topics (LiDAR clock)
  double ins_begin_s = 0.0, ins_end_s = 0.0;      ///< INS records (INS clock)
  /// INS stamp minus LiDAR frame time at the same record time (median over the messages): ~0 when
  /// the clocks agree; NaN when the container has no usable record times.
  double stamp_gap_s = std::numeric_limits<double>::quiet_NaN();
  double frames_inside_fraction = 0.0;            ///< LiDAR frames inside the INS range
  std::optional<ClockGapExplanation> explanation; ///< of stamp_gap_s (or of the range offset)
  bool consistent = true;                         ///< false: load_bag threw ClockGapError
  std::string summary;                            ///< one line for people
};

/// Thrown when the LiDAR and INS clocks disagree (see the top of this file); carries the analysis.
class ClockGapError : public InputError {
 public:
  ClockGapError(const std::string& file, const std::string& problem, ClockReport clock)
      : InputError(file, "", problem), clock_(std::move(clock)) {}
  const ClockReport& clock() const { return clock_; }

 private:
  ClockReport clock_;
};

struct InsReport {
  std::string kind;                      ///< ins_source_name
  std::vector<std::string> topics, types;
  std::string ins_frame, world_frame;    ///< descriptions (InsTrack body_frame / world_frame)
  std::string ins_frame_id, world_frame_id;
  std::string height_datum, time_base;
  std::size_t messages = 0, records = 0, records_skipped = 0;
  double t_begin_s = 0.0, t_end_s = 0.0, rate_hz = 0.0;
  std::vector<std::pair<std::string, std::size_t>> status_counts;  ///< as the messages state it
  std::vector<std::pair<std::string, double>> solution_fractions;  ///< "RTK fixed" 0.98, ...
  std::optional<GeodeticPoint> enu_origin;  ///< geodetic sources: the local ENU frame's origin
  std::vector<std::string> not_used;        ///< other INS topics
  double stamp_minus_record_s = std::numeric_limits<double>::quiet_NaN();  ///< median header.stamp - record time
};

/// The INS trajectory of a recording alone (info --bag on a bag without LiDAR, stitch).
struct BagTrajectory {
  PoseStream poses;                      ///< T_world_ins, recentred on the first position
  Vec3 world_origin_m = Vec3::Zero();    ///< subtracted from the positions (as Dataset)
  std::vector<InsQuality> ins_quality;   ///< empty when the source states nothing
  std::optional<LocalEnu> enu;           ///< geodetic sources: the world frame
  InsReport report;
  std::vector<std::string> warnings;     ///< container, then INS
};

struct BagReport {
  std::string path, container;       ///< container: BagReader::describe()
  std::vector<LidarTopicReport> lidars;
  InsReport ins;
  ClockReport clock;
  std::vector<std::string> warnings;  ///< container, definitions, INS, LiDAR, in that order
};

struct BagDatasets {
  std::vector<std::string> lidar_names;  ///< CONVENTIONS "Rigs": topic without '/', '/' -> '_'
  std::vector<Dataset> lidars;           ///< one per LiDAR topic, same poses, quality, fiducials
  BagReport report;
  std::optional<LocalEnu> enu;           ///< geodetic INS sources: the world frame
  std::shared_ptr<BagCounters> counters = std::make_shared<BagCounters>();
};

/// Opens options.path and builds the datasets. Throws InputError(path, location, what) for a bad
/// container, an ambiguous or missing topic, undecodable messages, and ClockGapError.
BagDatasets load_bag(const BagOptions& options);
/// The same over a reader already open (tests wrap readers; `options.path` is unused).
BagDatasets load_bag(std::shared_ptr<const bag::BagReader> reader, const BagOptions& options);

/// Only the INS source (no LiDAR topic needed): lidar_topics, init and fiducials are unused.
BagTrajectory load_bag_trajectory(const BagOptions& options);
BagTrajectory load_bag_trajectory(std::shared_ptr<const bag::BagReader> reader, const BagOptions& options);

/// The existing load report of one LiDAR (frames, time field, frame time source, pose format).
LoadReport to_load_report(const BagReport& report, std::size_t lidar = 0);

/// What `insalign info --bag` prints: container, LiDAR topics, INS source, clocks, warnings.
std::string describe_bag(const BagReport& report);
/// Every topic of a recording with its type, count and what insalign does with it; the
/// container, its record time range and warnings (works on any bag).
std::string describe_recording(const bag::BagReader& reader);
/// The INS source and its first and last poses (in the source's world, not recentred).
std::string describe_trajectory(const BagTrajectory& trajectory);

/// Fiducials for a dataset: "id x y z" in the world frame, or after a "# wgs84" first line
/// "id lat_deg lon_deg ellipsoidal_height_m" placed in `enu` (InputError without one: the INS
/// source is not geodetic). Recentred by world_origin_m like the poses.
std::vector<Fiducial> read_bag_fiducials(const std::filesystem::path& path, const std::optional<LocalEnu>& enu,
                                         const Vec3& world_origin_m);

/// Whether a fiducial file starts with the "# wgs84" line.
bool is_geodetic_fiducial_file(const std::filesystem::path& path);

}  // namespace insalign::io
