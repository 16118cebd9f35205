// insalign info: what an input holds (input/input_info.hpp), read the way calibrate reads it.
#include <fmt/core.h>

#include <memory>
#include <string>

#include "cli/commands.hpp"
#include "cli/input_options.hpp"
#include "input/input_info.hpp"

namespace insalign::cli {

namespace {

struct InfoOptions {
  InputOptions input;
  ConfigOptions config;
  std::size_t sample_frames = 5;
};

int run_info(const InfoOptions& o) {
  const ToolConfig tool = load_config(o.config);
  io::describe_input(input_spec(o.input), input_config(o.input, tool.input),
                     [](const std::string& text) {
                       fmt::print("{}", text);
                       std::fflush(stdout);  // the listing stays before an error that follows it
                     },
                     o.sample_frames);
  return kExitOk;
}

}  // namespace

Command make_info_command() {
  auto options = std::make_shared<InfoOptions>();
  Command command;
  command.setup = [options](CLI::App& app) {
    CLI::App* sub = app.add_subcommand(
        "info", "Summarise an input: a PCD folder + poses, a recording (--bag), a KITTI raw drive, or a pose source alone");
    add_input_options(*sub, options->input);
    add_config_options(*sub, options->config);
    sub->add_option("--sample-frames", options->sample_frames, "frames decoded to count points")->capture_default_str();
    return sub;
  };
  command.run = [options] { return run_info(*options); };
  return command;
}

}  // namespace insalign::cli
