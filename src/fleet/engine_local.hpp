// The local engine: a bounded pool of `insalign fleet task` processes on this machine.
#pragma once

#include <filesystem>
#include <vector>

#include "fleet/manifest.hpp"

namespace insalign::fleet {

struct LocalConfig {
  std::size_t jobs = 2;        ///< tasks at once (--jobs)
  bool force = false;          ///< rerun done rows (--force)
  std::filesystem::path exe;   ///< the insalign binary; empty: this one
};

/// Runs every row that is not done, at most `jobs` at a time, each as
/// `insalign fleet task MANIFEST --results DIR --index I`; returns when all have ended.
void run_local(const Manifest& m, const std::filesystem::path& results, const LocalConfig& config);

/// The task command line every engine runs (without --index for the batch engines).
std::vector<std::string> task_command(const std::filesystem::path& exe, const Manifest& m,
                                      const std::filesystem::path& results, bool force);

}  // namespace insalign::fleet
