// Bad INS stretches and moving traffic (issue 17, items 2-4): simulated drives with RTK float
// episodes, a wrong fix, a GNSS outage or moving traffic, calibrated with and without the
// screening (bad INS spans left out, moving points masked). Prints per run the error per DOF,
// the spans found against the true ones and, for traffic, how well the moving points were found;
// then MAE and worst per DOF for each arm.
//
//   build/bench/ins_robustness --case float|wrong-fix|outage|traffic|clean [--recorded] --seeds 10
//                              [--arms both|on|off] [--diagnose] [--azimuth-step-deg 0.2] [--set k=v ...]
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>

#include "cli/tool_config.hpp"
#include "core/errors.hpp"
#include "core/ins_screen.hpp"
#include "core/pipeline.hpp"
#include "io/poses.hpp"
#include "sim/world_dataset.hpp"

namespace insalign {
namespace {

struct Options {
  std::string which = "wrong-fix";
  bool recorded = false;
  std::string trajectory_file = "/work/shared/data/opencalib-sample/NovAtel-pose-lidar-time.txt";
  double azimuth_step_deg = 0.2;
  bool diagnose = false;
};

sim::SimConfig scenario(const cli::ToolConfig& tool, const Options& o, std::uint64_t seed) {
  sim::SimConfig c = tool.sim;
  c.seed = seed;
  c.azimuth_step_deg = o.azimuth_step_deg;
  if (o.recorded) {
    const io::PoseFile file = io::read_pose_file(o.trajectory_file);
    c.trajectory = sim::TrajectoryKind::kRecorded;
    c.ins_axes = sim::InsAxes::kYForward;
    for (std::size_t i = 0; i < file.T_world_ins.size(); ++i)
      c.recorded_trajectory.push_back({std::isfinite(file.t_s[i]) ? file.t_s[i] : 0.1 * i, file.T_world_ins[i]});
  }
  if (o.which == "float") c.ins_error.float_episodes = 2;
  if (o.which == "wrong-fix") c.ins_error.wrong_fixes = 1;
  if (o.which == "outage") c.ins_error.outages = 1;
  if (o.which == "traffic") c.traffic = 20, c.pedestrians = 30;
  return c;
}

// Seconds of the true events covered by the found spans, and seconds found outside every event.
struct SpanScore {
  double true_s = 0.0, covered_s = 0.0, false_s = 0.0;
  int events = 0, events_hit = 0;
};

double overlap_s(double a0, double a1, double b0, double b1) { return std::max(0.0, std::min(a1, b1) - std::max(a0, b0)); }

SpanScore score_spans(const std::vector<TimeSpan>& found, const std::vector<sim::InsEvent>& truth) {
  SpanScore s;
  for (const sim::InsEvent& e : truth) {
    ++s.events;
    s.true_s += e.t_end_s - e.t_begin_s;
    std::vector<TimeSpan> clipped;
    for (const TimeSpan& f : found)
      if (overlap_s(f.begin_s, f.end_s, e.t_begin_s, e.t_end_s) > 0.0)
        clipped.push_back({std::max(f.begin_s, e.t_begin_s), std::min(f.end_s, e.t_end_s), "", f.kind, f.source});
    s.covered_s += spans_duration_s(clipped);
    s.events_hit += !clipped.empty();
  }
  // Found time outside the events (with 1 s of slack on each side: the bounds are conservative).
  std::vector<TimeSpan> outside;
  for (const TimeSpan& f : found) {
    std::vector<std::pair<double, double>> pieces{{f.begin_s, f.end_s}};
    for (const sim::InsEvent& e : truth) {
      std::vector<std::pair<double, double>> next;
      for (auto [a, b] : pieces) {
        if (a < e.t_begin_s - 1.0) next.push_back({a, std::min(b, e.t_begin_s - 1.0)});
        if (b > e.t_end_s + 1.0) next.push_back({std::max(a, e.t_end_s + 1.0), b});
      }
      pieces = next;
    }
    for (auto [a, b] : pieces)
      if (b > a) outside.push_back({a, b, "", f.kind, f.source});
  }
  s.false_s = spans_duration_s(outside);
  return s;
}

void print_events(const sim::World& w) {
  for (const sim::InsEvent& e : w.ins_events)
    fmt::print("  true {:<13} {:8.2f} - {:8.2f} s  |error| {:.2f} m\n", sim::ins_event_name(e.kind),
               e.t_begin_s - w.frame_times_s.front(), e.t_end_s - w.frame_times_s.front(), e.error_m.norm());
}

void print_spans(const std::vector<TimeSpan>& spans, double t0) {
  for (const TimeSpan& s : spans)
    fmt::print("  found {:<12} {:<15} {:8.2f} - {:8.2f} s  {}\n", enum_name(s.source), enum_name(s.kind),
               s.begin_s - t0, s.end_s - t0, s.reason);
}

// Stage 1 on the status-screened store, then the LiDAR checks, printed in detail.
void diagnose(const cli::ToolConfig& tool, const Options& o, std::uint64_t seed) {
  auto world = std::make_shared<const sim::World>(sim::build_world(scenario(tool, o, seed)));
  const Dataset data = sim::world_dataset(world);
  const PipelineConfig& config = tool.calibrate;
  const double t0 = world->frame_times_s.front();
  fmt::print("seed {}: {} frames, {:.0f} s\n", seed, world->frame_count(), world->frame_times_s.back() - t0);
  print_events(*world);
  const InsScreenConfig screen;
  const std::vector<TimeSpan> status = status_spans(data.ins_quality, screen.status);
  print_spans(status, t0);
  const FrameStore base = make_frame_store(data, config);
  const FrameStore store = base.with(base.poses(), status);
  const auto start = std::chrono::steady_clock::now();
  const GlobalInitResult init = initialise_extrinsic(store, data.T_ins_lidar_init, config.init);
  const FrameGroups groups = rough_frame_groups(store, config.rough);
  const RoughResult rough = calibrate_rough(store, groups, init.T_ins_lidar, config.rough);
  const ExtrinsicError e1 = extrinsic_error(rough.T_ins_lidar, world->T_ins_lidar_true);
  fmt::print("  stage 1: |t| {:.4f} {:.4f} m |rpy| {:.4f} {:.4f} {:.4f} deg ({:.1f} s)\n", e1.dt_m.x(), e1.dt_m.y(),
             e1.drpy_deg.x(), e1.drpy_deg.y(), e1.drpy_deg.z(),
             std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  std::vector<std::size_t> frames = refine_frames(store, config.refine, 0.0, 0.05);
  for (const auto& g : groups) frames.insert(frames.end(), g.begin(), g.end());
  const InsScreenResult r = screen_with_lidar(store, frames, rough.T_ins_lidar, 0.0, screen);
  fmt::print("  lidar checks {:.2f} s: {} pairs (threshold {:.3f} m), {} frames (threshold {:.3f} m), time offset {:.4f} s\n",
             r.wall_time_s, r.pairs.size(), r.jump_threshold_m, r.offsets.size(), r.offset_threshold_m, r.time_offset_s);
  for (const PairCheck& p : r.pairs)
    fmt::print("    pair {:7.2f}-{:7.2f} {} jump {:.3f} m turn {:.3f} deg{}\n", p.t0_s - t0, p.t1_s - t0,
               p.used ? "used" : "----", p.jump_m.norm(), p.turn_deg, p.flagged ? "  FLAGGED" : "");
  for (const FrameOffset& f : r.offsets)
    if (f.flagged || o.which != "clean")
      fmt::print("    frame {:7.2f} {} offset {:.3f} m residual {:.3f} m{}\n", f.t_s - t0, f.used ? "used" : "----",
                 f.offset_m.norm(), f.residual_m, f.flagged ? "  FLAGGED" : "");
  print_spans(r.spans, t0);
  std::vector<TimeSpan> all = status;
  all.insert(all.end(), r.spans.begin(), r.spans.end());
  const SpanScore score = score_spans(all, world->ins_events);
  fmt::print("  events {}/{} hit, {:.1f} of {:.1f} s covered, {:.1f} s left out outside the events\n", score.events_hit,
             score.events, score.covered_s, score.true_s, score.false_s);
}

}  // namespace
}  // namespace insalign

int main(int argc, char** argv) {
  using namespace insalign;
  CLI::App app{"insalign: bad INS stretches and moving traffic, with and without screening"};
  int seeds = 3;
  std::uint64_t first_seed = 1;
  Options o;
  app.add_option("--case", o.which, "float, wrong-fix, outage, traffic or clean")->capture_default_str();
  app.add_flag("--recorded", o.recorded, "drive along the recorded NovAtel trajectory");
  app.add_option("--trajectory", o.trajectory_file, "pose file for --recorded")->capture_default_str();
  app.add_option("--seeds", seeds)->capture_default_str();
  app.add_option("--first-seed", first_seed)->capture_default_str();
  app.add_option("--azimuth-step-deg", o.azimuth_step_deg)->capture_default_str();
  app.add_flag("--diagnose", o.diagnose, "stage 1 and the screening only, in detail");
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
  for (int s = 0; s < seeds; ++s) {
    if (o.diagnose) diagnose(tool, o, first_seed + static_cast<std::uint64_t>(s));
  }
  return 0;
}
