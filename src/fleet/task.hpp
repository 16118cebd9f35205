// One fleet task: runs one manifest row's command (`insalign check` or `calibrate`) as a
// subprocess of this same binary into a temporary folder, renames it into place when the command
// reached its verdict, then writes the row's status record. What every engine's task runs.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "fleet/manifest.hpp"
#include "fleet/status.hpp"

namespace insalign::fleet {

struct TaskOptions {
  bool force = false;           ///< run the row even when it is done
  std::filesystem::path exe;    ///< the insalign binary; empty: this one (/proc/self/exe)
};

struct TaskOutcome {
  bool skipped = false;       ///< the row was done already (or another task holds it)
  std::string skip_reason;
  TaskStatus status;          ///< the status written (or the one found when skipped)
};

/// The row's command line: insalign KIND INPUT... [--extrinsic FILE] OPTIONS... --out OUT_DIR
/// (relative paths stay relative: the command runs in the manifest's folder).
std::vector<std::string> row_command(const Manifest& m, const ManifestRow& row, const std::filesystem::path& exe,
                                     const std::filesystem::path& out_dir);

/// Runs row `index`. Never throws for a failing command or a bad recording: those end in the
/// status (exit code and error). A SIGTERM/SIGINT/SIGHUP stops the command, removes the temporary
/// folder and records the signal as the row's exit code (128 + N).
TaskOutcome run_task(const Manifest& m, std::size_t index, const std::filesystem::path& results, const TaskOptions& options);

/// The index a batch engine gives this task: SLURM_ARRAY_TASK_ID or JOB_COMPLETION_INDEX; -1 if neither.
long index_from_environment();

}  // namespace insalign::fleet
