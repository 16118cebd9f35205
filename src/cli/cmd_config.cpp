// insalign config: every parameter with its default and meaning (--dump), or check a file (--check).
#include <fmt/core.h>

#include <memory>

#include "cli/commands.hpp"
#include "tool/tool_config.hpp"

namespace insalign::cli {

Command make_config_command() {
  struct Options {
    bool dump = false;
    std::string check;
  };
  auto o = std::make_shared<Options>();
  Command command;
  command.setup = [o](CLI::App& app) {
    CLI::App* sub = app.add_subcommand("config", "Print every parameter with its default and meaning, or check a config file");
    sub->add_flag("--dump", o->dump, "print all parameters as commented YAML (a starting point for --config FILE)");
    sub->add_option("--check", o->check, "load a config file and print the resulting parameters (errors name the line)");
    return sub;
  };
  command.run = [o] {
    if (!o->check.empty()) {
      // The dump of the loaded file shows what the run will use, defaults filled in.
      fmt::print("{}", dump_tool_config(load_tool_config(o->check)));
      return kExitOk;
    }
    if (!o->dump) {
      fmt::print(stderr, "insalign config: give --dump or --check FILE\n");
      return kExitUsage;
    }
    fmt::print("{}", dump_tool_config());
    return kExitOk;
  };
  return command;
}

}  // namespace insalign::cli
