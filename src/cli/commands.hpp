// Each subcommand lives in its own cmd_*.cpp and registers here.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <vector>

namespace insalign::cli {

// Exit codes, CONVENTIONS.md.
constexpr int kExitOk = 0;
constexpr int kExitOther = 1;
constexpr int kExitUsage = 2;         ///< bad usage or bad input
constexpr int kExitUnobservable = 3;  ///< the data cannot determine the extrinsic (check: inconclusive)
constexpr int kExitRecalibrate = 4;  ///< check: the installed extrinsic needs recalibration

struct Command {
  std::function<CLI::App*(CLI::App&)> setup;  ///< adds the subcommand and its options
  std::function<int()> run;                   ///< runs it; returns the exit code
};

/// Runs a command, turning library exceptions into messages and exit codes.
int run_guarded(const std::function<int()>& run);

std::vector<Command> all_commands();

// One factory per subcommand (cmd_<name>.cpp).
Command make_info_command();
Command make_calibrate_command();
Command make_check_command();
Command make_simulate_command();
Command make_evaluate_command();
Command make_stitch_command();
Command make_config_command();
Command make_fleet_command();

}  // namespace insalign::cli
