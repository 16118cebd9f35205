// insalign calibrate: load and validate the inputs, run the pipeline, write the results.
#include <fmt/core.h>

#include <chrono>
#include <memory>

#include "cli/commands.hpp"
#include "core/errors.hpp"
#include "core/pipeline.hpp"
#include "io/atomic_file.hpp"
#include "io/dataset.hpp"
#include "io/extrinsic_json.hpp"
#include "io/formats.hpp"
#include "io/result_json.hpp"

namespace insalign::cli {
namespace {

struct CalibrateOptions {
  std::string lidar_dir, poses, init, fiducials, config, out;
  double ins_height_m = std::numeric_limits<double>::quiet_NaN();
  bool trust_init = false;
  bool no_refine = false;
  int segments = 3;
  bool quiet = false, verbose = false;
};

void print_summary(const CalibrationResult& r) {
  const Vec3 t = r.T_ins_lidar.translation();
  const Vec3 rpy = rpy_from_rotation(r.T_ins_lidar.linear()) * kDegPerRad;
  fmt::print("\nT_ins_lidar (LiDAR to INS)\n");
  fmt::print("  {:<6} {:>12} {:>12} {:>12}\n", "dof", "value", "stddev", "determined");
  const char* names[6] = {"x m", "y m", "z m", "roll", "pitch", "yaw"};
  const double values[6] = {t.x(), t.y(), t.z(), rpy.x(), rpy.y(), rpy.z()};
  for (int i = 0; i < 6; ++i) {
    fmt::print("  {:<6} {:>12.4f} {:>12.4f} {:>12}\n", names[i], values[i], r.stddev[i], r.determined[i] ? "yes" : "NO");
  }
  fmt::print("  time offset {:.4f} s\n", r.time_offset_s);
  const auto stage_line = [](const char* name, double seconds, const std::string& note) {
    fmt::print("  {:<10} {:>7.2f} s  {}\n", name, seconds, note);
  };
  fmt::print("\nstages\n");
  stage_line("init", r.init.wall_time_s, r.init.source);
  stage_line("rough", r.rough.wall_time_s,
             fmt::format("cost {:.4g} -> {:.4g} m^2, {} frames", r.rough.cost_before, r.rough.cost_after,
                         r.rough.frames_used));
  if (r.refine) {
    stage_line("refine", r.refine->wall_time_s,
               fmt::format("{}: {:.4g} -> {:.4g}", r.refine->measure, r.refine->crispness_before,
                           r.refine->crispness_after));
  }
  stage_line("z", r.z.wall_time_s, r.z.determined ? r.z.method : "tz not determined");
  fmt::print("  total      {:>7.2f} s\n", r.wall_time_s);
  for (const std::string& w : r.warnings) fmt::print("warning: {}\n", w);
}

int run_calibrate(const CalibrateOptions& o) {
  const std::filesystem::path out_dir = o.out;
  io::ensure_writable_dir(out_dir);  // fail before the long work, not after

  io::DatasetPaths paths{o.lidar_dir, o.poses, std::nullopt, std::nullopt};
  if (!o.init.empty()) paths.init = o.init;
  if (!o.fiducials.empty()) paths.fiducials = o.fiducials;
  io::LoadReport load;
  const Dataset data = io::load_dataset(paths, &load);
  if (!o.quiet) {
    fmt::print(stderr, "loaded {} frames ({} skipped), {} poses; frame times: {}\n", load.frames_used,
               load.frames_total - load.frames_used, data.poses.size(), load.frame_time_source);
    for (const std::string& w : load.warnings) fmt::print(stderr, "warning: {}\n", w);
  }

  PipelineConfig config;
  config.init.trust_init = o.trust_init;
  config.run_refine = !o.no_refine;
  config.repeatability_segments = o.segments;
  if (std::isfinite(o.ins_height_m)) config.ins_height_m = o.ins_height_m;

  auto last_print = std::chrono::steady_clock::now() - std::chrono::seconds(10);
  const PipelineProgress progress = [&](std::string_view step, double fraction) {
    if (o.quiet) return;
    const auto now = std::chrono::steady_clock::now();
    if (fraction < 1.0 && now - last_print < std::chrono::milliseconds(500)) return;
    last_print = now;
    fmt::print(stderr, "  {:<14} {:5.1f}%\n", step, 100.0 * fraction);
  };
  const CalibrationResult result = run_calibration(data, config, progress);

  const DriveSummary drive = io::summarize_drive(data, 3);
  io::write_file_atomic(out_dir / "extrinsic.json", io::result_to_json(result, load, drive).dump(2) + "\n");
  io::write_opencalib_extrinsic(out_dir / "gnss-to-lidar-extrinsic.json", result.T_ins_lidar);
  io::write_all_formats(out_dir, result.T_ins_lidar);
  if (!o.quiet) print_summary(result);
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
    sub->add_option("--segments", o->segments, "disjoint drive segments calibrated alone for repeatability (0: off)")
        ->capture_default_str();
    sub->add_flag("-q,--quiet", o->quiet, "only errors and the result path");
    sub->add_flag("-v,--verbose", o->verbose, "more detail");
    return sub;
  };
  command.run = [o] { return run_calibrate(*o); };
  return command;
}

}  // namespace insalign::cli
