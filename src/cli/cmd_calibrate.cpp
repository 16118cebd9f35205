// insalign calibrate: load and validate the inputs (any input kind: cli/input_options.hpp), run
// the pipeline, write the results; several LiDARs go to the rig calibration (calibrate_rig.hpp).
#include <fmt/core.h>
#include <sys/resource.h>

#include <cmath>
#include <limits>
#include <memory>

#include "cli/calibrate_rig.hpp"
#include "cli/commands.hpp"
#include "cli/input_options.hpp"
#include "cli/progress.hpp"
#include "tool/tool_config.hpp"
#include "core/pipeline.hpp"
#include "files/atomic_file.hpp"
#include "files/extrinsic_json.hpp"
#include "files/formats.hpp"
#include "input/input_info.hpp"
#include "report/result_outputs.hpp"

namespace insalign::cli {
namespace {

struct CalibrateOptions {
  InputOptions input;
  ConfigOptions config;
  std::string out;
  double ins_height_m = std::numeric_limits<double>::quiet_NaN();
  bool trust_init = false;
  bool no_refine = false;
  int segments = -1;  ///< -1: as the config says
  bool quiet = false, verbose = false;
  bool no_report = false;
};

/// Peak resident memory of this process so far (Linux reports ru_maxrss in KiB).
double peak_rss_mb() {
  struct rusage usage {};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;
}

PipelineConfig pipeline_config(const CalibrateOptions& o, PipelineConfig config) {
  if (o.trust_init) config.init.trust_init = true;
  if (o.no_refine) config.run_refine = false;
  if (o.segments >= 0) config.repeatability.segments = o.segments;
  if (std::isfinite(o.ins_height_m)) config.ins_height_m = o.ins_height_m;
  return config;
}

Verbosity verbosity(const CalibrateOptions& o) {
  return o.quiet ? Verbosity::kQuiet : (o.verbose ? Verbosity::kVerbose : Verbosity::kNormal);
}

// One LiDAR: the pipeline, then every output; extrinsic.json last (its presence means the whole
// result is there).
int calibrate_one(const CalibrateOptions& o, const io::LoadedInput& input, const PipelineConfig& config,
                  const io::ViewerConfig& viewer) {
  const std::filesystem::path out_dir = o.out;
  io::RunInfo run;
  run.load = input.reports.front();
  ProgressBar bar(verbosity(o));
  const FrameStore store = make_frame_store(input.lidars.front(), config);
  // The report's pictures need only the final extrinsic: drawn beside the repeatability study.
  std::optional<io::ReportImages> images;
  const BesideRepeatability draw = [&](const CalibrationResult& r) { images = io::report_images(r, store, viewer); };
  const CalibrationResult result = run_calibration(store, config, bar.callback(), o.no_report ? nullptr : draw);

  run.format_files = io::write_all_formats(out_dir, result.T_ins_lidar);  // calib_imu_to_velo.txt among them
  io::write_opencalib_extrinsic(out_dir / "gnss-to-lidar-extrinsic.json", result.T_ins_lidar);
  store.forget();
  if (images) {
    bar.update("report", 0.0);
    io::write_report(out_dir, io::report_data(result, store, run, config), *images);
    bar.update("report", 1.0);
  }
  bar.finish();
  run.peak_memory_mb = peak_rss_mb();
  io::write_file_atomic(out_dir / "extrinsic.json", io::result_to_json(result, run).dump(2) + "\n");
  if (!o.quiet) fmt::print("{}", io::summary_text(result, run));
  if (!o.no_report) fmt::print("report: {}\n", (out_dir / "report.html").string());
  fmt::print("result: {}\n", (out_dir / "extrinsic.json").string());
  return kExitOk;
}

// Bad input is found before the output folder exists: a failed run writes nothing.
int run_calibrate(const CalibrateOptions& o) {
  const ToolConfig tool = load_config(o.config);
  const PipelineConfig config = pipeline_config(o, tool.calibrate);
  const io::LoadedInput input = load_inputs(o.input, tool.input);
  if (!o.quiet) {
    for (const io::LoadReport& r : input.reports) fmt::print(stderr, "{}", io::describe_load(r));
  }
  io::ensure_writable_dir(o.out);
  if (input.lidars.size() > 1) return calibrate_rig(input, config, {o.out, o.no_report, verbosity(o), tool.report});
  return calibrate_one(o, input, config, tool.report);
}

}  // namespace

Command make_calibrate_command() {
  auto o = std::make_shared<CalibrateOptions>();
  Command command;
  command.setup = [o](CLI::App& app) {
    CLI::App* sub = app.add_subcommand("calibrate", "Estimate T_ins_lidar from a drive");
    add_input_options(*sub, o->input);
    sub->add_option("--ins-height-m", o->ins_height_m, "INS origin height above the ground (fixes tz without fiducials)");
    add_config_options(*sub, o->config);
    sub->add_option("--out", o->out, "output folder")->required();
    sub->add_flag("--trust-init", o->trust_init, "start from --init without checking it against the data");
    sub->add_flag("--no-refine", o->no_refine, "stop after stage 1");
    sub->add_option("--segments", o->segments,
                    "disjoint drive segments calibrated alone for repeatability (0: off; default 3)");
    sub->add_flag("--no-report", o->no_report, "skip report.html (faster)");
    sub->add_flag("-q,--quiet", o->quiet, "only errors and the result path");
    sub->add_flag("-v,--verbose", o->verbose, "more detail");
    return sub;
  };
  command.run = [o] { return run_calibrate(*o); };
  return command;
}

}  // namespace insalign::cli
