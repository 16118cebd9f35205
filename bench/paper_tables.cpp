// Accuracy benchmark in the layout of the paper's Table II: N simulated drives (fresh scene,
// random true mount, random 20 deg / 0.5 m initial error), the error after each stage, the
// paper's rows beside ours, the worst run and the convergence rate. Two columns for the INS: the
// extrinsic with the INS taken as truth (stage 2) and the joint estimate with the INS trajectory
// corrected (whether or not the pipeline applied it), and, where the INS heading drifts, its
// drive-mean heading error: the yaw floor no method removes.
//
//   build/bench/paper_tables --seeds 30 [--scenario NAME] [--no-init] [--fixed-time-offset] [--set key=value ...]
//   NAME: default, recorded, drift, drift-position, float, wrong-fix, traffic, no-fiducials, hdl32, os1-64,
//         vlp16, feature-poor, time-offset, no-init (bench/scenarios.hpp)
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <sys/resource.h>

#include <limits>

#include "scenarios.hpp"
#include "tool/tool_config.hpp"
#include "core/pipeline.hpp"
#include "sim/world_dataset.hpp"

namespace insalign {
namespace {

Vec6 to_vec(const ExtrinsicError& e) {
  Vec6 v;
  v << e.dt_m, e.drpy_deg;
  return v;
}
Vec6 abs_error(const Iso3& est, const Iso3& gt) { return to_vec(extrinsic_error(est, gt)); }
double signed_yaw_deg(const Iso3& est, const Iso3& gt) {
  return kDegPerRad * rpy_from_rotation(est.linear() * gt.linear().transpose()).z();
}

struct RunResult {
  std::uint64_t seed = 0;
  bool ok = false;
  std::string message;
  std::vector<std::string> warnings;
  Vec6 rough = Vec6::Zero(), refined = Vec6::Zero(), joint = Vec6::Zero(), final = Vec6::Zero();
  double yaw_refined_deg = 0.0, yaw_joint_deg = 0.0;  // signed
  double yaw_floor_deg = 0.0;     // minus the INS's drive-mean heading error
  bool corrected = false;         // the pipeline used the corrected trajectory
  double correction_rms_mm = 0.0, thinner_pct = 0.0;
  double correction_err_mm = 0.0;  // RMS over the frames of the correction against the truth (means removed)
  Vec6 joint_stddev = Vec6::Zero();  // m, deg
  double time_offset_err_s = 0.0;
  double seconds_total = 0.0;
};

// How far the estimated correction is from the one that would remove the INS's slow position
// error exactly, both with their means over the frames removed (the mean is a world shift).
double correction_error_m(const sim::World& world, const TrajectoryCorrection& c, const std::vector<double>& t_ins) {
  if (c.t_s.empty() || t_ins.empty()) return 0.0;
  std::vector<Vec3> d;
  Vec3 mean = Vec3::Zero();
  for (double t : t_ins) {
    d.push_back(c.position_at(t) + sim::ins_slow_error(world, t).position_m);
    mean += d.back();
  }
  mean /= static_cast<double>(d.size());
  double sum = 0.0;
  for (const Vec3& v : d) sum += (v - mean).squaredNorm();
  return std::sqrt(sum / static_cast<double>(d.size()));
}

struct Options {
  std::string scenario = "default", trajectory_file;
  double azimuth_step_deg = 0.2, duration_s = 0.0;
  bool no_init = false, fixed_offset = false, verbose = false;
};

RunResult run_one(const cli::ToolConfig& tool, const Options& o, std::uint64_t seed) {
  bench::ScenarioRun scenario = bench::make_scenario(o.scenario, tool.sim, seed, o.trajectory_file);
  scenario.sim.azimuth_step_deg = o.azimuth_step_deg;
  scenario.sim.duration_s = o.duration_s;
  auto world = std::make_shared<const sim::World>(sim::build_world(scenario.sim));
  Dataset data = sim::world_dataset(world);
  if (!scenario.use_init || o.no_init) data.T_ins_lidar_init.reset();
  PipelineConfig pipeline = tool.calibrate;
  pipeline.repeatability.segments = 0;
  pipeline.refine.estimate_time_offset = !o.fixed_offset;
  RunResult run;
  run.seed = seed;
  const Iso3& gt = world->T_ins_lidar_true;
  std::vector<double> t_ins;
  for (double t : world->frame_times_s) t_ins.push_back(t + scenario.sim.time_offset_s);
  run.yaw_floor_deg = -kDegPerRad * bench::mean_heading_error_rad(*world, t_ins);
  try {
    const FrameStore store = make_frame_store(data, pipeline);
    const CalibrationResult r = run_calibration(store, pipeline);
    const Iso3 refined = r.refine ? r.refine->T_ins_lidar : r.rough.T_ins_lidar;
    // The joint estimate's rotation and x, y; its tz is stage 2's (stage 3 comes after).
    const Iso3 joint = r.trajectory.outcome.ok() ? r.trajectory.T_ins_lidar : refined;
    run.rough = abs_error(r.rough.T_ins_lidar, gt);
    run.refined = abs_error(refined, gt);
    run.joint = abs_error(joint, gt);
    run.final = abs_error(r.T_ins_lidar, gt);
    run.yaw_refined_deg = signed_yaw_deg(refined, gt);
    run.yaw_joint_deg = signed_yaw_deg(joint, gt);
    run.corrected = r.trajectory.applied;
    run.correction_rms_mm = 1e3 * r.trajectory.correction_rms_m;
    if (r.trajectory.cost_ins_rms_m > 0.0)
      run.thinner_pct = 100.0 * (1.0 - r.trajectory.cost_corrected_rms_m / r.trajectory.cost_ins_rms_m);
    run.correction_err_mm = 1e3 * correction_error_m(*world, r.trajectory, t_ins);
    run.joint_stddev = r.trajectory.outcome.stddev;
    run.joint_stddev.tail<3>() *= kDegPerRad;
    run.time_offset_err_s = std::abs(r.time_offset_s - scenario.sim.time_offset_s);
    run.seconds_total = r.wall_time_s;
    run.warnings = r.warnings;
    run.ok = true;
  } catch (const std::exception& e) {
    run.message = e.what();
  }
  return run;
}

void print_run(const RunResult& run, bool verbose) {
  if (!run.ok) {
    fmt::print(stderr, "seed {:>3}: FAIL  {}\n", run.seed, run.message);
    return;
  }
  const auto& f = run.final;
  fmt::print(stderr, "seed {:>3}: ok    final |t| {:.4f} {:.4f} {:.4f} m  |rpy| {:.4f} {:.4f} {:.4f} deg  dt_off {:.4f} s  "
             "{:.1f} s (rendering included)\n", run.seed, f[0], f[1], f[2], f[3], f[4], f[5], run.time_offset_err_s,
             run.seconds_total);
  fmt::print(stderr, "          INS as truth |t| {:.4f} {:.4f} m |rpy| {:.4f} {:.4f} {:.4f}; corrected INS |t| {:.4f} {:.4f} m "
             "|rpy| {:.4f} {:.4f} {:.4f}; correction {:.1f} mm RMS, planes {:.1f}% thinner, {}\n",
             run.refined[0], run.refined[1], run.refined[3], run.refined[4], run.refined[5], run.joint[0], run.joint[1],
             run.joint[3], run.joint[4], run.joint[5], run.correction_rms_mm, run.thinner_pct,
             run.corrected ? "applied" : "not applied");
  fmt::print(stderr, "          signed yaw: INS as truth {:+.4f}, corrected {:+.4f}, floor (-mean INS heading error) {:+.4f} deg; "
             "correction off the truth by {:.1f} mm RMS\n",
             run.yaw_refined_deg, run.yaw_joint_deg, run.yaw_floor_deg, run.correction_err_mm);
  if (verbose)
    for (const std::string& w : run.warnings) fmt::print(stderr, "          warning: {}\n", w);
  const Vec6& sd = run.joint_stddev;
  fmt::print(stderr, "          joint stddev: t {:.2f} {:.2f} mm, rpy {:.4f} {:.4f} {:.4f} deg\n", 1e3 * sd[0], 1e3 * sd[1],
             sd[3], sd[4], sd[5]);
}

void print_row(const char* label, const Vec6& v) {
  fmt::print("| {:<31} | {:>8.4f} | {:>8.4f} | {:>8.4f} | {:>8.4f} | {:>8.4f} | {:>8.4f} |\n", label, v[0], v[1], v[2],
             v[3], v[4], v[5]);
}

struct Summary {
  int ok = 0, converged = 0;
  Vec6 mae_rough = Vec6::Zero(), mae_refined = Vec6::Zero(), mae_joint = Vec6::Zero(), mae_final = Vec6::Zero();
  Vec6 worst_rough = Vec6::Zero(), worst_refined = Vec6::Zero(), worst_joint = Vec6::Zero(), worst = Vec6::Zero();
  double mae_offset = 0.0, worst_offset = 0.0;
  double floor_mae = 0.0, beyond_refined = 0.0, beyond_joint = 0.0, worst_beyond_joint = 0.0;
  int corrected = 0;
};

Summary summarise(const std::vector<RunResult>& runs) {
  Summary s;
  for (const RunResult& r : runs) {
    if (!r.ok) continue;
    ++s.ok;
    s.mae_rough += r.rough, s.mae_refined += r.refined, s.mae_joint += r.joint, s.mae_final += r.final;
    s.worst_rough = s.worst_rough.cwiseMax(r.rough);
    s.worst_refined = s.worst_refined.cwiseMax(r.refined);
    s.worst_joint = s.worst_joint.cwiseMax(r.joint);
    s.worst = s.worst.cwiseMax(r.final);
    s.mae_offset += r.time_offset_err_s;
    s.worst_offset = std::max(s.worst_offset, r.time_offset_err_s);
    s.floor_mae += std::abs(r.yaw_floor_deg);
    s.beyond_refined += std::abs(r.yaw_refined_deg - r.yaw_floor_deg);
    s.beyond_joint += std::abs(r.yaw_joint_deg - r.yaw_floor_deg);
    s.worst_beyond_joint = std::max(s.worst_beyond_joint, std::abs(r.yaw_joint_deg - r.yaw_floor_deg));
    s.corrected += r.corrected ? 1 : 0;
    if (r.final.tail<3>().maxCoeff() <= 0.2 && r.final.head<2>().maxCoeff() <= 0.03) ++s.converged;
  }
  if (s.ok > 0) {
    const double n = s.ok;
    s.mae_rough /= n, s.mae_refined /= n, s.mae_joint /= n, s.mae_final /= n;
    s.mae_offset /= n, s.floor_mae /= n, s.beyond_refined /= n, s.beyond_joint /= n;
  }
  return s;
}

// Prints the table; returns whether every stage bound is met (the exit status).
bool print_summary(const Summary& s, const Options& o, int seeds, std::uint64_t first_seed, std::size_t runs) {
  fmt::print("\nScenario: {}{}, {} seeds from {}, azimuth step {} deg, duration {}\n", o.scenario,
             o.no_init ? ", no initial guess" : "", seeds, first_seed, o.azimuth_step_deg,
             o.duration_s > 0 ? fmt::format("{} s", o.duration_s) : std::string("full"));
  fmt::print("Mean absolute error (m, m, m, deg, deg, deg)\n\n");
  fmt::print("| {:<31} | {:>8} | {:>8} | {:>8} | {:>8} | {:>8} | {:>8} |\n", "stage", "tx", "ty", "tz", "roll", "pitch",
             "yaw");
  fmt::print("|{:-<33}|{:->10}|{:->10}|{:->10}|{:->10}|{:->10}|{:->10}|\n", "", "", "", "", "", "", "");
  // The paper's figures as the project brief quotes them (Yan et al. 2022): stage 1 reaches about
  // 0.2 deg / 0.03 m (a bound, not a mean; NaN: not quoted); all stages: the MAE of its Table II.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  Vec6 paper_rough, paper_z;
  paper_rough << 0.03, 0.03, nan, 0.2, 0.2, 0.2;
  paper_z << 0.007, 0.008, 0.012, 0.003, 0.034, 0.075;
  print_row("paper: rough (bound)", paper_rough);
  print_row("paper: all stages", paper_z);
  print_row("insalign: rough", s.mae_rough);
  print_row("insalign: refined (INS as truth)", s.mae_refined);
  print_row("insalign: joint (INS corrected)", s.mae_joint);
  print_row("insalign: z-corrected (final)", s.mae_final);
  print_row("insalign: worst rough", s.worst_rough);
  print_row("insalign: worst refined", s.worst_refined);
  print_row("insalign: worst joint", s.worst_joint);
  print_row("insalign: worst final", s.worst);
  fmt::print("\nruns finished: {}/{}; converged (final within 0.2 deg per axis and 3 cm in x, y): {}/{}; "
             "INS trajectory correction applied on {}/{}\n", s.ok, runs, s.converged, runs, s.corrected, s.ok);
  fmt::print("time offset error: mean {:.2f} ms, worst {:.2f} ms\n", 1e3 * s.mae_offset, 1e3 * s.worst_offset);
  fmt::print("yaw floor (|mean INS heading error|): mean {:.4f} deg; yaw error beyond it: INS as truth {:.4f}, "
             "corrected {:.4f} (worst {:.4f}) deg\n", s.floor_mae, s.beyond_refined, s.beyond_joint, s.worst_beyond_joint);
  // The stage issues' bounds (tz: fiducials; its floor is the INS's own height error, see README).
  auto verdict = [](bool met) { return met ? "met" : "MISSED"; };
  const bool refine_mae = s.mae_refined.tail<3>().maxCoeff() <= 0.01 && s.mae_refined.head<2>().maxCoeff() <= 0.005;
  const bool refine_worst = s.worst_refined.tail<3>().maxCoeff() <= 0.03 && s.worst_refined.head<2>().maxCoeff() <= 0.01;
  const bool refine_better = s.mae_refined.tail<3>().sum() <= s.mae_rough.tail<3>().sum() &&
                             s.mae_refined.head<2>().sum() <= s.mae_rough.head<2>().sum();
  fmt::print("stage 2 bounds: MAE <= 0.01 deg and 5 mm {}; every run <= 0.03 deg and 1 cm {}; better than stage 1 "
             "on average (sum of rotation MAEs, of x+y MAEs) {}\n",
             verdict(refine_mae), verdict(refine_worst), verdict(refine_better));
  fmt::print("stage 3 bounds: tz MAE <= 1 cm {}; every run <= 2 cm {}\n", verdict(s.mae_final[2] <= 0.01),
             verdict(s.worst[2] <= 0.02));
  fmt::print("issue 17 item 1 (corrected): every run within 0.01 deg {}, x and y within 5 mm {}\n",
             verdict(s.worst_joint.tail<3>().maxCoeff() <= 0.01), verdict(s.worst_joint.head<2>().maxCoeff() <= 0.005));
  return refine_mae && refine_worst && s.mae_final[2] <= 0.01 && s.worst[2] <= 0.02 &&
         s.converged == static_cast<int>(runs);
}

}  // namespace
}  // namespace insalign

