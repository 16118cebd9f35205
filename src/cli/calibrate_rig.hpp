// insalign calibrate with several LiDARs (CONVENTIONS.md "Rigs"): every LiDAR calibrated to the
// INS in one run, OUT/<name>/ per LiDAR, rig.json, a URDF and one report. cmd_calibrate.cpp loads
// the inputs and calls this when they hold more than one LiDAR.
#pragma once

#include <filesystem>

#include "cli/progress.hpp"
#include "core/pipeline.hpp"
#include "input/input_source.hpp"
#include "report/viewer.hpp"

namespace insalign::cli {

struct RigRunOptions {
  std::filesystem::path out_dir;
  bool no_report = false;
  Verbosity verbosity = Verbosity::kNormal;
  io::ViewerConfig viewer;  ///< the reports' 3D views (config report.*)
};

/// Runs the rig calibration and writes its outputs; returns the exit code (CONVENTIONS.md).
int calibrate_rig(const io::LoadedInput& input, const PipelineConfig& config, const RigRunOptions& options);

}  // namespace insalign::cli
