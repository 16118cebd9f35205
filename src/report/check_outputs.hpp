// What `insalign check` writes (CONVENTIONS.md "Checking an installed extrinsic"): check.json,
// check.html, the history records and the corrected extrinsic in every format calibrate writes.
// Units as a person reads them: m, deg, s; a stddev the drive does not determine is JSON null.
#pragma once

#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/check_history.hpp"
#include "core/check_run.hpp"
#include "core/frame_store.hpp"
#include "report/viewer.hpp"

namespace insalign::io {

/// One LiDAR's check: the drive's own run and, with --history, the combination of the records.
struct LidarCheck {
  std::string name;                  ///< "" for a single LiDAR
  std::string source;                ///< the --extrinsic FILE
  std::string format;                ///< its format (io/installed_extrinsic.hpp)
  Iso3 T_ins_lidar_installed = Iso3::Identity();
  double time_offset_installed_s = 0.0;
  CheckRun run;
  std::optional<HistoryFindings> history;  ///< set: the verdict is the history's
  std::string drive_end;             ///< ISO 8601 UTC time of the drive's last sweep
  ViewerScene viewer;                ///< check.html's 3D view (check_viewer_scene); empty: none
  /// The verdict, per-DOF findings and message the outputs state (the history's when set).
  CheckVerdict verdict() const { return history ? history->verdict : run.findings.verdict; }
  const std::array<DofCheck, 7>& dofs() const { return history ? history->dofs : run.findings.dofs; }
  std::string message() const { return history ? history->message : run.findings.message; }
};

/// The worst of several LiDARs' verdicts: recalibrate, then inconclusive, then ok.
CheckVerdict rig_verdict(const std::vector<LidarCheck>& lidars);

/// "2023-11-14T22:13:20.100Z" for UNIX seconds, and its file-name form "20231114T221320.100Z".
std::string iso8601_utc(double unix_s);
std::string iso8601_basic(const std::string& extended);

/// check.json: one LiDAR's object (CONVENTIONS), or {"verdict", "lidars": {name: ...}} for a rig.
nlohmann::json check_to_json(const std::vector<LidarCheck>& lidars);
/// check.html: verdict first, per-DOF correction with its interval against the tolerance, then the
/// 3D view (`viewer_html`, may be empty), then the map's crispness at the installed and the
/// corrected extrinsic, the stretches used.
std::string check_html(const std::vector<LidarCheck>& lidars, const std::string& viewer_html = "");
/// check.html and its 3D view's files (OUT_DIR/report/viewer*.js; a rig's LiDARs in one view,
/// coloured by LiDAR).
void write_check_html(const std::filesystem::path& out_dir, const std::vector<LidarCheck>& lidars);

/// The 3D view of one LiDAR's check (store: the whole drive, as the check was given it): the
/// same frames placed at the installed extrinsic and at the one this drive's measurement corrects
/// it to; frames in the stretches the check used (as many as its crispness figures) and, grey,
/// some beyond them; the points the stages left out in their own colours. None when
/// config.max_points is 0.
ViewerScene check_viewer_scene(const FrameStore& store, const CheckRun& run, const Iso3& T_ins_lidar_installed,
                               double time_offset_installed_s, const ViewerConfig& config);

/// A check.json read back as history records, one per LiDAR name ("" for a single LiDAR): the
/// drive's own measurement (its "drive" object), not a combination. Throws InputError.
std::map<std::string, CheckRecord> parse_check_record(std::string_view text, const std::string& file_for_errors);
/// Every `*.check.json` in dir (none if it does not exist) but `skip_name`, by LiDAR name.
std::map<std::string, std::vector<CheckRecord>> read_history(const std::filesystem::path& dir,
                                                             const std::string& skip_name = "");

/// OUT_DIR/corrected/ (a rig: corrected/<name>/ per LiDAR and corrected/rig.json): extrinsic.json,
/// the OpenCalib JSON and every format of write_all_formats, for the corrected extrinsic.
std::vector<std::filesystem::path> write_corrected(const std::filesystem::path& out_dir,
                                                   const std::vector<LidarCheck>& lidars);

}  // namespace insalign::io
