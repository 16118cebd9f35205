// Accuracy benchmark in the layout of the paper's Table II: N simulated drives (fresh scene,
// random true mount, random 20 deg / 0.5 m initial error), the error after each stage, the
// paper's rows beside ours, the worst run and the convergence rate.
//
//   build/bench/paper_tables --seeds 30 [--scenario default|recorded|feature-poor|time-offset|hdl32|os1-64|vlp16|no-init]
//                            [--no-init] [--fixed-time-offset] [--set key=value ...]
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <sys/resource.h>

#include <chrono>
#include <limits>
#include <random>

#include "core/errors.hpp"
#include "core/pipeline.hpp"
#include "cli/tool_config.hpp"
#include "io/poses.hpp"
#include "sim/world_dataset.hpp"

namespace insalign {
namespace {

struct StageErrors {
  Vec6 err = Vec6::Zero();  // |tx| |ty| |tz| m, |roll| |pitch| |yaw| deg
};

Vec6 to_vec(const ExtrinsicError& e) {
  Vec6 v;
  v << e.dt_m, e.drpy_deg;
  return v;
}

struct RunResult {
  std::uint64_t seed = 0;
  bool ok = false;
  std::string message;
  Vec6 init = Vec6::Zero(), rough = Vec6::Zero(), refined = Vec6::Zero(), final = Vec6::Zero();
  double time_offset_err_s = 0.0;
  Vec6 refine_stddev = Vec6::Zero();  // m, deg
  double refine_offset_stddev_s = 0.0;
  double seconds_init = 0, seconds_rough = 0, seconds_refine = 0, seconds_z = 0, seconds_total = 0;
};

void print_row(const char* label, const Vec6& v) {
  fmt::print("| {:<23} | {:>8.4f} | {:>8.4f} | {:>8.4f} | {:>8.4f} | {:>8.4f} | {:>8.4f} |\n", label, v[0], v[1], v[2],
             v[3], v[4], v[5]);
}

}  // namespace
}  // namespace insalign

