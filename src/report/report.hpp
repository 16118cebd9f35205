// report.html: what a calibration engineer reads to trust or reject a result before putting it
// on a car. Plain data in (filled by the calibrate command), one self-contained page out: tables,
// inline SVG plots and PNG images of the stitched map in OUT/report/, no external references.
#pragma once

#include <array>
#include <filesystem>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/geometry.hpp"
#include "report/render.hpp"
#include "report/viewer.hpp"

namespace insalign::io {

/// The stitched map at one extrinsic (world frame), e.g. "initial", "rough", "refined", "final".
struct MapSnapshot {
  std::string label;
  std::vector<Vec3f> p_world;
  std::vector<Vec3f> p_moving_world;  ///< points on moving things, left out by the stages (drawn apart)
};

/// One row of the per-stage table.
struct StageRow {
  std::string stage;                 ///< "initial", "stage 1: rough", ...
  Iso3 T_ins_lidar = Iso3::Identity();
  double time_offset_s = 0.0;
  std::string metric_name;           ///< crispness measure and unit, e.g. "plane RMS (m)"
  double metric_before = std::numeric_limits<double>::quiet_NaN();
  double metric_after = std::numeric_limits<double>::quiet_NaN();
  double wall_time_s = std::numeric_limits<double>::quiet_NaN();
  std::string note;
};

/// The estimate after one optimiser round (for the convergence plots).
struct ConvergencePoint {
  std::string stage;
  int round = 0;
  Iso3 T_ins_lidar = Iso3::Identity();
  double cost = std::numeric_limits<double>::quiet_NaN();
};

struct FiducialRow {
  std::string id;
  double residual_before_m = std::numeric_limits<double>::quiet_NaN();  ///< map minus survey, vertical
  double residual_after_m = std::numeric_limits<double>::quiet_NaN();
  bool used = false;
  std::string reason;  ///< why not used
};

/// The verdict per degree of freedom, in the order tx ty tz roll pitch yaw.
struct ObservabilityReport {
  std::array<bool, 6> determined{};
  Vec6 stddev = Vec6::Constant(std::numeric_limits<double>::infinity());  ///< m and rad; +inf: not determined
  std::string explanation;
};

/// One disjoint segment of the drive calibrated on its own.
struct SegmentRow {
  std::string label;  ///< e.g. "0-60 s"
  bool ok = false;
  std::string message;
  Iso3 T_ins_lidar = Iso3::Identity();
  double time_offset_s = 0.0;
};

struct RepeatabilityReport {
  std::vector<SegmentRow> segments;
  Vec6 spread = Vec6::Zero();  ///< max - min over the segments that succeeded: m and rad
  Vec6 warn_above = Vec6::Zero();  ///< a spread above this is flagged (from the config), m and rad
};

/// The INS position correction estimated with the extrinsic (core/trajectory_correction).
struct TrajectoryCorrectionReport {
  bool applied = false;
  std::string decision;            ///< why it was (not) applied
  std::vector<double> t_s;         ///< knot times, seconds after the first frame
  std::vector<Vec3> position_m;    ///< world frame: corrected = reported + this
};

struct ReportData {
  std::string title = "insalign calibration report";
  std::vector<std::pair<std::string, std::string>> input_summary;  ///< (what, value): frames, distance, ...
  Iso3 T_ins_lidar = Iso3::Identity();  ///< the final result
  std::string parent_frame = "ins", child_frame = "lidar";
  std::vector<StageRow> stages;          ///< in order; the first is usually the initial guess
  std::vector<ConvergencePoint> convergence;
  std::vector<MapSnapshot> maps;         ///< in order; the last is the final map (sections are picked on it)
  std::vector<FiducialRow> fiducials;
  std::string fiducial_summary;          ///< e.g. "tz from 5 of 6 fiducials, stddev 2 mm"
  std::optional<double> time_offset_s;   ///< estimated LiDAR-to-INS offset (t_ins = t_lidar + offset)
  std::optional<double> time_offset_stddev_s;
  std::string time_offset_note;
  std::optional<ObservabilityReport> observability;
  std::optional<RepeatabilityReport> repeatability;
  std::optional<TrajectoryCorrectionReport> trajectory_correction;
  std::vector<std::string> warnings;
  /// What the stages left out: INS spans (when, who found them, why) and moving points.
  std::vector<std::string> left_out;
  std::vector<std::pair<std::string, std::string>> output_files;  ///< (file name relative to the report, what)
  std::string command_line;
};

/// What write_report produced, for tests and the terminal summary.
struct ReportFiles {
  std::filesystem::path html;
  std::vector<std::filesystem::path> images;
  /// Per map snapshot: robust thickness (m) of the wall and ground cross-sections (NaN if none).
  std::vector<std::pair<double, double>> section_thickness_m;
};

/// One map snapshot's pictures: (file relative to the report, caption) per view, and the sections.
struct SnapshotImages {
  std::string label;
  std::vector<std::pair<std::string, std::string>> views;
  std::string wall_file, ground_file;
  SectionStats wall, ground;
};

/// The report's pictures drawn and PNG-encoded in memory, nothing written: the costly part of a
/// report, which needs only the maps (calibrate draws them beside the repeatability study).
struct ReportImages {
  std::vector<SnapshotImages> snaps;  ///< per map, in map order
  std::optional<Section> wall, ground;  ///< picked on the final map
  std::vector<std::pair<std::string, std::string>> png_files;  ///< (file relative to the report, PNG bytes)
  ViewerOutput viewer;  ///< the 3D view (report/viewer*.js); empty html: none
};
/// The sections picked on the final map, as the viewer marks them.
std::vector<Section> report_sections(const ReportImages& images);
ReportImages draw_report_images(const std::vector<MapSnapshot>& maps);
/// The same, with map i (the final map last) stitched by `map(i)` only when it is drawn and freed
/// after: one map's points held at a time, not all of them.
ReportImages draw_report_images(std::size_t maps, const std::function<MapSnapshot(std::size_t)>& map);

/// Writes out_dir/report.html and out_dir/report/*.png, every file atomically; the HTML last,
/// so a report that exists is complete. Throws InputError if out_dir cannot be written.
ReportFiles write_report(const std::filesystem::path& out_dir, const ReportData& data);
/// The same with the pictures already drawn (data.maps is not read).
ReportFiles write_report(const std::filesystem::path& out_dir, const ReportData& data, const ReportImages& images);

}  // namespace insalign::io
