#include "tool/tool_config.hpp"

#include "files/config_file.hpp"

namespace insalign::cli {

ToolConfig load_tool_config(const std::filesystem::path& path, ToolConfig defaults) {
  io::load_config_file(path, defaults);
  return defaults;
}

ToolConfig tool_config_with(const std::vector<std::string>& assignments, const std::string& source,
                            ToolConfig defaults) {
  io::apply_config_assignments(assignments, source, defaults);
  return defaults;
}

std::string dump_tool_config(const ToolConfig& config) {
  return io::dump_config(config,
                         "insalign parameters with their defaults. Pass a file with any subset of them to\n"
                         "`insalign calibrate --config FILE` or `insalign simulate --config FILE`; unknown\n"
                         "names are errors. Keys are the struct paths of the code (src/core/*.hpp).");
}

std::vector<std::string> tool_config_keys() { return io::config_keys<ToolConfig>(); }

}  // namespace insalign::cli