int main(int argc, char** argv) {
  using namespace insalign;
  CLI::App app{"insalign accuracy benchmark (paper Table II layout)"};
  int seeds = 30;
  std::uint64_t first_seed = 1;
  std::string scenario = "default";
  std::string trajectory_file;
  double azimuth_step_deg = 0.2;
  double duration_s = 0.0;
  bool use_init = true;
  app.add_option("--seeds", seeds, "number of simulated drives")->capture_default_str();
  app.add_option("--first-seed", first_seed)->capture_default_str();
  app.add_option("--scenario", scenario, "default, recorded, feature-poor, time-offset, hdl32, os1-64, vlp16, no-init")
      ->capture_default_str();
  app.add_option("--trajectory", trajectory_file, "pose file for --scenario recorded")
      ->default_str("../shared/data/opencalib-sample/NovAtel-pose-lidar-time.txt");
  app.add_option("--azimuth-step-deg", azimuth_step_deg)->capture_default_str();
  app.add_option("--duration-s", duration_s, "truncate drives (0: full)")->capture_default_str();
  bool no_init = false, fixed_offset = false;
  app.add_flag("--fixed-time-offset", fixed_offset, "stage 2 keeps the time offset at 0 (clocks known to be synchronised)");
  app.add_flag("--no-init", no_init, "drop the initial guess (combines with any scenario; --scenario no-init = default scene)");
  std::vector<std::string> assignments;
  app.add_option("--set", assignments, "override a parameter, e.g. refine.max_frames=240 or sim.ins_noise_scale=0 "
                                       "(keys: insalign config --dump)");
  CLI11_PARSE(app, argc, argv);
  cli::ToolConfig tool;
  try {
    tool = cli::tool_config_with(assignments);
  } catch (const std::exception& e) {
    fmt::print(stderr, "{}\n", e.what());
    return 2;
  }
  if (no_init) use_init = false;
  if (trajectory_file.empty()) trajectory_file = "../shared/data/opencalib-sample/NovAtel-pose-lidar-time.txt";

  std::vector<RunResult> runs;
  for (int s = 0; s < seeds; ++s) {
    sim::SimConfig config = tool.sim;  // --set sim.* applies; the scenario and options below win
    config.seed = first_seed + s;
    config.azimuth_step_deg = azimuth_step_deg;
    config.duration_s = duration_s;
    std::mt19937_64 rng(config.seed * 7919);
    if (scenario == "feature-poor") config.scene = sim::SceneKind::kFeaturePoor;
    if (scenario == "hdl32") config.lidar_model = "hdl32";
    if (scenario == "os1-64") config.lidar_model = "os1-64";
    if (scenario == "vlp16") config.lidar_model = "vlp16";
    if (scenario == "time-offset") config.time_offset_s = std::uniform_real_distribution<double>(-0.05, 0.05)(rng);
    if (scenario == "no-init") use_init = false;
    if (scenario == "recorded") {
      const io::PoseFile file = io::read_pose_file(trajectory_file);
      config.trajectory = sim::TrajectoryKind::kRecorded;
      config.ins_axes = sim::InsAxes::kYForward;
      for (std::size_t i = 0; i < file.T_world_ins.size(); ++i) {
        config.recorded_trajectory.push_back({std::isfinite(file.t_s[i]) ? file.t_s[i] : 0.1 * i, file.T_world_ins[i]});
      }
    }
    auto world = std::make_shared<const sim::World>(sim::build_world(config));
    Dataset data = sim::world_dataset(world);
    if (!use_init) data.T_ins_lidar_init.reset();

    PipelineConfig pipeline = tool.calibrate;
    pipeline.repeatability.segments = 0;
    pipeline.refine.estimate_time_offset = !fixed_offset;
    RunResult run;
    run.seed = config.seed;
    run.init = to_vec(extrinsic_error(world->T_ins_lidar_init, world->T_ins_lidar_true));
    try {
      const FrameStore store = make_frame_store(data, pipeline);
      const CalibrationResult r = run_calibration(store, pipeline);
      run.rough = to_vec(extrinsic_error(r.rough.T_ins_lidar, world->T_ins_lidar_true));
      run.refined = to_vec(extrinsic_error(r.refine ? r.refine->T_ins_lidar : r.rough.T_ins_lidar, world->T_ins_lidar_true));
      run.final = to_vec(extrinsic_error(r.T_ins_lidar, world->T_ins_lidar_true));
      run.time_offset_err_s = std::abs(r.time_offset_s - config.time_offset_s);
      if (r.refine) {
        run.refine_stddev = r.refine->outcome.stddev;
        run.refine_stddev.tail<3>() *= kDegPerRad;
        run.refine_offset_stddev_s = r.refine->time_offset_stddev_s;
      }
      run.seconds_init = r.init.outcome.wall_time_s;
      run.seconds_rough = r.rough.outcome.wall_time_s;
      run.seconds_refine = r.refine ? r.refine->outcome.wall_time_s : 0.0;
      run.seconds_z = r.z.outcome.wall_time_s;
      run.seconds_total = r.wall_time_s;
      run.ok = true;
    } catch (const std::exception& e) {
      run.message = e.what();
    }
    fmt::print(stderr,
               "seed {:>3}: {}  final |t| {:.4f} {:.4f} {:.4f} m  |rpy| {:.4f} {:.4f} {:.4f} deg  dt_off {:.4f} s  "
               "{:.1f} s (rendering included)\n",
               run.seed, run.ok ? "ok  " : "FAIL", run.final[0], run.final[1], run.final[2], run.final[3],
               run.final[4], run.final[5], run.time_offset_err_s, run.seconds_total);
    if (run.ok) {
      fmt::print(stderr, "          stage 2 stddev: t {:.2f} {:.2f} mm, rpy {:.4f} {:.4f} {:.4f} deg, offset {:.2f} ms\n",
                 1e3 * run.refine_stddev[0], 1e3 * run.refine_stddev[1], run.refine_stddev[3], run.refine_stddev[4],
                 run.refine_stddev[5], 1e3 * run.refine_offset_stddev_s);
    } else {
      fmt::print(stderr, "          {}\n", run.message);
    }
    runs.push_back(run);
  }

  Vec6 mae_rough = Vec6::Zero(), mae_refined = Vec6::Zero(), mae_final = Vec6::Zero();
  Vec6 worst_rough = Vec6::Zero(), worst_refined = Vec6::Zero(), worst = Vec6::Zero();
  double mae_offset = 0.0, worst_offset = 0.0;
  int ok = 0, converged = 0;
  for (const RunResult& r : runs) {
    if (!r.ok) continue;
    ++ok;
    mae_rough += r.rough;
    mae_refined += r.refined;
    mae_final += r.final;
    worst_rough = worst_rough.cwiseMax(r.rough);
    worst_refined = worst_refined.cwiseMax(r.refined);
    worst = worst.cwiseMax(r.final);
    mae_offset += r.time_offset_err_s;
    worst_offset = std::max(worst_offset, r.time_offset_err_s);
    if (r.final.tail<3>().maxCoeff() <= 0.2 && r.final.head<2>().maxCoeff() <= 0.03) ++converged;
  }
  if (ok > 0) {
    mae_rough /= ok;
    mae_refined /= ok;
    mae_final /= ok;
    mae_offset /= ok;
  }
  fmt::print("\nScenario: {}{}, {} seeds from {}, azimuth step {} deg, duration {}\n", scenario,
             use_init ? "" : ", no initial guess", seeds, first_seed,
             azimuth_step_deg, duration_s > 0 ? fmt::format("{} s", duration_s) : std::string("full"));
  fmt::print("Mean absolute error (m, m, m, deg, deg, deg)\n\n");
  fmt::print("| {:<23} | {:>8} | {:>8} | {:>8} | {:>8} | {:>8} | {:>8} |\n", "stage", "tx", "ty", "tz", "roll", "pitch",
             "yaw");
  fmt::print("|{:-<25}|{:->10}|{:->10}|{:->10}|{:->10}|{:->10}|{:->10}|\n", "", "", "", "", "", "", "");
  // The paper's figures as the project brief quotes them (Yan et al. 2022): stage 1 reaches about
  // 0.2 deg / 0.03 m (a bound, not a mean; NaN: not quoted); all stages: the MAE of its Table II.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  Vec6 paper_rough, paper_z;
  paper_rough << 0.03, 0.03, nan, 0.2, 0.2, 0.2;
  paper_z << 0.007, 0.008, 0.012, 0.003, 0.034, 0.075;
  print_row("paper: rough (bound)", paper_rough);
  print_row("paper: all stages", paper_z);
  print_row("insalign: rough", mae_rough);
  print_row("insalign: refined", mae_refined);
  print_row("insalign: z-corrected", mae_final);
  print_row("insalign: worst rough", worst_rough);
  print_row("insalign: worst refined", worst_refined);
  print_row("insalign: worst final", worst);
  fmt::print("\nruns finished: {}/{}; converged (final within 0.2 deg per axis and 3 cm in x, y): {}/{}\n", ok,
             static_cast<int>(runs.size()), converged, static_cast<int>(runs.size()));
  fmt::print("time offset error: mean {:.2f} ms, worst {:.2f} ms\n", 1e3 * mae_offset, 1e3 * worst_offset);
  // The stage issues' bounds (tz: fiducials; its floor is the INS's own height error, see README).
  auto verdict = [](bool met) { return met ? "met" : "MISSED"; };
  const bool refine_mae = mae_refined.tail<3>().maxCoeff() <= 0.01 && mae_refined.head<2>().maxCoeff() <= 0.005;
  const bool refine_worst = worst_refined.tail<3>().maxCoeff() <= 0.03 && worst_refined.head<2>().maxCoeff() <= 0.01;
  const bool refine_better = mae_refined.tail<3>().sum() <= mae_rough.tail<3>().sum() &&
                             mae_refined.head<2>().sum() <= mae_rough.head<2>().sum();
  fmt::print("stage 2 bounds: MAE <= 0.01 deg and 5 mm {}; every run <= 0.03 deg and 1 cm {}; better than stage 1 "
             "on average (sum of rotation MAEs, of x+y MAEs) {}\n",
             verdict(refine_mae), verdict(refine_worst), verdict(refine_better));
  fmt::print("stage 3 bounds: tz MAE <= 1 cm {}; every run <= 2 cm {}\n", verdict(mae_final[2] <= 0.01),
             verdict(worst[2] <= 0.02));
  struct rusage usage {};
  getrusage(RUSAGE_SELF, &usage);
  fmt::print("peak RSS of this benchmark process: {:.0f} MB\n", usage.ru_maxrss / 1024.0);
  // Exit status: 0 only when every run converged and every stage bound is met (CI and scripts).
  const bool all_met = refine_mae && refine_worst && mae_final[2] <= 0.01 && worst[2] <= 0.02;
  return converged == static_cast<int>(runs.size()) && all_met ? 0 : 1;
}
