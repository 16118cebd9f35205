// Rig accuracy and speed: a four-LiDAR rig (roof Pandar64, left and right VLP-16 on the mirrors,
// front OS1-64 on the bumper) simulated per seed on the default scene and along the real recorded
// trajectory; every LiDAR's error against the truth jointly and alone, the LiDAR-to-LiDAR
// transforms against the truth in units of their stated stddev, the loop T_a_b T_b_c T_c_a, and
// the time of the rig against the roof LiDAR alone (cold: the simulator renders the sweeps as a
// loader would decode them; warm: the same stores again, sweeps cached: the calibration alone).
//
// Also each LiDAR's error in units of its stated stddev (the rig's honesty, as the coverage study
// counts it for one LiDAR).
//
//   build/bench/rig_accuracy --seeds 10 [--scene default|recorded|both|SCENARIO] [--azimuth-step-deg 0.2]
//     [--relative-tz 0|1] [--shared-stage3 0|1] [--ins-noise-scale S] [--no-alone] [--no-timing]
//     [--set KEY=VALUE ...]
// SCENARIO: any of bench/scenarios.hpp (drift-position: the INS walking 5 mm/sqrt(s), as the
// drift study's INS).
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <sys/resource.h>

#include <chrono>
#include <filesystem>

#include "core/errors.hpp"
#include "core/rig.hpp"
#include "scenarios.hpp"
#include "sim/world_dataset.hpp"
#include "tool/tool_config.hpp"

