// insalign command line: parses arguments, calls the library, maps errors to exit codes.
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include "cli/commands.hpp"

int main(int argc, char** argv) {
  CLI::App app{"insalign: LiDAR to GNSS/INS extrinsic calibration"};
  app.require_subcommand(1);
  std::vector<insalign::cli::Command> commands = insalign::cli::all_commands();
  std::vector<CLI::App*> subcommands;
  for (auto& command : commands) subcommands.push_back(command.setup(app));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);
    return rc == 0 ? 0 : insalign::cli::kExitUsage;
  }
  for (std::size_t i = 0; i < commands.size(); ++i) {
    if (subcommands[i]->parsed()) return insalign::cli::run_guarded(commands[i].run);
  }
  return insalign::cli::kExitOther;
}
