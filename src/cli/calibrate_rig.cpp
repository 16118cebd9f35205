// insalign calibrate with several LiDARs: one FrameStore per LiDAR, the rig pipeline
// (core/rig.hpp), the rig outputs (report/rig_outputs.hpp) and the terminal summary.
#include "cli/calibrate_rig.hpp"

#include <fmt/core.h>
#include <sys/resource.h>

#include "cli/commands.hpp"
#include "core/errors.hpp"
#include "core/rig.hpp"
#include "files/atomic_file.hpp"
#include "report/rig_outputs.hpp"

namespace insalign::cli {
namespace {

double peak_rss_mb() {
  struct rusage usage {};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // Linux: KiB
}

}  // namespace

int calibrate_rig(const io::LoadedInput& input, const PipelineConfig& config, const RigRunOptions& options) {
  if (input.lidars.size() != input.lidar_names.size() || input.lidars.empty())
    throw InputError("--lidar-dir", "", "one name per LiDAR needed");
  io::ensure_writable_dir(options.out_dir);  // fail before the long work, not after
  std::vector<FrameStore> stores;
  std::vector<io::RunInfo> runs(input.lidars.size());
  for (std::size_t l = 0; l < input.lidars.size(); ++l) {
    stores.push_back(make_frame_store(input.lidars[l], config));
    if (l < input.reports.size()) runs[l].load = input.reports[l];
  }
  ProgressBar bar(options.verbosity);
  // Each LiDAR's report pictures need only its final extrinsic: drawn beside the repeatability study.
  std::vector<std::optional<io::LidarReportDrawing>> drawn(stores.size());
  const RigBeside draw = [&](std::size_t l, const CalibrationResult& r) { drawn[l] = io::draw_lidar_report(r, stores[l], options.viewer, stores.size());
  };
  const RigResult rig = run_rig_calibration(stores, input.lidar_names, config, bar.callback(),
                                            options.no_report ? nullptr : draw);
  const double peak_mb = peak_rss_mb();
  for (io::RunInfo& run : runs) run.peak_memory_mb = peak_mb;
  io::RigOutputOptions out;
  out.report = !options.no_report;
  out.viewer = options.viewer;
  io::write_rig_outputs(options.out_dir, rig, stores, runs, config, out, [&](double f) { bar.update("outputs", f); },
                        std::move(drawn));
  bar.finish();
  if (options.verbosity != Verbosity::kQuiet) fmt::print("{}", io::rig_summary_text(rig, peak_rss_mb()));
  if (!options.no_report) fmt::print("report: {}\n", (options.out_dir / "report.html").string());
  fmt::print("result: {}\n", (options.out_dir / io::kRigJsonFile).string());
  return kExitOk;
}

}  // namespace insalign::cli