int main(int argc, char** argv) {
  using namespace insalign;
  CLI::App app{"insalign accuracy benchmark (paper Table II layout)"};
  int seeds = 30;
  std::uint64_t first_seed = 1;
  Options o;
  app.add_option("--seeds", seeds, "number of simulated drives")->capture_default_str();
  app.add_option("--first-seed", first_seed)->capture_default_str();
  app.add_option("--scenario", o.scenario, "see bench/scenarios.hpp")->capture_default_str();
  app.add_option("--trajectory", o.trajectory_file, "pose file for the recorded-trajectory scenarios")
      ->default_str("../shared/data/opencalib-sample/NovAtel-pose-lidar-time.txt");
  app.add_option("--azimuth-step-deg", o.azimuth_step_deg)->capture_default_str();
  app.add_option("--duration-s", o.duration_s, "truncate drives (0: full)")->capture_default_str();
  app.add_flag("--fixed-time-offset", o.fixed_offset, "stage 2 keeps the time offset at 0 (clocks known to be synchronised)");
  app.add_flag("--verbose", o.verbose, "print every run's warnings");
  app.add_flag("--no-init", o.no_init, "drop the initial guess (combines with any scenario)");
  std::vector<std::string> assignments;
  app.add_option("--set", assignments, "override a parameter, e.g. refine.max_frames=240 or sim.ins_noise_scale=0 "
                                       "(keys: insalign config --dump)");
  CLI11_PARSE(app, argc, argv);
  cli::ToolConfig tool;
  try {
    tool = cli::tool_config_with(assignments);
    if (o.trajectory_file.empty()) o.trajectory_file = "../shared/data/opencalib-sample/NovAtel-pose-lidar-time.txt";
    bench::make_scenario(o.scenario, tool.sim, first_seed, o.trajectory_file);  // checks the name and the file
  } catch (const std::exception& e) {
    fmt::print(stderr, "{}\n", e.what());
    return 2;
  }
  std::vector<RunResult> runs;
  for (int s = 0; s < seeds; ++s) {
    runs.push_back(run_one(tool, o, first_seed + static_cast<std::uint64_t>(s)));
    print_run(runs.back(), o.verbose);
  }
  const bool met = print_summary(summarise(runs), o, seeds, first_seed, runs.size());
  struct rusage usage {};
  getrusage(RUSAGE_SELF, &usage);
  fmt::print("peak RSS of this benchmark process: {:.0f} MB\n", usage.ru_maxrss / 1024.0);
  return met ? 0 : 1;  // 0 only when every run converged and every stage bound is met (CI and scripts)
}
