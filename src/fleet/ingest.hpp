// `fleet ingest`: every row's status and outputs under a results folder into the history database.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "fleet/database.hpp"
#include "fleet/status.hpp"

namespace insalign::fleet {

struct IngestSummary {
  int inserted = 0, replaced = 0, unchanged = 0;
  std::vector<std::string> unreadable;  ///< status files that are not status records, with the reason
};

/// The run a status describes: its verdict from the exit code and the row's check.json.
RunRecord run_from_status(const TaskStatus& status, const std::filesystem::path& results);

/// The extrinsics of a done row: a calibration's extrinsic.json or rig.json, a check's check.json.
/// Throws InputError naming the file when an output is there but unreadable.
std::vector<ExtrinsicRecord> extrinsics_from_outputs(const TaskStatus& status, const std::filesystem::path& results);

/// The status files under DIR (DIR/<car>/<date>-<kind>.status.json), sorted.
std::vector<std::filesystem::path> find_status_files(const std::filesystem::path& results);

/// Migrates the schema, then stores every row in one exclusive transaction. Idempotent: the same
/// results again change nothing; safe with concurrent ingests (they serialize).
IngestSummary ingest_results(const std::filesystem::path& results, SqlConnection& db);

}  // namespace insalign::fleet
