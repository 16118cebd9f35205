// The one mapping from a CalibrationResult to what a person or a program reads: extrinsic.json
// (CONVENTIONS.md), the report's data, and the terminal summary. Units convert here, once: the
// core works in m and rad, the outputs show m and deg; "not determined" (+inf) is JSON null.
#pragma once

#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/frame_store.hpp"
#include "core/pipeline.hpp"
#include "input/dataset.hpp"
#include "report/report.hpp"

namespace insalign::io {

/// What the command knows beside the result.
struct RunInfo {
  LoadReport load;
  std::vector<std::filesystem::path> format_files;  ///< the extrinsic in other tools' formats
  double peak_memory_mb = 0.0;
};

/// The extrinsic alone in the result shape: T_ins_lidar, translation_m, rpy_deg, quaternion_wxyz.
nlohmann::json extrinsic_fields(const Iso3& T_ins_lidar);

/// Per DOF [tx ty tz roll pitch yaw] in m and rad as {"tx_m", ..., "yaw_deg"} (null: +inf), and
/// the verdicts as {"tx": bool, ...}: the shapes extrinsic.json uses (rig.json too).
nlohmann::json dof_json(const Vec6& m_rad);
nlohmann::json determined_json(const std::array<bool, 6>& determined);

nlohmann::json result_to_json(const CalibrationResult& result, const RunInfo& run);

/// The frames the report's maps are stitched from: 40 spread over the drive (the maps are drawn
/// beside the repeatability study, whose frames stay decoded meanwhile: 60 took a 4000-frame
/// drive's peak memory past 500 MB).
std::vector<std::size_t> report_frames(const FrameStore& store, const CalibrationResult& result);

/// The report's maps: `frames` (report_frames) stitched at the start's, stage 1's and the final
/// extrinsic (i = 0, 1, 2). They need no stddev: calibrate draws them beside the repeatability study.
inline constexpr std::size_t kReportMaps = 3;
MapSnapshot report_map(const CalibrationResult& result, const FrameStore& store, const std::vector<std::size_t>& frames,
                       std::size_t i);
/// The report's pictures (draw_report_images of report_map) and, drawn beside them, the 3D view
/// of the same frames at the start's and the final extrinsic (no view when viewer.max_points is 0).
ReportImages report_images(const CalibrationResult& result, const FrameStore& store, const ViewerConfig& viewer);
/// The 3D view's scene alone (sections not set): start and final extrinsic, moving points and
/// left-out INS stretches marked.
ViewerScene report_viewer_scene(const CalibrationResult& result, const FrameStore& store,
                                const std::vector<std::size_t>& frames, const ViewerConfig& viewer);
/// All of them, start first.
std::vector<MapSnapshot> report_maps(const CalibrationResult& result, const FrameStore& store);

/// The report's tables from the result, without maps (report_maps). Warning limits come from `config`.
ReportData report_data(const CalibrationResult& result, const FrameStore& store, const RunInfo& run,
                       const PipelineConfig& config);

/// The terminal summary: the extrinsic with its verdicts, the stages' costs and times, warnings.
std::string summary_text(const CalibrationResult& result, const RunInfo& run);

}  // namespace insalign::io
