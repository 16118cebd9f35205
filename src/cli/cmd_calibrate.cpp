// insalign calibrate: load and validate the inputs, run the pipeline, write the results.
#include <fmt/core.h>
#include <sys/resource.h>

#include <chrono>
#include <memory>

#include "cli/commands.hpp"
#include "core/errors.hpp"
#include "core/pipeline.hpp"
#include "io/atomic_file.hpp"
#include "io/dataset.hpp"
#include "io/extrinsic_json.hpp"
#include "cli/progress.hpp"
#include "cli/tool_config.hpp"
#include "io/formats.hpp"
#include "io/result_outputs.hpp"

namespace insalign::cli {
namespace {

struct CalibrateOptions {
  std::string lidar_dir, poses, init, fiducials, config, out;
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

int run_calibrate(const CalibrateOptions& o) {
  const std::filesystem::path out_dir = o.out;
  io::ensure_writable_dir(out_dir);  // fail before the long work, not after

  io::DatasetPaths paths{o.lidar_dir, o.poses, std::nullopt, std::nullopt};
  if (!o.init.empty()) paths.init = o.init;
  if (!o.fiducials.empty()) paths.fiducials = o.fiducials;
  io::RunInfo run;
  const Dataset data = io::load_dataset(paths, &run.load);
  if (!o.quiet) {
    fmt::print(stderr, "loaded {} frames ({} skipped), {} poses; frame times: {}\n", run.load.frames_used,
               run.load.frames_total - run.load.frames_used, data.poses.size(), run.load.frame_time_source);
    for (const std::string& w : run.load.warnings) fmt::print(stderr, "warning: {}\n", w);
  }

  PipelineConfig config = o.config.empty() ? PipelineConfig{} : load_tool_config(o.config).calibrate;
  if (o.trust_init) config.init.trust_init = true;
  if (o.no_refine) config.run_refine = false;
  if (o.segments >= 0) config.repeatability.segments = o.segments;
  if (std::isfinite(o.ins_height_m)) config.ins_height_m = o.ins_height_m;

  ProgressBar bar(o.quiet ? Verbosity::kQuiet : (o.verbose ? Verbosity::kVerbose : Verbosity::kNormal));
  const FrameStore store = make_frame_store(data, config);
  const CalibrationResult result = run_calibration(store, config, bar.callback());

  run.format_files = io::write_all_formats(out_dir, result.T_ins_lidar);
  io::write_opencalib_extrinsic(out_dir / "gnss-to-lidar-extrinsic.json", result.T_ins_lidar);
  if (!o.no_report) {
    bar.update("report", 0.0);
    io::write_report(out_dir, io::report_data(result, store, run, config, [&](double f) { bar.update("report", f); }));
    bar.update("report", 1.0);
  }
  bar.finish();
  run.peak_memory_mb = peak_rss_mb();
  // extrinsic.json last: its presence means the whole result is there.
  io::write_file_atomic(out_dir / "extrinsic.json", io::result_to_json(result, run).dump(2) + "\n");
  if (!o.quiet) fmt::print("{}", io::summary_text(result, run));
  if (!o.no_report) fmt::print("report: {}\n", (out_dir / "report.html").string());
  fmt::print("result: {}\n", (out_dir / "extrinsic.json").string());
  return kExitOk;
}

}  // namespace

Command make_calibrate_command() {
  auto o = std::make_shared<CalibrateOptions>();
  Command command;
  command.setup = [o](CLI::App& app) {
    CLI::App* sub = app.add_subcommand("calibrate", "Estimate T_ins_lidar from a drive");
    sub->add_option("--lidar-dir", o->lidar_dir, "folder of PCD sweeps, one per frame")->required();
    sub->add_option("--poses", o->poses, "INS poses T_world_ins: OpenCalib per-frame lines or TUM")->required();
    sub->add_option("--init", o->init, "initial extrinsic, OpenCalib JSON (T_lidar_ins); optional");
    sub->add_option("--fiducials", o->fiducials, "surveyed points 'id x y z' (world frame) to fix tz");
    sub->add_option("--ins-height-m", o->ins_height_m, "INS origin height above the ground (fixes tz without fiducials)");
    sub->add_option("--config", o->config, "YAML file setting any parameter (see 'insalign config --dump')");
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
