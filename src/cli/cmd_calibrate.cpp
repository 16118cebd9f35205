#include "cli/commands.hpp"

#include <fmt/core.h>

namespace insalign::cli {

Command make_calibrate_command() {
  Command command;
  command.setup = [](CLI::App& app) { return app.add_subcommand("calibrate", "(not implemented yet)"); };
  command.run = [] {
    fmt::print(stderr, "insalign calibrate: not implemented yet\n");
    return kExitOther;
  };
  return command;
}

}  // namespace insalign::cli
