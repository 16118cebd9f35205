// Which rows a run still has to do, and what became of each row (from the status records).
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "fleet/manifest.hpp"

namespace insalign::fleet {

/// Indices of the rows that are not done (every row with `force`).
std::vector<std::size_t> rows_to_run(const Manifest& m, const std::filesystem::path& results, bool force);

struct RowReport {
  std::string id;
  std::string state;   ///< "done", "failed", "not run", or the engine's state (e.g. Slurm's CANCELLED)
  int exit_code = -1;  ///< -1 without a status
  int attempts = 0;
  std::string error;
};

/// One report per row; `engine_states` (by row index) names what the engine says of rows
/// that have no status record (a task cancelled before it started, a pending task).
std::vector<RowReport> row_reports(const Manifest& m, const std::filesystem::path& results,
                                   const std::map<std::size_t, std::string>& engine_states = {});

/// "12 rows: 10 done, 1 failed, 1 CANCELLED" and one line per row that is not done.
std::string summarize(const std::vector<RowReport>& reports);

bool all_done(const std::vector<RowReport>& reports);

}  // namespace insalign::fleet
