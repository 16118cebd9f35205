// Bad INS stretches and moving traffic (issue 17, items 2-3): simulated drives with RTK float
// episodes, a wrong fix, a GNSS outage or moving traffic, calibrated with the screening off (INS
// spans and moving points used as they come) and on (the defaults). Prints per run the error per
// DOF, the spans found against the true events and, for traffic, the moving-point mask's
// precision and recall against the simulator's ground truth; then MAE and worst per arm.
//
//   build/bench/screen_robustness --case float|wrong-fix|outage|traffic|clean --seeds 5
//                                 [--arms both|on|off] [--azimuth-step-deg 0.8] [--set k=v ...]
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <algorithm>
#include <cstdlib>
#include <cmath>
#include <memory>

#include "tool/tool_config.hpp"
#include "core/enum_names.hpp"
#include "core/ins_screen.hpp"
#include "core/moving_points.hpp"
#include "core/pipeline.hpp"
#include "sim/traffic.hpp"
#include "sim/world_dataset.hpp"

namespace insalign {
namespace {

struct Options {
  std::string which = "wrong-fix";
  std::string arms = "both";
  double azimuth_step_deg = 0.8;
  double duration_s = 75.0;
};

sim::SimConfig scenario(const cli::ToolConfig& tool, const Options& o, std::uint64_t seed) {
  sim::SimConfig c = tool.sim;
  c.seed = seed;
  c.azimuth_step_deg = o.azimuth_step_deg;
  c.duration_s = o.duration_s;
  if (o.which == "float") c.ins_error.float_episodes = 2;
  if (o.which == "wrong-fix") c.ins_error.wrong_fixes = 1;
  if (o.which == "outage") c.ins_error.outages = 1;
  if (o.which == "traffic") c.traffic = 20, c.pedestrians = 30;
  return c;
}

double overlap_s(double a0, double a1, double b0, double b1) { return std::max(0.0, std::min(a1, b1) - std::max(a0, b0)); }

// Per true event: the fraction of it the found spans cover; and the found seconds outside every event.
std::string span_score(const std::vector<TimeSpan>& found, const std::vector<sim::InsEvent>& truth, double t0_s,
                       int& missed) {
  std::string s;
  for (const sim::InsEvent& e : truth) {
    std::vector<TimeSpan> clipped;
    for (const TimeSpan& f : found)
      if (overlap_s(f.begin_s, f.end_s, e.t_begin_s, e.t_end_s) > 0.0)
        clipped.push_back({std::max(f.begin_s, e.t_begin_s), std::min(f.end_s, e.t_end_s), "", f.kind, f.source});
    const double covered = spans_duration_s(clipped) / (e.t_end_s - e.t_begin_s);
    missed += covered < 0.5;
    s += fmt::format(" {} {:.1f}-{:.1f} s {:.0f}% covered", sim::ins_event_name(e.kind), e.t_begin_s - t0_s,
                     e.t_end_s - t0_s, 100.0 * covered);
  }
  double outside = spans_duration_s(found);
  for (const sim::InsEvent& e : truth) {
    std::vector<TimeSpan> in;
    for (const TimeSpan& f : found)
      if (overlap_s(f.begin_s, f.end_s, e.t_begin_s - 1.0, e.t_end_s + 1.0) > 0.0)
        in.push_back({std::max(f.begin_s, e.t_begin_s - 1.0), std::min(f.end_s, e.t_end_s + 1.0), "", f.kind, f.source});
    outside -= spans_duration_s(in);
  }
  return s + fmt::format(", {:.1f} s left out elsewhere", std::max(outside, 0.0));
}

// The mask the run used (same store, stage 1's extrinsic) against the simulator's mover flags on
// every 10th frame at full resolution.
std::string mask_score(const sim::World& world, const FrameStore& store, const CalibrationResult& r,
                       const PipelineConfig& config) {
  MovingPointsResult res;
  const auto mask = find_moving_points(store.with(store.poses(), r.excluded), r.rough.T_ins_lidar, 0.0, config.moving, res);
  if (!mask) return "no mask";
  std::size_t tp = 0, fp = 0, fn = 0, all = 0;
  for (std::size_t k = 0; k < world.frame_count(); k += 10) {
    std::vector<std::uint8_t> truth;
    const Sweep s = sim::render_sweep(world, k, &truth);
    const std::vector<char> keep = mask->keep(k, s);
    for (std::size_t i = 0; i < s.size(); ++i) {
      tp += truth[i] && !keep[i], fp += !truth[i] && !keep[i], fn += truth[i] && keep[i];
      ++all;
    }
  }
  return fmt::format("movers {:.2f}% of points, precision {:.3f} recall {:.3f} ({:.1f} s)",
                     100.0 * (tp + fn) / std::max<double>(all, 1), tp / std::max<double>(tp + fp, 1),
                     tp / std::max<double>(tp + fn, 1), res.wall_time_s);
}

struct Arm {
  std::string name;
  std::vector<ExtrinsicError> errors;
  int missed = 0, failed = 0;
};

void run_one(const cli::ToolConfig& tool, const Options& o, std::uint64_t seed, bool screen, Arm& arm) {
  auto world = std::make_shared<const sim::World>(sim::build_world(scenario(tool, o, seed)));
  const Dataset data = sim::world_dataset(world);
  PipelineConfig config = tool.calibrate;
  config.repeatability.segments = 0;
  if (!screen) config.ins_screen.from_status = config.ins_screen.from_lidar = config.moving.enabled = false;
  const FrameStore store = make_frame_store(data, config);
  CalibrationResult r;
  try {
    r = run_calibration(store, config);
  } catch (const std::exception& e) {
    fmt::print("seed {:3} {:4}: failed: {}\n", seed, arm.name, e.what());
    ++arm.failed;
    return;
  }
  const ExtrinsicError e = extrinsic_error(r.T_ins_lidar, world->T_ins_lidar_true);
  arm.errors.push_back(e);
  std::string extra;
  for (int i = 0; i < 6; ++i)
    if (!r.determined[i]) extra += fmt::format(" [{} undetermined]", kDofNames[i]);
  if (screen && !world->ins_events.empty()) extra = span_score(r.excluded, world->ins_events, world->frame_times_s.front(), arm.missed);
  if (screen && world->traffic && !world->traffic->movers.empty()) extra += mask_score(*world, store, r, config);
  if (screen)
    extra += fmt::format(" [screen {:.1f} s, mask {:.1f} s: {} of {} points]", r.ins_screen.wall_time_s,
                         r.moving.wall_time_s, r.moving.points_moving, r.moving.points_checked);
  if (screen && std::getenv("SCREEN_SPANS"))
    for (const TimeSpan& sp : r.excluded)
      extra += fmt::format("\n    {:7.2f}-{:7.2f} s {}: {}", sp.begin_s - world->frame_times_s.front(),
                           sp.end_s - world->frame_times_s.front(), enum_name(sp.source), sp.reason);
  fmt::print("seed {:3} {:4}: |t| {:5.1f} {:5.1f} {:5.1f} mm |rpy| {:.4f} {:.4f} {:.4f} deg, {} spans, {:.0f} s{}{}\n",
             seed, arm.name, 1e3 * e.dt_m.x(), 1e3 * e.dt_m.y(), 1e3 * e.dt_m.z(), e.drpy_deg.x(), e.drpy_deg.y(),
             e.drpy_deg.z(), r.excluded.size(), r.wall_time_s, extra.empty() ? "" : "\n           ", extra);
  std::fflush(stdout);
}

void print_summary(const Arm& arm) {
  Eigen::Matrix<double, 6, 1> mae = Eigen::Matrix<double, 6, 1>::Zero(), worst = mae;
  for (const ExtrinsicError& e : arm.errors) {
    Eigen::Matrix<double, 6, 1> v;
    v << 1e3 * e.dt_m, e.drpy_deg;
    mae += v / static_cast<double>(arm.errors.size());
    worst = worst.cwiseMax(v);
  }
  fmt::print("| {} | {} | {:.1f} / {:.1f} | {:.1f} / {:.1f} | {:.1f} / {:.1f} | {:.4f} / {:.4f} | {:.4f} / {:.4f} | "
             "{:.4f} / {:.4f} | {} |\n",
             arm.name, arm.errors.size(), mae(0), worst(0), mae(1), worst(1), mae(2), worst(2), mae(3), worst(3), mae(4),
             worst(4), mae(5), worst(5), arm.failed + arm.missed);
}

}  // namespace
}  // namespace insalign

