// INS errors and honest uncertainty (issue 17, items 1 and 6), two studies on simulated drives.
//
// drift: along the recorded NovAtel trajectory, each seed twice: perfect poses (no INS error at
//   all) and a drifting INS (position random walk only: drift_heading_deg_per_sqrt_s = 0, because
//   a heading error is an extrinsic yaw error no method separates). For the drifting drive it
//   prints the extrinsic with the INS taken as truth (stage 2), the joint estimate (INS
//   trajectory corrected, whether or not the pipeline applied it) and the final result.
// coverage: the scenarios of bench/scenarios.hpp (default pipeline, repeatability included), per
//   degree of freedom the fraction of runs whose error is within 3 reported standard deviations
//   (a DOF the run reports undetermined counts as covered and is tallied apart; see Coverage).
// modes: per scenario, the trajectory correction's modes side by side on the same drives: perfect
//   poses (the method's own floor on that drive: no INS error at all), `off`, `auto` and the
//   default (`if-drifting`); MAE and worst per DOF, how often the correction was applied, time.
//
//   build/bench/ins_robustness --study drift --seeds 10 [--azimuth-step-deg 0.4] [--vertical-walk 0]
//       [--horizontal-walk 0] [--noise-floor]
//   build/bench/ins_robustness --study coverage --seeds 3 --azimuth-step-deg 0.8 --duration-s 75
//       [--scenarios default,drift,...]
//   build/bench/ins_robustness --study modes --seeds 3 --azimuth-step-deg 0.8 --duration-s 75
//       --scenarios default,recorded,drift-position,drift,float,wrong-fix,outage,traffic
// Skips (exit 0) when the recorded trajectory file is missing.
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <array>
#include <chrono>
#include <filesystem>
#include <memory>
#include <optional>
#include <sstream>

#include "scenarios.hpp"
#include "tool/tool_config.hpp"
#include "core/pipeline.hpp"
#include "sim/world_dataset.hpp"

