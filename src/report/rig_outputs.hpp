// A rig's outputs (CONVENTIONS.md "Rigs"): OUT/<name>/ with each LiDAR's usual files, OUT/rig.json,
// OUT/rig.urdf (every LiDAR as a fixed joint off the INS link) and OUT/report.html over every LiDAR.
// Each LiDAR's result is a CalibrationResult, so its own files come from result_outputs.hpp.
#pragma once

#include <array>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/rig.hpp"
#include "report/report.hpp"
#include "report/result_outputs.hpp"

namespace insalign::io {

inline constexpr const char* kRigJsonFile = "rig.json";
inline constexpr const char* kRigUrdfFile = "rig.urdf";

/// rig.json: {"lidars": {name: {T_ins_lidar, time_offset_s, stddev, determined, joint_with, note}},
/// "T_lidar_lidar": {"a__b": T_a_b}, "T_lidar_lidar_stddev": {"a__b": {...}}, "overlap": {...}}.
nlohmann::json rig_to_json(const RigResult& rig);

/// rig.json read back (the keys CONVENTIONS names). stddev in m and rad (+inf: null).
struct RigFileLidar {
  std::string name;
  Iso3 T_ins_lidar = Iso3::Identity();
  double time_offset_s = 0.0;
  Vec6 stddev = Vec6::Constant(std::numeric_limits<double>::infinity());
  std::array<bool, 6> determined{};
};
struct RigFilePair {
  std::string a, b;
  Iso3 T_a_b = Iso3::Identity();
};
struct RigFile {
  std::vector<RigFileLidar> lidars;  ///< in the file's key order
  std::vector<RigFilePair> pairs;
};
/// Throws InputError naming the file and the key when a field is missing or malformed.
RigFile parse_rig_json(std::string_view text, const std::string& file_for_errors);

/// A URDF with link "ins" and one fixed joint "ins_to_<name>" per LiDAR (T_ins_<name>).
std::string format_rig_urdf(const RigResult& rig);

struct RigOutputOptions {
  bool report = true;
  std::string command_line;
  ViewerConfig viewer;  ///< the rig's 3D view holds viewer.max_points / 2, each LiDAR's own the rest
};

/// A LiDAR's report pictures and the maps the rig's report reuses.
struct LidarReportDrawing {
  std::vector<MapSnapshot> maps;  ///< the first (start) and the last (final) map
  ReportImages images;
  ViewerScene scene;  ///< its 3D view's points, merged into the rig's
};
/// Needs only the final extrinsic: calibrate draws it beside the repeatability study (RigBeside).
/// `lidars`: the rig's LiDAR count; each LiDAR's view gets viewer.max_points / (2 * lidars).
LidarReportDrawing draw_lidar_report(const CalibrationResult& r, const FrameStore& store, const ViewerConfig& viewer = {},
                                     std::size_t lidars = 1);

/// Writes everything into out_dir (each file atomically; rig.json last: its presence means the
/// whole result is there); returns the files written at the top level. drawn[l]: LiDAR l's
/// report already drawn (missing or empty: drawn here).
std::vector<std::filesystem::path> write_rig_outputs(const std::filesystem::path& out_dir, const RigResult& rig,
                                                     const std::vector<FrameStore>& stores,
                                                     const std::vector<RunInfo>& runs, const PipelineConfig& config,
                                                     const RigOutputOptions& options,
                                                     const std::function<void(double)>& progress = {},
                                                     std::vector<std::optional<LidarReportDrawing>> drawn = {});

/// What a LiDAR's steps after stage 1 left out, in one line (empty: nothing was screened); its
/// own report and extrinsic.json list every span and why.
std::string left_out_line(const RigLidar& lidar);

/// The terminal summary: per LiDAR its extrinsic, stddevs, verdicts and how it was refined; the
/// LiDAR-to-LiDAR transforms.
std::string rig_summary_text(const RigResult& rig, double peak_memory_mb);

/// report.html over every LiDAR (report_rig.cpp): a section per LiDAR (linking its own report),
/// the combined map coloured by LiDAR before and after, the overlap regions' cross-sections.
struct RigReportMaps {
  std::string label;                           ///< "start", "final"
  std::vector<std::vector<Vec3f>> p_world;     ///< per LiDAR
  std::vector<Vec3f> p_moving_world;           ///< every LiDAR's points on moving things (left out): magenta
};
/// scene: the combined 3D view (merge_scenes of the LiDARs'), nullptr or empty: none.
std::filesystem::path write_rig_report(const std::filesystem::path& out_dir, const RigResult& rig,
                                       const std::vector<RigReportMaps>& maps, const std::string& command_line,
                                       const ViewerScene* scene = nullptr);

}  // namespace insalign::io