int main(int argc, char** argv) {
  using namespace insalign;
  CLI::App app{"insalign: bad INS stretches and moving traffic, with the screening off and on"};
  int seeds = 5;
  std::uint64_t first_seed = 1;
  Options o;
  app.add_option("--case", o.which, "float, wrong-fix, outage, traffic or clean")->capture_default_str();
  app.add_option("--arms", o.arms, "both, on or off")->capture_default_str();
  app.add_option("--seeds", seeds)->capture_default_str();
  app.add_option("--first-seed", first_seed)->capture_default_str();
  app.add_option("--azimuth-step-deg", o.azimuth_step_deg)->capture_default_str();
  app.add_option("--duration-s", o.duration_s)->capture_default_str();
  std::vector<std::string> assignments;
  app.add_option("--set", assignments, "override a parameter (keys: insalign config --dump)");
  CLI11_PARSE(app, argc, argv);
  cli::ToolConfig tool;
  try {
    tool = cli::tool_config_with(assignments);
  } catch (const std::exception& e) {
    fmt::print(stderr, "{}\n", e.what());
    return 2;
  }
  Arm off, on;
  off.name = "off";
  on.name = "on";
  for (int s = 0; s < seeds; ++s) {
    const std::uint64_t seed = first_seed + static_cast<std::uint64_t>(s);
    if (o.arms != "on") run_one(tool, o, seed, false, off);
    if (o.arms != "off") run_one(tool, o, seed, true, on);
  }
  fmt::print("\n{}: MAE / worst (mm, deg); last column: failed runs + events missed (< 50% covered)\n", o.which);
  fmt::print("| screen | runs | x | y | z | roll | pitch | yaw | failed+missed |\n|---|---|---|---|---|---|---|---|---|\n");
  if (o.arms != "on") print_summary(off);
  if (o.arms != "off") print_summary(on);
  return 0;
}