namespace insalign {
namespace {

constexpr const char* kRig = "top:pandar64,left:vlp16@left,right:vlp16@right,front:os1-64@front";

double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
// Process CPU seconds (both cores): on a shared machine a fairer ratio than wall time.
double cpu_s() {
  struct rusage u {};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_utime.tv_sec + u.ru_stime.tv_sec + 1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}
double peak_rss_mb() {
  struct rusage u {};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;
}

Vec6 error_vec(const Iso3& est, const Iso3& truth) {
  const ExtrinsicError e = extrinsic_error(est, truth);
  Vec6 v;
  v << e.dt_m, e.drpy_deg;
  return v;
}

bool within_target(const Vec6& e) { return e[0] <= 0.01 && e[1] <= 0.01 && e.tail<3>().maxCoeff() <= 0.03; }

struct SeedRun {
  std::vector<Vec6> joint, alone;   // per LiDAR |error| (m, deg); alone empty row = undetermined
  std::vector<Vec6> sigmas;         // per LiDAR |joint error| / stated stddev (NaN: no stddev)
  std::vector<bool> corrected;      // per LiDAR: the INS trajectory correction was applied
  std::vector<bool> alone_ok;
  double worst_sigma = 0.0;         // LiDAR-to-LiDAR error / stated stddev, worst DOF and pair
  std::string worst_pair;           // which pair and DOF, its error and stddev
  std::vector<double> own_z;        // per LiDAR |tz error| had it kept its own stage 3 (NaN: not replaced)
  std::string map_check;            // per LiDAR: how far the map check moved it and what it did
  double loop_m = 0.0, loop_deg = 0.0;
  double rig_cold_s = 0, rig_warm_s = 0, roof_cold_s = 0, roof_warm_s = 0;
  double rig_warm_cpu_s = 0, roof_warm_cpu_s = 0;
  std::vector<std::string> notes;
};

std::vector<FrameStore> stores_of(const std::vector<Dataset>& data, const PipelineConfig& config) {
  std::vector<FrameStore> out;
  for (const Dataset& d : data) out.push_back(make_frame_store(d, config));
  return out;
}

// The pairs against the truth (in units of the stated stddev) and the worst loop of three.
void check_pairs(const RigResult& rig, const sim::World& world, SeedRun& run) {
  for (const LidarPair& p : rig.pairs) {
    const Iso3 truth = world.lidars[p.a].T_ins_lidar_true.inverse() * world.lidars[p.b].T_ins_lidar_true;
    Vec6 e;
    e.head<3>() = p.T_a_b.translation() - truth.translation();
    e.tail<3>() = so3_log(p.T_a_b.linear() * truth.linear().transpose());
    for (int i = 0; i < 6; ++i) {
      if (!std::isfinite(p.stddev[i]) || !(p.stddev[i] > 0) || std::abs(e[i]) / p.stddev[i] <= run.worst_sigma) continue;
      run.worst_sigma = std::abs(e[i]) / p.stddev[i];
      const double unit = i < 3 ? 1e3 : kDegPerRad;
      run.worst_pair = fmt::format("{}__{} {}: error {:.4f}, stddev {:.4f} {}", rig.lidars[p.a].name, rig.lidars[p.b].name,
                                   kDofNames[i], unit * e[i], unit * p.stddev[i], i < 3 ? "mm" : "deg");
    }
  }
  const std::size_t n = rig.lidars.size();
  for (std::size_t a = 0; a < n; ++a)
    for (std::size_t b = a + 1; b < n; ++b)
      for (std::size_t c = b + 1; c < n; ++c) {
        const auto T = [&](std::size_t i) { return rig.lidars[i].result.T_ins_lidar; };
        const Iso3 loop = (T(a).inverse() * T(b)) * (T(b).inverse() * T(c)) * (T(c).inverse() * T(a));
        run.loop_m = std::max(run.loop_m, loop.translation().norm());
        run.loop_deg = std::max(run.loop_deg, so3_log(loop.linear()).norm() * kDegPerRad);
      }
}

struct Options {
  double azimuth_step_deg = 0.2, duration_s = 0.0;
  double ins_noise_scale = std::nan("");  // NaN: the scenario's (0: perfect poses)
  std::string trajectory;
  bool alone = true, timing = true;  // run the LiDARs alone; time warm runs and the roof alone
  PipelineConfig config;
};

SeedRun run_seed(const std::string& scene, std::uint64_t seed, const Options& o) {
  const double azimuth_step_deg = o.azimuth_step_deg, duration_s = o.duration_s;
  const std::string& trajectory = o.trajectory;
  sim::SimConfig base;
  base.azimuth_step_deg = azimuth_step_deg;
  base.duration_s = duration_s;
  bench::ScenarioRun scenario = bench::make_scenario(scene, base, seed, trajectory);
  scenario.sim.rig = kRig;
  if (std::isfinite(o.ins_noise_scale)) scenario.sim.ins_noise_scale = o.ins_noise_scale;
  const auto world = std::make_shared<const sim::World>(sim::build_world(scenario.sim));
  std::vector<Dataset> data;
  std::vector<std::string> names;
  for (std::size_t l = 0; l < world->lidars.size(); ++l) {
    data.push_back(sim::world_dataset(world, l));
    names.push_back(world->lidars[l].name);
  }
  const PipelineConfig& config = o.config;
  SeedRun run;
  std::vector<FrameStore> stores = stores_of(data, config);
  double t = now_s();
  const RigResult rig = run_rig_calibration(stores, names, config);
  run.rig_cold_s = now_s() - t;
  t = now_s();
  double c = cpu_s();
  if (o.timing) run_rig_calibration(stores, names, config);
  run.rig_warm_s = now_s() - t;
  run.rig_warm_cpu_s = cpu_s() - c;
  for (std::size_t l = 0; l < names.size(); ++l) {
    const CalibrationResult& r = rig.lidars[l].result;
    run.joint.push_back(error_vec(r.T_ins_lidar, world->lidars[l].T_ins_lidar_true));
    Vec6 sigmas;
    for (int i = 0; i < 6; ++i) {
      const double unit = i < 3 ? 1.0 : kDegPerRad;  // error_vec: m and deg; stddev: m and rad
      sigmas[i] = std::isfinite(r.stddev[i]) && r.stddev[i] > 0 ? run.joint.back()[i] / (unit * r.stddev[i]) : std::nan("");
    }
    run.sigmas.push_back(sigmas);
    run.corrected.push_back(r.trajectory.applied);
    run.own_z.push_back(std::abs(rig.lidars[l].own_stage3_tz_m - world->lidars[l].T_ins_lidar_true.translation().z()));
    if (rig.lidars[l].joint_with.empty()) run.notes.push_back(names[l] + ": " + rig.lidars[l].joint_note);
    const RigMapCheck& m = rig.lidars[l].map_check;
    if (!m.reference.empty())
      run.map_check += fmt::format(" {} {:.3f} deg {:.1f} mm, RMS {:.1f} -> {:.1f} mm{};", names[l], m.moved_rot_deg,
                                   1e3 * m.moved_xy_m, 1e3 * m.rms_before_m, 1e3 * m.rms_after_m,
                                   m.restarted ? " restarted" : (m.map_start ? " map-start" : ""));
  }
  check_pairs(rig, *world, run);

  // Alone: the same start and stage 1, stage 2 per LiDAR (what calibrating one at a time gives).
  PipelineConfig alone_config = config;
  alone_config.refine.joint.enabled = false;
  for (std::size_t l = 0; l < names.size(); ++l) {
    if (!o.alone) {
      run.alone.push_back(Vec6::Constant(std::nan("")));
      run.alone_ok.push_back(false);
      continue;
    }
    try {
      const std::vector<FrameStore> one = {stores[l]};
      const RigResult alone = run_rig_calibration(one, {names[l]}, alone_config);
      run.alone.push_back(error_vec(alone.lidars[0].result.T_ins_lidar, world->lidars[l].T_ins_lidar_true));
      run.alone_ok.push_back(true);
    } catch (const UnobservableError& e) {
      run.alone.push_back(Vec6::Constant(std::nan("")));
      run.alone_ok.push_back(false);
      run.notes.push_back(names[l] + " alone: " + e.what());
    }
  }
  // The roof LiDAR alone through run_calibration, on a store of its own (cold, then warm).
  if (!o.timing) return run;
  const FrameStore roof = make_frame_store(data[0], config);
  t = now_s();
  run_calibration(roof, config);
  run.roof_cold_s = now_s() - t;
  t = now_s();
  c = cpu_s();
  run_calibration(roof, config);
  run.roof_warm_s = now_s() - t;
  run.roof_warm_cpu_s = cpu_s() - c;
  return run;
}

void print_row(const std::string& label, const Vec6& e) {
  fmt::print("| {:<26} | {:>7.2f} | {:>7.2f} | {:>7.2f} | {:>7.4f} | {:>7.4f} | {:>7.4f} |\n", label, 1e3 * e[0],
             1e3 * e[1], 1e3 * e[2], e[3], e[4], e[5]);
}

void report(const std::string& scene, const std::vector<std::string>& names, const std::vector<SeedRun>& runs) {
  fmt::print("\n### {} ({} seeds)\n\n| {:<26} | {:>7} | {:>7} | {:>7} | {:>7} | {:>7} | {:>7} |\n", scene, runs.size(), "LiDAR, MAE (worst)",
             "x mm", "y mm", "z mm", "roll deg", "pitch", "yaw");
  fmt::print("|{:-<28}|{:-<9}|{:-<9}|{:-<9}|{:-<9}|{:-<9}|{:-<9}|\n", "", "", "", "", "", "", "");
  int within = 0, total = 0;
  for (std::size_t l = 0; l < names.size(); ++l) {
    for (const bool joint : {true, false}) {
      Vec6 mae = Vec6::Zero(), worst = Vec6::Zero();
      int n = 0, undetermined = 0;
      for (const SeedRun& r : runs) {
        const Vec6& e = joint ? r.joint[l] : r.alone[l];
        if (!joint && !r.alone_ok[l]) { ++undetermined; continue; }
        mae += e, worst = worst.cwiseMax(e), ++n;
        if (joint) within += within_target(e), ++total;
      }
      if (n > 0) mae /= n;
      const std::string label = names[l] + (joint ? " joint" : " alone") + (undetermined ? fmt::format(" ({} undet.)", undetermined) : "");
      print_row(label + " MAE", mae);
      print_row(label + " worst", worst);
    }
  }
  // Joint against alone per seed (alone minus joint |error|: positive = better jointly), with the
  // standard error of the mean: is a difference larger than the seeds' scatter?
  for (std::size_t l = 0; l < names.size(); ++l) {
    std::string line;
    for (int i = 3; i < 6; ++i) {
      std::vector<double> d;
      for (const SeedRun& r : runs)
        if (r.alone_ok[l]) d.push_back(r.alone[l][i] - r.joint[l][i]);
      if (d.size() < 2) continue;
      double mean = 0, var = 0;
      for (double x : d) mean += x / d.size();
      for (double x : d) var += (x - mean) * (x - mean) / (d.size() - 1);
      line += fmt::format(" {} {:+.4f} +- {:.4f}", kDofNames[i], mean, std::sqrt(var / d.size()));
    }
    if (!line.empty()) fmt::print("{} alone - joint |error|, deg (mean +- standard error):{}\n", names[l], line);
  }
  double sigma = 0, loop_m = 0, loop_deg = 0, rc = 0, rw = 0, oc = 0, ow = 0, rcpu = 0, ocpu = 0;
  for (const SeedRun& r : runs) {
    sigma = std::max(sigma, r.worst_sigma), loop_m = std::max(loop_m, r.loop_m), loop_deg = std::max(loop_deg, r.loop_deg);
    rc += r.rig_cold_s, rw += r.rig_warm_s, oc += r.roof_cold_s, ow += r.roof_warm_s;
    rcpu += r.rig_warm_cpu_s, ocpu += r.roof_warm_cpu_s;
    for (const std::string& n : r.notes) fmt::print("note: {}\n", n);
    fmt::print("worst pair: {:.2f} sigma, {}\n", r.worst_sigma, r.worst_pair);
  }
  const double n = static_cast<double>(runs.size());
  int honest = 0, stated = 0, corrected = 0;
  for (const SeedRun& r : runs)
    for (std::size_t l = 0; l < r.sigmas.size(); ++l) {
      corrected += r.corrected[l];
      for (int i = 0; i < 6; ++i)
        if (std::isfinite(r.sigmas[l][i])) honest += r.sigmas[l][i] <= 3.0, ++stated;
    }
  fmt::print("\nevery LiDAR within 0.03 deg per axis and 1 cm in x, y (joint): {} of {}\n", within, total);
  fmt::print("(LiDAR, DOF) errors within 3 stated stddev: {} of {}; INS trajectory correction applied for {} of {} LiDAR runs\n",
             honest, stated, corrected, total);
  fmt::print("LiDAR-to-LiDAR vs truth: worst |error| / stated stddev = {:.2f} (any pair, any DOF)\n", sigma);
  fmt::print("loop T_a_b T_b_c T_c_a: worst {:.2e} m, {:.2e} deg (identity by construction: every LiDAR is tied to the one INS)\n",
             loop_m, loop_deg);
  fmt::print("time per seed: rig cold {:.1f} s, warm {:.1f} s; roof alone cold {:.1f} s, warm {:.1f} s; ratio cold {:.2f}x, warm {:.2f}x\n",
             rc / n, rw / n, oc / n, ow / n, rc / oc, rw / ow);
  fmt::print("CPU per seed (warm): rig {:.1f} s, roof alone {:.1f} s, ratio {:.2f}x\n", rcpu / n, ocpu / n, rcpu / ocpu);
  fmt::print("peak memory so far {:.0f} MB\n", peak_rss_mb());
  std::fflush(stdout);
}

}  // namespace
}  // namespace insalign

