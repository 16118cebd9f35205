// The Slurm engine: an sbatch array script (one array index per row) submitted with sbatch, and
// following the job to its end with squeue/scontrol (or sacct where the cluster keeps accounting).
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "fleet/manifest.hpp"

namespace insalign::fleet {

/// Defaults sized for insalign's measured cost (bench/results/fleet.md): about 1 s of one core
/// and 1 MB of memory per MB of recording, with a wide margin.
struct SlurmConfig {
  std::size_t jobs = 2;                 ///< --jobs: the array's % limit (tasks running at once)
  bool force = false;                   ///< --force: rerun done rows
  std::string partition;                ///< --partition; empty: the cluster's default
  std::vector<std::string> sbatch_options;  ///< --sbatch-option, each one more #SBATCH line
  int cpus_per_task = 2;                ///< a task's threads (the calibration is parallel)
  double base_minutes = 10.0;           ///< time limit per task: base + minutes_per_gb * largest recording
  double minutes_per_gb = 30.0;
  double base_memory_mb = 1024.0;       ///< memory per task: base + memory_mb_per_gb * largest recording
  double memory_mb_per_gb = 1024.0;
  double poll_s = 2.0;                  ///< --wait: seconds between squeue polls
  std::filesystem::path exe;            ///< the insalign binary (on a shared file system); empty: this one
};

/// Bytes of the files and folders the row's input names (relative to the manifest's folder).
std::uintmax_t recording_bytes(const Manifest& m, const ManifestRow& row);

/// "0,2,5-9%2": the array specification for these row indices and concurrency limit.
std::string array_spec(const std::vector<std::size_t>& indices, std::size_t limit);

/// The sbatch script for these rows: an array job running `insalign fleet task` per index.
std::string slurm_script(const Manifest& m, const std::filesystem::path& results, const std::vector<std::size_t>& indices,
                         const SlurmConfig& config);

/// Writes DIR/slurm/fleet.sbatch and submits it; the job id, or empty when nothing is left to run.
/// Throws std::runtime_error with sbatch's message when the submission fails.
std::string submit_slurm(const Manifest& m, const std::filesystem::path& results, const SlurmConfig& config);

/// What in this cluster's configuration (`scontrol show config`'s text) makes every array task
/// wait for slurmctld's periodic passes, one sentence each with the slurm.conf line that avoids it;
/// empty when nothing does. Without an Epilog a freed slot waits for the next one-second pass
/// (0.8-0.9 s per task measured, 0.15 s with one: bench/results/fleet.md).
std::vector<std::string> slurm_latency_hints(const std::string& show_config);

/// The same for the cluster `scontrol` reaches; empty when scontrol fails.
std::vector<std::string> slurm_latency_hints();

/// Follows the job until none of its tasks is pending or running, printing each row's state as
/// it changes; returns the final Slurm state per row index (COMPLETED, FAILED, CANCELLED, ...).
std::map<std::size_t, std::string> wait_slurm(const Manifest& m, const std::string& job_id, const SlurmConfig& config);

}  // namespace insalign::fleet
