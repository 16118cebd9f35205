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
#include "io/config_file.hpp"
#include "io/formats.hpp"
#include "io/report.hpp"
#include "io/result_json.hpp"

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

// The report: tables from the result, maps of the same frames at each stage's extrinsic.
io::ReportData make_report(const Dataset& data, const CalibrationResult& r, const DriveSummary& drive,
                           const io::LoadReport& load, const std::vector<std::filesystem::path>& formats,
                           ProgressBar& bar) {
  io::ReportData report;
  report.T_ins_lidar = r.T_ins_lidar;
  report.input_summary = {
      {"frames", fmt::format("{} used of {} PCD files", load.frames_used, load.frames_total)},
      {"poses", fmt::format("{} ({})", drive.poses, load.pose_format)},
      {"duration", fmt::format("{:.1f} s", drive.duration_s)},
      {"distance driven", fmt::format("{:.1f} m", drive.distance_m)},
      {"total heading change", fmt::format("{:.0f} deg", drive.heading_change_deg)},
      {"speed", fmt::format("{:.1f} to {:.1f} km/h", 3.6 * drive.speed_min_mps, 3.6 * drive.speed_max_mps)},
      {"point time field", load.time_field.empty() ? "none (no deskew)" : load.time_field},
      {"frame times", load.frame_time_source}};
  const double offset_rough = 0.0;
  report.stages.push_back({"start (" + r.init.source + ")", r.init.T_ins_lidar, 0.0, "", NAN, NAN,
                           r.init.wall_time_s, r.init.explanation});
  report.stages.push_back({"stage 1: rough", r.rough.T_ins_lidar, offset_rough, "robust point-to-plane cost (m^2)",
                           r.rough.cost_before, r.rough.cost_after, r.rough.wall_time_s,
                           fmt::format("{} frames, {} planes", r.rough.frames_used, r.rough.planes)});
  if (r.refine) {
    report.stages.push_back({"stage 2: refine", r.refine->T_ins_lidar, r.refine->time_offset_s, r.refine->measure,
                             r.refine->crispness_before, r.refine->crispness_after, r.refine->wall_time_s,
                             fmt::format("occupied voxels {} -> {}", r.refine->occupied_voxels_before,
                                         r.refine->occupied_voxels_after)});
  }
  report.stages.push_back({"stage 3: z", r.z.T_ins_lidar, r.time_offset_s, "", NAN, NAN, r.z.wall_time_s,
                           r.z.determined ? r.z.method : r.z.explanation});
  for (const RoundLog& log : r.rough.convergence) report.convergence.push_back({"rough", log.round, log.T_ins_lidar, log.cost});
  if (r.refine) {
    for (const RefineRound& log : r.refine->rounds) {
      report.convergence.push_back({"refine", log.round, log.T_ins_lidar, log.cost});
    }
  }
  for (const FiducialResidual& f : r.z.fiducials) {
    report.fiducials.push_back({f.id, f.residual_before_m, f.residual_after_m, f.used, f.reason_rejected});
  }
  report.fiducial_summary = r.z.explanation;
  report.time_offset_s = r.time_offset_s;
  if (r.refine) {
    report.time_offset_stddev_s = r.refine->time_offset_stddev_s;
    report.time_offset_note = r.refine->time_offset_estimated ? "estimated in stage 2" : "not estimated";
  }
  io::ObservabilityReport obs;
  obs.determined = r.determined;
  obs.stddev = r.stddev;
  obs.explanation = r.rough.observability.explanation;
  report.observability = obs;
  if (!r.segments.empty()) {
    io::RepeatabilityReport rep;
    for (const SegmentResult& seg : r.segments) {
      rep.segments.push_back({fmt::format("{:.0f}-{:.0f} s", seg.t_begin_s - r.segments.front().t_begin_s,
                                          seg.t_end_s - r.segments.front().t_begin_s),
                              seg.ok, seg.message, seg.T_ins_lidar, seg.time_offset_s});
    }
    rep.spread = r.segment_spread;
    report.repeatability = rep;
  }
  report.warnings = r.warnings;
  for (const auto& f : formats) report.output_files.push_back({f.filename().string(), "extrinsic for other tools"});
  report.output_files.push_back({"extrinsic.json", "the result with uncertainties and per-stage metrics"});
  report.output_files.push_back({"gnss-to-lidar-extrinsic.json", "OpenCalib JSON (T_lidar_ins)"});

  // Maps: the same frames stitched at each stage's extrinsic, so the thinning is visible.
  StitchConfig stitch;
  stitch.frames.max_frames = 60;
  stitch.voxel_m = 0.05;
  const std::vector<std::pair<std::string, std::pair<Iso3, double>>> snapshots = {
      {"start", {r.init.T_ins_lidar, 0.0}},
      {"stage 1: rough", {r.rough.T_ins_lidar, 0.0}},
      {"final", {r.T_ins_lidar, r.time_offset_s}}};
  for (std::size_t i = 0; i < snapshots.size(); ++i) {
    bar.update("report", static_cast<double>(i) / (snapshots.size() + 1));
    report.maps.push_back({snapshots[i].first,
                           stitch_map(data, snapshots[i].second.first, snapshots[i].second.second, stitch)});
  }
  return report;
}

/// Peak resident memory of this process so far (Linux reports ru_maxrss in KiB).
double peak_rss_mb() {
  struct rusage usage {};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;
}

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
  fmt::print("  total      {:>7.2f} s  (loading included), peak memory {:.0f} MB\n", r.wall_time_s, peak_rss_mb());
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

  PipelineConfig config = o.config.empty() ? PipelineConfig{} : io::load_tool_config(o.config).calibrate;
  if (o.trust_init) config.init.trust_init = true;
  if (o.no_refine) config.run_refine = false;
  if (o.segments >= 0) config.repeatability_segments = o.segments;
  if (std::isfinite(o.ins_height_m)) config.ins_height_m = o.ins_height_m;

  ProgressBar bar(o.quiet ? Verbosity::kQuiet : (o.verbose ? Verbosity::kVerbose : Verbosity::kNormal));
  const CalibrationResult result = run_calibration(data, config, bar.callback());

  const DriveSummary drive = io::summarize_drive(data, 3);
  const std::vector<std::filesystem::path> formats = io::write_all_formats(out_dir, result.T_ins_lidar);
  io::write_opencalib_extrinsic(out_dir / "gnss-to-lidar-extrinsic.json", result.T_ins_lidar);
  if (!o.no_report) {
    bar.update("report", 0.0);
    io::write_report(out_dir, make_report(data, result, drive, load, formats, bar));
    bar.update("report", 1.0);
  }
  bar.finish();
  // extrinsic.json last: its presence means the whole result is there.
  io::write_file_atomic(out_dir / "extrinsic.json", io::result_to_json(result, load, drive).dump(2) + "\n");
  if (!o.quiet) print_summary(result);
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