namespace insalign {
namespace {

struct Options {
  std::string study = "drift";
  std::string trajectory_file = "/work/shared/data/opencalib-sample/NovAtel-pose-lidar-time.txt";
  std::string scenarios =
      "default,recorded,drift,float,wrong-fix,outage,traffic,no-fiducials,no-fiducials-perfect,hdl32,os1-64,vlp16,"
      "livox-avia";
  double azimuth_step_deg = 0.4;
  double duration_s = 0.0;           ///< drives on the simulator's own trajectory (0: full)
  double recorded_duration_s = 0.0;  ///< coverage: drives along the recorded trajectory (0: full, 108 s)
  /// The INS states no accuracy (as a TUM or OpenCalib pose file): if-drifting decides from the LiDAR.
  bool no_stated_quality = false;
  double vertical_walk_m_per_sqrt_s = 0.005;    ///< drift study: the INS's vertical random walk
  double horizontal_walk_m_per_sqrt_s = 0.005;  ///< drift study: the INS's horizontal random walk
  bool noise_floor = false;                     ///< drift study: also the same INS without its walk
};

// Absolute errors [tx ty tz (m), roll pitch yaw (deg)].
Vec6 abs_error(const Iso3& est, const Iso3& gt) {
  const ExtrinsicError e = extrinsic_error(est, gt);
  Vec6 v;
  v << e.dt_m, e.drpy_deg;
  return v;
}

struct Calibrated {
  bool ok = false;
  std::string message;
  CalibrationResult r;
  std::shared_ptr<const sim::World> world;
};

Calibrated calibrate(const sim::SimConfig& sim_config, bool use_init, const PipelineConfig& pipeline,
                     bool no_stated_quality) {
  Calibrated c;
  c.world = std::make_shared<const sim::World>(sim::build_world(sim_config));
  Dataset data = sim::world_dataset(c.world);
  if (!use_init) data.T_ins_lidar_init.reset();
  if (no_stated_quality) data.ins_quality.clear();
  try {
    const FrameStore store = make_frame_store(data, pipeline);
    c.r = run_calibration(store, pipeline);
    c.ok = true;
  } catch (const std::exception& e) {
    c.message = e.what();
  }
  return c;
}

void print_row(const std::string& label, const Vec6& v) {
  fmt::print("| {:<34} | {:>6.2f} | {:>6.2f} | {:>7.1f} | {:>7.4f} | {:>7.4f} | {:>7.4f} |\n", label, 1e3 * v[0],
             1e3 * v[1], 1e3 * v[2], v[3], v[4], v[5]);
}

std::vector<std::string> split(const std::string& list) {
  std::vector<std::string> out;
  std::stringstream ss(list);
  for (std::string item; std::getline(ss, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

// ---- drift ---------------------------------------------------------------------------------

struct DriftRun {
  Vec6 perfect = Vec6::Zero(), ins_truth = Vec6::Zero(), joint = Vec6::Zero(), final = Vec6::Zero();
  Vec6 noise_default = Vec6::Zero(), noise_corrected = Vec6::Zero();  // --noise-floor: the INS without its walk
  bool applied = false;
  double correction_rms_mm = 0.0;
};

int drift_study(const cli::ToolConfig& tool, const Options& o, int seeds, std::uint64_t first_seed) {
  PipelineConfig pipeline = tool.calibrate;
  pipeline.repeatability.segments = 0;  // the study is about the estimate, not its stddev
  std::vector<DriftRun> runs;
  for (int s = 0; s < seeds; ++s) {
    const std::uint64_t seed = first_seed + static_cast<std::uint64_t>(s);
    bench::ScenarioRun base = bench::make_scenario("recorded", tool.sim, seed, o.trajectory_file);
    base.sim.azimuth_step_deg = o.azimuth_step_deg;
    base.sim.duration_s = o.duration_s;
    sim::SimConfig perfect = base.sim;
    perfect.ins_noise_scale = 0.0;
    sim::SimConfig drift = base.sim;
    drift.ins_error.model = sim::InsErrorModel::kDrift;
    drift.ins_error.drift_heading_deg_per_sqrt_s = 0.0;
    drift.ins_error.drift_vertical_m_per_sqrt_s = o.vertical_walk_m_per_sqrt_s;
    drift.ins_error.drift_horizontal_m_per_sqrt_s = o.horizontal_walk_m_per_sqrt_s;
    const auto t0 = std::chrono::steady_clock::now();
    const Calibrated p = calibrate(perfect, true, pipeline, o.no_stated_quality);
    const Calibrated d = calibrate(drift, true, pipeline, o.no_stated_quality);
    if (!p.ok || !d.ok) {
      fmt::print(stderr, "seed {}: FAIL {} {}\n", seed, p.message, d.message);
      continue;
    }
    const Iso3& gt = d.world->T_ins_lidar_true;
    DriftRun run;
    run.perfect = abs_error(p.r.T_ins_lidar, p.world->T_ins_lidar_true);
    run.ins_truth = abs_error(d.r.refine ? d.r.refine->T_ins_lidar : d.r.rough.T_ins_lidar, gt);
    run.joint = abs_error(d.r.trajectory.outcome.ok() ? d.r.trajectory.T_ins_lidar : d.r.T_ins_lidar, gt);
    run.final = abs_error(d.r.T_ins_lidar, gt);
    run.applied = d.r.trajectory.applied;
    run.correction_rms_mm = 1e3 * d.r.trajectory.correction_rms_m;
    if (o.noise_floor) {
      // The same INS without its walk: what its white noise alone leaves, through the default
      // (stage 2: no drift stated) and through the correction forced on.
      sim::SimConfig noise = drift;
      noise.ins_error.drift_horizontal_m_per_sqrt_s = noise.ins_error.drift_vertical_m_per_sqrt_s = 0.0;
      PipelineConfig forced = pipeline;
      forced.trajectory.mode = TrajectoryCorrectionMode::kAlways;
      const Calibrated nd = calibrate(noise, true, pipeline, o.no_stated_quality);
      const Calibrated nc = calibrate(noise, true, forced, o.no_stated_quality);
      if (nd.ok) run.noise_default = abs_error(nd.r.T_ins_lidar, nd.world->T_ins_lidar_true);
      if (nc.ok) run.noise_corrected = abs_error(nc.r.T_ins_lidar, nc.world->T_ins_lidar_true);
    }
    runs.push_back(run);
    fmt::print(stderr,
               "seed {:>3}: perfect rpy {:.4f} {:.4f} {:.4f} xy {:.1f} {:.1f} mm | drift: INS as truth rpy {:.4f} {:.4f} "
               "{:.4f} xy {:.1f} {:.1f} | joint rpy {:.4f} {:.4f} {:.4f} xy {:.1f} {:.1f} | final tz {:.1f} mm | "
               "correction {:.1f} mm RMS, {:.0f}% thinner, {} | map offset median {:.1f} mm, perfect {:.1f} mm ({:.0f} s)\n",
               seed, run.perfect[3], run.perfect[4], run.perfect[5], 1e3 * run.perfect[0], 1e3 * run.perfect[1],
               run.ins_truth[3], run.ins_truth[4], run.ins_truth[5], 1e3 * run.ins_truth[0], 1e3 * run.ins_truth[1],
               run.joint[3], run.joint[4], run.joint[5], 1e3 * run.joint[0], 1e3 * run.joint[1], 1e3 * run.final[2],
               run.correction_rms_mm,
               d.r.trajectory.cost_ins_rms_m > 0.0 ? 100.0 * (1.0 - d.r.trajectory.cost_corrected_rms_m / d.r.trajectory.cost_ins_rms_m) : 0.0,
               run.applied ? "applied" : "not applied",
               1e3 * map_offset_median_m(d.r.ins_screen),
               1e3 * map_offset_median_m(p.r.ins_screen), std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  if (runs.empty()) return 1;
  Vec6 mae_p = Vec6::Zero(), mae_i = Vec6::Zero(), mae_j = Vec6::Zero(), mae_f = Vec6::Zero();
  Vec6 mae_nd = Vec6::Zero(), mae_nc = Vec6::Zero();
  Vec6 worst_p = Vec6::Zero(), worst_i = Vec6::Zero(), worst_j = Vec6::Zero(), worst_f = Vec6::Zero();
  int applied = 0;
  for (const DriftRun& r : runs) {
    mae_p += r.perfect, mae_i += r.ins_truth, mae_j += r.joint, mae_f += r.final;
    mae_nd += r.noise_default, mae_nc += r.noise_corrected;
    worst_p = worst_p.cwiseMax(r.perfect), worst_i = worst_i.cwiseMax(r.ins_truth);
    worst_j = worst_j.cwiseMax(r.joint), worst_f = worst_f.cwiseMax(r.final);
    applied += r.applied;
  }
  const double n = static_cast<double>(runs.size());
  mae_p /= n, mae_i /= n, mae_j /= n, mae_f /= n, mae_nd /= n, mae_nc /= n;
  fmt::print("\nRecorded NovAtel trajectory, {} seeds from {}, azimuth step {} deg; drifting INS: position random walk "
             "{} mm/sqrt(s) per horizontal axis, {} vertical, heading drift 0; trajectory.mode {}; correction applied on {}/{}\n",
             runs.size(), first_seed, o.azimuth_step_deg, 1e3 * o.horizontal_walk_m_per_sqrt_s,
             1e3 * o.vertical_walk_m_per_sqrt_s,
             enum_name(pipeline.trajectory.mode), applied, runs.size());
  fmt::print("| {:<34} | {:>6} | {:>6} | {:>7} | {:>7} | {:>7} | {:>7} |\n", "(mm, mm, mm, deg, deg, deg)", "tx", "ty",
             "tz", "roll", "pitch", "yaw");
  fmt::print("|{:-<36}|{:->8}|{:->8}|{:->9}|{:->9}|{:->9}|{:->9}|\n", "", "", "", "", "", "", "");
  print_row("MAE perfect poses (final)", mae_p);
  print_row("MAE drift, INS as truth (stage 2)", mae_i);
  print_row("MAE drift, joint (INS corrected)", mae_j);
  print_row("MAE drift, final", mae_f);
  if (o.noise_floor) {
    print_row("MAE no walk, INS noise (default)", mae_nd);
    print_row("MAE no walk, INS noise (corrected)", mae_nc);
  }
  print_row("worst perfect poses", worst_p);
  print_row("worst drift, INS as truth", worst_i);
  print_row("worst drift, joint", worst_j);
  print_row("worst drift, final", worst_f);
  auto verdict = [](bool met) { return met ? "met" : "MISSED"; };
  const bool within_2x = (mae_f.tail<3>().array() <= 2.0 * mae_p.tail<3>().array()).all();
  fmt::print("\nissue 17 item 1 (final): rotation MAE within 2x perfect {}; every run within 0.01 deg {}; x and y within "
             "5 mm {}\n", verdict(within_2x), verdict(worst_f.tail<3>().maxCoeff() <= 0.01),
             verdict(worst_f.head<2>().maxCoeff() <= 0.005));
  return 0;
}

// ---- modes ---------------------------------------------------------------------------------

int modes_study(const cli::ToolConfig& tool, const Options& o, int seeds, std::uint64_t first_seed) {
  struct Arm {
    std::string label;
    bool perfect = false;
    std::optional<TrajectoryCorrectionMode> mode;  ///< none: the configuration's (the default)
  };
  const std::vector<Arm> arms = {{"perfect poses", true, TrajectoryCorrectionMode::kOff},
                                 {"off", false, TrajectoryCorrectionMode::kOff},
                                 {"auto", false, TrajectoryCorrectionMode::kAuto},
                                 {fmt::format("default ({})", enum_name(tool.calibrate.trajectory.mode)), false, {}}};
  struct Tally {
    Vec6 sum = Vec6::Zero(), worst = Vec6::Zero();
    int runs = 0, failed = 0, applied = 0;
    double wall_s = 0.0;
  };
  const std::vector<std::string> names = split(o.scenarios);
  std::vector<std::vector<Tally>> tallies(names.size(), std::vector<Tally>(arms.size()));
  for (int s = 0; s < seeds; ++s) {  // seed-major, as coverage
    const std::uint64_t seed = first_seed + static_cast<std::uint64_t>(s);
    for (std::size_t n = 0; n < names.size(); ++n) {
      bench::ScenarioRun sc = bench::make_scenario(names[n], tool.sim, seed, o.trajectory_file);
      sc.sim.azimuth_step_deg = o.azimuth_step_deg;
      sc.sim.duration_s = sc.recorded ? o.recorded_duration_s : o.duration_s;
      for (std::size_t a = 0; a < arms.size(); ++a) {
        sim::SimConfig sim = sc.sim;
        if (arms[a].perfect) sim.ins_error = sim::InsErrorConfig{}, sim.ins_noise_scale = 0.0;
        PipelineConfig pipeline = tool.calibrate;
        pipeline.repeatability.segments = 0;  // the estimate, not its stddev
        if (arms[a].mode) pipeline.trajectory.mode = *arms[a].mode;
        const auto t0 = std::chrono::steady_clock::now();
        const Calibrated c = calibrate(sim, sc.use_init, pipeline, o.no_stated_quality);
        Tally& t = tallies[n][a];
        if (!c.ok) {
          ++t.failed;
          fmt::print(stderr, "RUN {} seed {} {}: FAIL {}\n", names[n], seed, arms[a].label, c.message);
          continue;
        }
        const Vec6 err = abs_error(c.r.T_ins_lidar, c.world->T_ins_lidar_true);
        ++t.runs, t.applied += c.r.trajectory.applied, t.sum += err, t.worst = t.worst.cwiseMax(err);
        t.wall_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        fmt::print(stderr, "RUN {} seed {} {}: xyz {:.1f} {:.1f} {:.1f} mm rpy {:.4f} {:.4f} {:.4f} deg | {}\n", names[n], seed,
                   arms[a].label, 1e3 * err[0], 1e3 * err[1], 1e3 * err[2], err[3], err[4], err[5],
                   c.r.trajectory.decision.empty() ? "no correction estimated" : c.r.trajectory.decision);
      }
    }
  }
  fmt::print("\nThe trajectory correction's modes side by side, {} seeds from {} per scenario, azimuth step {} deg, "
             "stage 2's estimate (no repeatability segments); MAE (worst): x, y, z mm, roll, pitch, yaw deg\n\n",
             seeds, first_seed, o.azimuth_step_deg);
  fmt::print("| scenario | arm | runs | applied | x | y | z | roll | pitch | yaw | s per run |\n");
  fmt::print("|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (std::size_t n = 0; n < names.size(); ++n)
    for (std::size_t a = 0; a < arms.size(); ++a) {
      const Tally& t = tallies[n][a];
      if (t.runs == 0) continue;
      const Vec6 mae = t.sum / t.runs;
      std::string cells;
      for (int i = 0; i < 6; ++i)
        cells += i < 3 ? fmt::format(" {:.1f} ({:.1f}) |", 1e3 * mae[i], 1e3 * t.worst[i])
                       : fmt::format(" {:.4f} ({:.4f}) |", mae[i], t.worst[i]);
      fmt::print("| {} | {} | {}{} | {} |{} {:.1f} |\n", names[n], arms[a].label, t.runs,
                 t.failed ? fmt::format("+{}F", t.failed) : "", t.applied, cells, t.wall_s / t.runs);
    }
  return 0;
}

// ---- coverage ------------------------------------------------------------------------------

// How a DOF of one run counts: covered when the error is within 3 reported stddev; a DOF the run
// reports undetermined (determined false) counts as covered, since the tool said not to trust it
// (tallied apart, "u"); an infinite stddev on a DOF reported determined counts as not covered.
struct Coverage {
  std::array<int, 6> within{}, counted{}, undetermined{};
  int runs = 0, failed = 0;
  void add(const Vec6& err, const Vec6& sd, const std::array<bool, 6>& determined) {
    ++runs;
    for (std::size_t i = 0; i < 6; ++i) {
      ++counted[i];
      if (!determined[i]) {
        ++undetermined[i], ++within[i];
        continue;
      }
      within[i] += std::isfinite(sd[static_cast<int>(i)]) && err[static_cast<int>(i)] <= 3.0 * sd[static_cast<int>(i)];
    }
  }
  void add(const Coverage& o) {
    for (std::size_t i = 0; i < 6; ++i)
      within[i] += o.within[i], counted[i] += o.counted[i], undetermined[i] += o.undetermined[i];
    runs += o.runs, failed += o.failed;
  }
  std::string cell(std::size_t i) const {
    if (!counted[i]) return "-";
    return undetermined[i] ? fmt::format("{}/{} ({}u)", within[i], counted[i], undetermined[i])
                           : fmt::format("{}/{}", within[i], counted[i]);
  }
};

// One run's line: error, 3 sd and error / sd per DOF (mm, deg; "u": reported undetermined).
void print_coverage_run(const std::string& name, std::uint64_t seed, const Vec6& err, const Vec6& sd,
                        const CalibrationResult& r, double wall_s) {
  std::string cells;
  for (int i = 0; i < 6; ++i) {
    const double k = i < 3 ? 1e3 : 1.0;
    cells += fmt::format(" {}={:.4g}/{:.4g}({}{:.2f})", std::array{"tx", "ty", "tz", "roll", "pitch", "yaw"}[i],
                         k * err[i], 3 * k * sd[i], r.determined[static_cast<std::size_t>(i)] ? "" : "u",
                         err[i] / sd[i]);
  }
  // The parts of the stddev (mm, deg, 1 sigma): stage 2's formal one, the segments' and tz's share.
  const Vec6 formal = r.trajectory.applied ? r.trajectory.outcome.stddev
                                           : (r.refine ? r.refine->outcome.stddev : r.rough.outcome.stddev);
  const Vec6& seg = r.repeatability.stddev_whole_drive;
  std::string parts;
  for (int i : {0, 1, 3, 4, 5}) {
    const double k = i < 3 ? 1e3 : kDegPerRad;
    parts += fmt::format(" {:.4g}/{:.4g}", k * formal[i], k * seg[i]);
  }
  fmt::print(stderr,
             "RUN {} seed {}:{} | formal/segments{} ({} segments) | tz_coupling {} dxy/dtz {:.4f} {:.4f} added {:.3g} "
             "{:.3g} mm, rpy {:.2g} {:.2g} {:.2g} deg | map offset median {:.1f} mm | correction {} ({}) | left out {:.1f} s | "
             "{:.0f} s\n",
             name, seed, cells, parts, r.repeatability.segments_ok, r.tz_coupling.ok ? "on" : "off",
             r.tz_coupling.dxy_dtz.x(), r.tz_coupling.dxy_dtz.y(), 1e3 * r.tz_coupling.stddev_added_m.x(),
             1e3 * r.tz_coupling.stddev_added_m.y(), kDegPerRad * r.tz_coupling.rpy_stddev_added_rad.x(),
             kDegPerRad * r.tz_coupling.rpy_stddev_added_rad.y(), kDegPerRad * r.tz_coupling.rpy_stddev_added_rad.z(),
             1e3 * map_offset_median_m(r.ins_screen), r.trajectory.applied ? "applied" : "not applied", r.trajectory.decision,
             spans_duration_s(r.excluded), wall_s);
}

int coverage_study(const cli::ToolConfig& tool, const Options& o, int seeds, std::uint64_t first_seed) {
  const std::vector<std::string> names = split(o.scenarios);
  std::vector<Coverage> rows(names.size());
  // Seed-major, so that a study cut short has every scenario at about the same seed count.
  for (int s = 0; s < seeds; ++s) {
    const std::uint64_t seed = first_seed + static_cast<std::uint64_t>(s);
    for (std::size_t n = 0; n < names.size(); ++n) {
      bench::ScenarioRun sc = bench::make_scenario(names[n], tool.sim, seed, o.trajectory_file);
      sc.sim.azimuth_step_deg = o.azimuth_step_deg;
      sc.sim.duration_s = sc.recorded ? o.recorded_duration_s : o.duration_s;
      const auto t0 = std::chrono::steady_clock::now();
      const Calibrated c = calibrate(sc.sim, sc.use_init, tool.calibrate, o.no_stated_quality);
      if (!c.ok) {
        ++rows[n].failed;
        fmt::print(stderr, "RUN {} seed {}: FAIL {}\n", names[n], seed, c.message);
        continue;
      }
      const Vec6 err = abs_error(c.r.T_ins_lidar, c.world->T_ins_lidar_true);
      Vec6 sd = c.r.stddev;
      sd.tail<3>() *= kDegPerRad;
      rows[n].add(err, sd, c.r.determined);
      print_coverage_run(names[n], seed, err, sd, c.r,
                         std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
  }
  Coverage all;
  for (const Coverage& c : rows) all.add(c);
  fmt::print("\nRuns whose error is within 3 reported standard deviations, per DOF ({} seeds from {} per scenario, "
             "azimuth step {} deg; (Nu): N of them reported undetermined, counted as covered)\n\n", seeds, first_seed,
             o.azimuth_step_deg);
  fmt::print("| {:<20} | {:>4} | {:>9} | {:>9} | {:>9} | {:>9} | {:>9} | {:>9} |\n", "scenario", "runs", "tx", "ty",
             "tz", "roll", "pitch", "yaw");
  fmt::print("|{:-<22}|{:->6}|{:->11}|{:->11}|{:->11}|{:->11}|{:->11}|{:->11}|\n", "", "", "", "", "", "", "", "");
  auto row = [](const std::string& name, const Coverage& c) {
    fmt::print("| {:<20} | {:>4} | {:>9} | {:>9} | {:>9} | {:>9} | {:>9} | {:>9} |\n", name,
               c.failed ? fmt::format("{}+{}F", c.runs, c.failed) : fmt::format("{}", c.runs), c.cell(0), c.cell(1),
               c.cell(2), c.cell(3), c.cell(4), c.cell(5));
  };
  for (std::size_t n = 0; n < names.size(); ++n) row(names[n], rows[n]);
  row("all", all);
  int within = 0, counted = 0;
  double worst_dof = 1.0;
  for (std::size_t i = 0; i < 6; ++i) {
    within += all.within[i], counted += all.counted[i];
    if (all.counted[i]) worst_dof = std::min(worst_dof, double(all.within[i]) / all.counted[i]);
  }
  fmt::print("\noverall {}/{} = {:.1f}% (target >= 95%); worst DOF {:.1f}% (target >= 90%); failed runs {}\n", within,
             counted, counted ? 100.0 * within / counted : 0.0, 100.0 * worst_dof, all.failed);
  return 0;
}

}  // namespace
}  // namespace insalign

int main(int argc, char** argv) {
  using namespace insalign;
  CLI::App app{"insalign: INS drift correction and honest uncertainty over the simulated scenarios"};
  int seeds = 10;
  std::uint64_t first_seed = 1;
  Options o;
  app.add_option("--study", o.study, "drift, coverage or modes")->capture_default_str();
  app.add_option("--seeds", seeds)->capture_default_str();
  app.add_option("--first-seed", first_seed)->capture_default_str();
  app.add_option("--trajectory", o.trajectory_file, "recorded pose file")->capture_default_str();
  app.add_option("--scenarios", o.scenarios, "coverage: comma-separated scenario names")->capture_default_str();
  app.add_option("--azimuth-step-deg", o.azimuth_step_deg)->capture_default_str();
  app.add_option("--duration-s", o.duration_s, "truncate drives (0: full; coverage: the figure-8 ones)")
      ->capture_default_str();
  app.add_option("--recorded-duration-s", o.recorded_duration_s,
                 "coverage: truncate drives along the recorded trajectory (0: full)")
      ->capture_default_str();
  app.add_flag("--no-stated-quality", o.no_stated_quality,
               "the INS states no accuracy (as a TUM or OpenCalib pose file): if-drifting decides from the LiDAR");
  app.add_option("--vertical-walk", o.vertical_walk_m_per_sqrt_s,
                 "drift study: the INS's vertical position random walk, m/sqrt(s)")
      ->capture_default_str();
  app.add_option("--horizontal-walk", o.horizontal_walk_m_per_sqrt_s,
                 "drift study: the INS's horizontal position random walk per axis, m/sqrt(s) (0 and "
                 "--vertical-walk 0: the INS's white noise alone)")
      ->capture_default_str();
  app.add_flag("--noise-floor", o.noise_floor,
               "drift study: also run each seed's INS without its walk (its white noise alone), through the "
               "default and with the correction forced on");
  std::vector<std::string> assignments;
  app.add_option("--set", assignments, "override a parameter (keys: insalign config --dump)");
  CLI11_PARSE(app, argc, argv);
  if (!std::filesystem::exists(o.trajectory_file)) {
    fmt::print("skipped: the recorded trajectory {} is missing\n", o.trajectory_file);
    return 0;
  }
  cli::ToolConfig tool;
  try {
    tool = cli::tool_config_with(assignments);
  } catch (const std::exception& e) {
    fmt::print(stderr, "{}\n", e.what());
    return 2;
  }
  if (o.study == "drift") return drift_study(tool, o, seeds, first_seed);
  if (o.study == "coverage") return coverage_study(tool, o, seeds, first_seed);
  if (o.study == "modes") return modes_study(tool, o, seeds, first_seed);
  fmt::print(stderr, "unknown --study '{}' (drift, coverage or modes)\n", o.study);
  return 2;
}
