// Child processes: the fleet runs this same insalign binary as subprocesses, and the batch
// engines' command line clients (sbatch, squeue, scontrol, sacct).
#pragma once

#include <sys/types.h>

#include <filesystem>
#include <string>
#include <vector>

namespace insalign::fleet {

struct ProcessSpec {
  std::vector<std::string> argv;      ///< argv[0] is the program (a path, or a name looked up in PATH)
  std::filesystem::path cwd;          ///< empty: this process's folder
  std::filesystem::path output_file;  ///< stdout and stderr appended here; empty: inherited
  bool die_with_parent = false;       ///< SIGKILL the child when this process dies (a killed task leaves no orphan)
};

/// Starts the process; throws std::runtime_error when it cannot.
pid_t spawn(const ProcessSpec& spec);

/// Waits for the child; its exit code, or 128 + N when signal N ended it (as a shell reports it).
/// Retries when a signal interrupts the wait.
int wait_exit_code(pid_t pid);

struct Captured {
  int exit_code = -1;  ///< 127 when the program could not be started
  std::string output;  ///< stdout and stderr
};
/// Runs a program to its end and returns what it printed.
Captured run_captured(const std::vector<std::string>& argv);

/// The path of the running insalign binary (/proc/self/exe), so tasks run the same build.
std::filesystem::path self_exe();

std::string host_name();

}  // namespace insalign::fleet
