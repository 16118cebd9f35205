// The fleet's history (CONVENTIONS.md "Fleets"): tables schema_version, runs (one per manifest
// row) and extrinsics (one per run and LiDAR), the same schema on SQLite and PostgreSQL,
// versioned and migrated in place.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "fleet/sql_connection.hpp"

namespace insalign::fleet {

/// The schema this build writes. 1: the tables of CONVENTIONS.md; 2: runs gain attempts, host
/// and report (the row's own report page).
constexpr int kSchemaVersion = 2;

/// The degrees of freedom, in the columns' order: m, m, m, deg, deg, deg, s.
inline constexpr std::array<const char*, 7> kFleetDofs{"tx", "ty", "tz", "roll", "pitch", "yaw", "time_offset"};

struct RunRecord {
  std::string id, car, date, kind, input;
  int exit_code = -1;
  std::string verdict;  ///< check: ok|recalibrate|inconclusive; calibrate: calibrated|not-determined; failed
  std::string error, started, ended;
  int attempts = 0;
  std::string host;
  std::string report;  ///< absolute path of the row's report.html or check.html; empty when none
  bool operator==(const RunRecord&) const = default;
};

struct ExtrinsicRecord {
  std::string run_id;
  std::string lidar;                      ///< "lidar" for one LiDAR; the rig's names otherwise
  std::array<double, 16> T_ins_lidar{};   ///< row-major 4x4 (checks: the corrected extrinsic)
  std::optional<double> time_offset_s;
  std::array<std::optional<double>, 7> stddev;      ///< per kFleetDofs, m / deg / s
  std::array<std::optional<bool>, 7> determined;
  std::array<std::optional<double>, 7> correction;  ///< checks: corrected - installed
  std::array<std::string, 7> dof_verdict;           ///< checks: ok|drifted|not-observable
  bool operator==(const ExtrinsicRecord&) const = default;
};

/// The version the database is at (0: empty).
int schema_version(SqlConnection& db);

/// Brings the schema up to `target` (at most kSchemaVersion), one migration at a time, in one
/// exclusive transaction; returns the version found. Throws DatabaseError for a newer database.
int migrate(SqlConnection& db, int target = kSchemaVersion);

enum class StoreOutcome { kInserted, kReplaced, kUnchanged };

/// Stores one run and its extrinsics, keyed by the run's id and `ended`: the same run again
/// changes nothing, a newer attempt replaces it. Call inside an ExclusiveTransaction.
StoreOutcome store_run(SqlConnection& db, const RunRecord& run, const std::vector<ExtrinsicRecord>& extrinsics);

/// Every run (ordered by car, date, id) and every extrinsic (by run id, LiDAR).
std::vector<RunRecord> load_runs(SqlConnection& db);
std::vector<ExtrinsicRecord> load_extrinsics(SqlConnection& db);

}  // namespace insalign::fleet
