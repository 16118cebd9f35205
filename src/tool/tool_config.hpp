// Everything `--config` and `--set` can reach: the calibration pipeline (keys at the top:
// `rough.filter.voxel_m`), reading the inputs (`input.clock.enabled`) and the simulator
// (`sim.seed`). It joins core, io and sim, so it lives with the programs that use them all (the
// command line and the benchmarks), not in io.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "core/check_run.hpp"
#include "core/pipeline.hpp"
#include "input/input_config.hpp"
#include "report/viewer.hpp"
#include "sim/simulate_config.hpp"

namespace insalign::cli {

struct ToolConfig {
  PipelineConfig calibrate;
  CheckRunConfig check;  ///< insalign check: tolerances, verdict rules, stretches, history
  io::InputConfig input;
  sim::SimConfig sim;
  io::ViewerConfig report;  ///< the report's 3D view
};

template <class V>
void visit_config(V& v, ToolConfig& c) {
  visit_config(v, c.calibrate);
  v.section("check", c.check);
  v.section("input", c.input);
  v.section("sim", c.sim);
  v.section("report", c.report);
}

/// Defaults overridden by the YAML file. Throws InputError(path, "line N", ...).
ToolConfig load_tool_config(const std::filesystem::path& path, ToolConfig defaults = {});

/// Defaults overridden by `key=value` assignments. Throws InputError naming `source` and the key.
ToolConfig tool_config_with(const std::vector<std::string>& assignments, const std::string& source = "--set",
                            ToolConfig defaults = {});

/// `insalign config --dump`: commented YAML of every parameter with its value in `config`.
std::string dump_tool_config(const ToolConfig& config = {});

/// Every key, for help texts and tests.
std::vector<std::string> tool_config_keys();

}  // namespace insalign::cli
