// A row's status record (CONVENTIONS.md "Fleets"): DIR/<car>/<date>-<kind>.status.json, written
// last and atomically by the task. A row is done when its status exists with exit code 0, 3 or 4.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include "fleet/manifest.hpp"

namespace insalign::fleet {

struct TaskStatus {
  std::string id;
  int exit_code = -1;  ///< the command's exit code; 128 + N when a signal N ended it
  std::string error;   ///< why the row failed (empty when done)
  int attempts = 0;    ///< how many times a task started this row
  std::string host;
  std::string started;  ///< ISO 8601 UTC with milliseconds
  std::string ended;
  ManifestRow row;  ///< the manifest row, so that ingest needs only the results folder
};

/// Exit codes that mean the command ran to its verdict: 0 result, 3 not determined, 4 recalibrate.
inline bool is_done_exit_code(int exit_code) { return exit_code == 0 || exit_code == 3 || exit_code == 4; }

/// DIR/<car>/<date>-<kind>: the row's outputs.
std::filesystem::path row_dir(const std::filesystem::path& results, const ManifestRow& row);
/// DIR/<car>/<date>-<kind>.status.json
std::filesystem::path status_path(const std::filesystem::path& results, const ManifestRow& row);

std::string status_to_json(const TaskStatus& s);
/// Throws InputError naming the file when it is not a status record.
TaskStatus status_from_json(const std::string& text, const std::string& file);

/// The row's status, or nothing when there is none yet (a status that cannot be read counts as none).
std::optional<TaskStatus> read_status(const std::filesystem::path& results, const ManifestRow& row);
void write_status(const std::filesystem::path& results, const TaskStatus& s);

bool is_done(const std::filesystem::path& results, const ManifestRow& row);

/// Now as ISO 8601 UTC, milliseconds: 2026-03-01T08:30:00.123Z
std::string utc_now();

}  // namespace insalign::fleet