int main(int argc, char** argv) {
  using namespace insalign;
  CLI::App app{"rig accuracy and speed"};
  int seeds = 10, first_seed = 1;
  std::string scene = "both";
  Options o;
  o.trajectory = "../shared/data/opencalib-sample/NovAtel-pose-lidar-time.txt";
  bool no_alone = false, no_timing = false;
  std::vector<std::string> assignments;
  app.add_option("--seeds", seeds, "seeds per scene");
  app.add_option("--first-seed", first_seed, "first seed");
  app.add_option("--scene", scene, "default, recorded, both or another scenario of bench/scenarios.hpp (drift-position, ...)");
  app.add_option("--trajectory", o.trajectory, "pose file of the recorded trajectory");
  app.add_option("--azimuth-step-deg", o.azimuth_step_deg, "simulator horizontal resolution");
  app.add_option("--duration-s", o.duration_s, "drive length (0: the trajectory's, ~1000 frames)");
  app.add_option("--relative-tz", o.config.refine.joint.relative_tz, "joint stage 2 moves the members' tz but the anchor's (refine.joint.relative_tz)");
  app.add_option("--shared-stage3", o.config.refine.joint.shared_stage3, "the anchor's stage-3 change moves every member (refine.joint.shared_stage3)");
  app.add_option("--ins-noise-scale", o.ins_noise_scale, "INS noise scale of the simulator (default: the scenario's; 0: perfect poses)");
  app.add_flag("--no-alone", no_alone, "skip the LiDARs alone (the alone rows print nan)");
  app.add_flag("--no-timing", no_timing, "skip the warm rig run and the roof alone (no times)");
  app.add_option("--set", assignments, "override a calibration parameter (keys: insalign config --dump)");
  CLI11_PARSE(app, argc, argv);
  try {  // --relative-tz and --shared-stage3 win over --set
    const PipelineConfig set = cli::tool_config_with(assignments).calibrate;
    const JointConfig joint = o.config.refine.joint;
    o.config = set;
    o.config.refine.joint.relative_tz = joint.relative_tz;
    o.config.refine.joint.shared_stage3 = joint.shared_stage3;
  } catch (const std::exception& e) {
    fmt::print(stderr, "{}\n", e.what());
    return 2;
  }
  o.alone = !no_alone, o.timing = !no_timing;
  const std::string& trajectory = o.trajectory;
  std::vector<std::string> scenes;
  if (scene == "both" || scene == "default") scenes.push_back("default");
  const bool other = scene != "both" && scene != "default";  // recorded or another scenario along it
  if (scene == "both" || other) {
    if (std::filesystem::exists(trajectory)) scenes.push_back(other ? scene : "recorded");
    else fmt::print("recorded trajectory {} missing: skipped\n", trajectory);
  }
  const std::vector<std::string> names = {"top", "left", "right", "front"};
  fmt::print("rig {} at azimuth step {} deg, duration {} s (0: full); relative_tz {}, shared_stage3 {}; INS noise scale {}\n",
             kRig, o.azimuth_step_deg, o.duration_s, o.config.refine.joint.relative_tz, o.config.refine.joint.shared_stage3,
             std::isfinite(o.ins_noise_scale) ? fmt::format("{}", o.ins_noise_scale) : std::string("of the scenario"));
  for (const std::string& s : scenes) {
    std::vector<SeedRun> runs;
    for (int seed = first_seed; seed < first_seed + seeds; ++seed) {
      try {
        runs.push_back(run_seed(s, static_cast<std::uint64_t>(seed), o));
        const SeedRun& r = runs.back();
        fmt::print("{} seed {}: joint max rot err {:.4f} deg, max xy err {:.2f} mm; rig {:.1f} s vs roof {:.1f} s (warm)\n", s, seed,
                   [&] { double m = 0; for (const Vec6& e : r.joint) m = std::max(m, e.tail<3>().maxCoeff()); return m; }(),
                   [&] { double m = 0; for (const Vec6& e : r.joint) m = std::max(m, 1e3 * e.head<2>().maxCoeff()); return m; }(),
                   r.rig_warm_s, r.roof_warm_s);
        for (std::size_t l = 0; l < names.size(); ++l)
          fmt::print("  {:<6} joint x {:.2f} y {:.2f} z {:.2f} mm, r/p/y {:.4f} {:.4f} {:.4f} deg | alone x {:.2f} y {:.2f} z {:.2f} mm, "
                     "r/p/y {:.4f} {:.4f} {:.4f} deg\n", names[l], 1e3 * r.joint[l][0], 1e3 * r.joint[l][1], 1e3 * r.joint[l][2],
                     r.joint[l][3], r.joint[l][4], r.joint[l][5], 1e3 * r.alone[l][0], 1e3 * r.alone[l][1], 1e3 * r.alone[l][2],
                     r.alone[l][3], r.alone[l][4], r.alone[l][5]);
        fmt::print("  own stage-3 |tz error| (shared stage 3 replaced it; nan: not replaced): {:.2f} {:.2f} {:.2f} {:.2f} mm\n",
                   1e3 * r.own_z[0], 1e3 * r.own_z[1], 1e3 * r.own_z[2], 1e3 * r.own_z[3]);
        fmt::print("  worst pair {:.2f} sigma: {}\n", r.worst_sigma, r.worst_pair);
        fmt::print("  map check (stage 1 to the reference's map; restarted / map-start: it acted):{}\n", r.map_check);
        std::fflush(stdout);
      } catch (const std::exception& e) {
        fmt::print("{} seed {}: FAILED: {}\n", s, seed, e.what());
      }
    }
    if (!runs.empty()) report(s, names, runs);
  }
  return 0;
}
