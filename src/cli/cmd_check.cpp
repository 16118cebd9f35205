// insalign check: does the installed extrinsic still hold? (CONVENTIONS.md "Checking an
// installed extrinsic"). Loads the drive and the installed extrinsic(s), runs core/check_run per
// LiDAR, combines with --history, writes check.json, check.html and (recalibrate) corrected/.
#include <fmt/format.h>

#include <cmath>
#include <malloc.h>
#include <limits>
#include <memory>

#include "cli/commands.hpp"
#include "cli/input_options.hpp"
#include "cli/progress.hpp"
#include "tool/tool_config.hpp"
#include "core/check_run.hpp"
#include "core/errors.hpp"
#include "files/atomic_file.hpp"
#include "report/check_outputs.hpp"
#include "input/input_info.hpp"
#include "files/installed_extrinsic.hpp"

namespace insalign::cli {
namespace {

struct CheckOptions {
  InputOptions input;
  ConfigOptions config;
  std::vector<std::string> extrinsics;
  std::string history;
  std::string out;
  double ins_height_m = std::numeric_limits<double>::quiet_NaN();
  bool quiet = false, verbose = false;
};

struct Installed {
  io::InstalledExtrinsic extrinsic;
  std::string source;
};

// Every --extrinsic's entries matched to the input's LiDARs: by name when the files name every
// LiDAR (rig.json, a rig URDF), else in the order given.
std::vector<Installed> match_extrinsics(const std::vector<std::string>& files, const std::vector<std::string>& lidar_names) {
  std::vector<Installed> entries;
  for (const std::string& f : files)
    for (io::InstalledExtrinsic& e : io::read_installed_extrinsics(f)) entries.push_back({std::move(e), f});
  auto by_name = [&](const std::string& name) -> const Installed* {
    for (const Installed& e : entries)
      if (e.extrinsic.name == name) return &e;
    return nullptr;
  };
  std::vector<Installed> out;
  bool all_named = true;
  for (const std::string& name : lidar_names) all_named = all_named && by_name(name) != nullptr;
  if (all_named && (entries.size() > 1 || lidar_names.size() > 1)) {
    for (const std::string& name : lidar_names) out.push_back(*by_name(name));
    return out;
  }
  if (entries.size() != lidar_names.size())
    throw InputError("--extrinsic", "",
                     fmt::format("{} extrinsic(s) in the files given for {} LiDAR(s) ({}): give one --extrinsic per LiDAR "
                                 "in the input's order, or one rig.json naming every LiDAR",
                                 entries.size(), lidar_names.size(), fmt::join(lidar_names, ", ")));
  return entries;
}

PipelineConfig pipeline_config(const CheckOptions& o, PipelineConfig config) {
  if (std::isfinite(o.ins_height_m)) config.ins_height_m = o.ins_height_m;
  return config;
}

io::LidarCheck check_lidar(const CheckOptions& o, Dataset data, const std::string& name, const Installed& installed,
                           const ToolConfig& tool, const io::ViewerConfig& viewer) {
  io::LidarCheck l;
  l.name = name;
  l.source = installed.source;
  l.format = installed.extrinsic.format;
  l.T_ins_lidar_installed = installed.extrinsic.T_ins_lidar;
  l.time_offset_installed_s = installed.extrinsic.time_offset_s;
  data.T_ins_lidar_init = l.T_ins_lidar_installed;  // global initialisation checks it against the data
  data.time_offset_init_s = l.time_offset_installed_s;  // what the drive cannot decide stays installed
  const PipelineConfig config = pipeline_config(o, tool.calibrate);
  const FrameStore store = make_frame_store(data, config);
  if (!o.quiet) fmt::print(stderr, "checking {}{} ...\n", name.empty() ? "" : name + " against ", installed.source);
  ProgressBar bar(o.quiet ? Verbosity::kQuiet : (o.verbose ? Verbosity::kVerbose : Verbosity::kNormal), stderr);
  l.run = run_check(store, l.T_ins_lidar_installed, l.time_offset_installed_s, config, tool.check, bar.callback());
  const double t_end = data.frames.frames.empty() ? 0.0 : data.frames.frames.back().t_end_s;
  l.drive_end = io::iso8601_utc(t_end + l.run.measured.time_offset_s);
  // The report's 3D view needs 60 frames and 50-80 MB of its own: the stages' 300 decoded sweeps
  // (250 MB at the sensor's resolution) and the memory they freed go back first, so that a
  // 10-minute drive's check stays within 500 MB (587 -> 468-478 MB for ~0.5 s of CPU;
  // bench/results/check.md). cli/main.cpp keeps freed memory otherwise.
  store.forget();
#ifdef __GLIBC__
  malloc_trim(0);
#endif
  bar.update("3d view", 0.0);
  l.viewer = io::check_viewer_scene(store, l.run, l.T_ins_lidar_installed, l.time_offset_installed_s, viewer);
  bar.update("3d view", 1.0);
  bar.finish();
  return l;
}

// --history: this drive's record joins DIR (replacing an earlier check of the same drive), and
// the verdict is the combination of the records since the last step.
void apply_history(const CheckOptions& o, const ToolConfig& tool, std::vector<io::LidarCheck>& lidars) {
  const std::filesystem::path dir = o.history;
  const std::string record_name = io::iso8601_basic(lidars.front().drive_end) + ".check.json";
  auto records = io::read_history(dir, record_name);
  const std::string this_drive = io::check_to_json(lidars).dump(2) + "\n";
  for (auto& [name, record] : io::parse_check_record(this_drive, record_name)) records[name].push_back(record);
  for (io::LidarCheck& l : lidars)
    l.history = combine_history(records[l.name], l.T_ins_lidar_installed, l.time_offset_installed_s, tool.check.check,
                                tool.check.history);
  std::filesystem::create_directories(dir);
  io::write_file_atomic(dir / record_name, this_drive);
}

int exit_code(CheckVerdict v) {
  switch (v) {
    case CheckVerdict::kOk: return kExitOk;
    case CheckVerdict::kRecalibrate: return kExitRecalibrate;
    default: return kExitUnobservable;
  }
}

int run_check_command(const CheckOptions& o) {
  const ToolConfig tool = load_config(o.config);
  try {
    (void)unchecked_dofs(tool.check.check);  // a bad check.unchecked_dofs is bad usage, before any work
  } catch (const std::invalid_argument& e) {
    throw InputError(o.config.file.empty() ? "--set" : o.config.file, "check.unchecked_dofs", e.what());
  }
  const io::LoadedInput input = load_inputs(o.input, tool.input);
  const std::vector<Installed> installed = match_extrinsics(o.extrinsics, input.lidar_names);
  if (!o.quiet)
    for (const io::LoadReport& r : input.reports) fmt::print(stderr, "{}", io::describe_load(r));
  io::ensure_writable_dir(o.out);
  std::vector<io::LidarCheck> lidars;
  const bool rig = input.lidars.size() > 1;
  io::ViewerConfig viewer = tool.report;  // the LiDARs share the 3D view's budget
  viewer.max_points /= std::max<std::size_t>(1, input.lidars.size());
  for (std::size_t i = 0; i < input.lidars.size(); ++i)
    lidars.push_back(check_lidar(o, input.lidars[i], rig ? input.lidar_names[i] : "", installed[i], tool, viewer));
  if (!o.history.empty()) apply_history(o, tool, lidars);
  const std::filesystem::path out = o.out;
  const CheckVerdict verdict = io::rig_verdict(lidars);
  if (verdict == CheckVerdict::kRecalibrate) io::write_corrected(out, lidars);
  io::write_check_html(out, lidars);
  io::write_file_atomic(out / "check.json", io::check_to_json(lidars).dump(2) + "\n");
  for (const io::LidarCheck& l : lidars) {
    fmt::print("{}{}\n", l.name.empty() ? "" : l.name + ": ", l.message());
    if (!o.quiet)
      for (const std::string& w : l.run.findings.warnings) fmt::print(stderr, "warning: {}\n", w);
  }
  fmt::print("check: {}\n", (out / "check.json").string());
  return exit_code(verdict);
}

}  // namespace

Command make_check_command() {
  auto o = std::make_shared<CheckOptions>();
  Command command;
  command.setup = [o](CLI::App& app) {
    CLI::App* sub = app.add_subcommand("check", "Check an installed extrinsic on an ordinary drive (exit 0 ok, 4 recalibrate, 3 inconclusive)");
    add_input_options(*sub, o->input, false);
    sub->add_option("--extrinsic", o->extrinsics,
                    "the installed extrinsic: extrinsic.json, OpenCalib JSON, rig.json, URDF/xacro, KITTI "
                    "calib_imu_to_velo.txt, ...; one per LiDAR in the input's order, or one rig.json")
        ->required();
    sub->add_option("--fiducials", o->input.fiducials, "surveyed points 'id x y z' (world frame) or '# wgs84': let the drive check tz");
    sub->add_option("--ins-height-m", o->ins_height_m, "INS origin height above the ground: lets the drive check tz");
    sub->add_option("--history", o->history, "folder of this car's earlier checks (<drive end time>.check.json), read and appended");
    add_config_options(*sub, o->config);
    sub->add_option("--out", o->out, "output folder")->required();
    sub->add_flag("-q,--quiet", o->quiet, "only the verdict and the result path");
    sub->add_flag("-v,--verbose", o->verbose, "each step's wall and CPU time");
    return sub;
  };
  command.run = [o] { return run_check_command(*o); };
  return command;
}

}  // namespace insalign::cli
