// Stage 1 accuracy and runtime on simulated drives: for each seed a fresh scene and random roof
// mount (any yaw), the rough calibration started from the truth off by init_rot_deg about a random
// axis and init_trans_m in a random direction (the simulator's initial guess); errors against the
// truth in the INS frame. The frames the stage picks are rendered before the clock starts, so the
// stage time excludes ray casting but includes the stage's own per-frame work after "loading".
//
//   build/bench/rough_accuracy --seeds 10 [--lidar pandar64] [--azimuth-step 0.2]
//        [--trajectory NovAtel-pose-lidar-time.txt] [--duration 0] [--scene intersection|feature-poor]
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <tbb/parallel_for.h>

#include <chrono>
#include <ctime>
#include <map>
#include <mutex>

#include "core/pipeline.hpp"
#include "core/rough.hpp"
#include "files/poses.hpp"
#include "sim/world_dataset.hpp"

namespace insalign {
namespace {

struct Run {
  Vec6 err = Vec6::Zero();  // |tx| |ty| |tz| m, |roll| |pitch| |yaw| deg
  double seconds = 0.0, cpu_s = 0.0;  // wall time; CPU time summed over threads
  std::string verdict;
};

}  // namespace
}  // namespace insalign

int main(int argc, char** argv) {
  using namespace insalign;
  CLI::App app{"stage-1 rough calibration accuracy on simulated drives"};
  int seeds = 10, first_seed = 1;
  std::string lidar = "pandar64", trajectory_file, scene = "intersection", trajectory = "figure8";
  double azimuth_step = 0.2, duration = 0.0, init_rot = 20.0, init_trans = 0.5;
  bool verbose = false;
  app.add_option("--seeds", seeds);
  app.add_option("--first-seed", first_seed);
  app.add_option("--lidar", lidar);
  app.add_option("--azimuth-step", azimuth_step);
  app.add_option("--duration", duration);
  app.add_option("--trajectory", trajectory_file, "recorded pose file (kRecorded)");
  app.add_option("--motion", trajectory, "figure8|straight|standstill");
  app.add_option("--scene", scene);
  app.add_option("--init-rot", init_rot);
  app.add_option("--init-trans", init_trans);
  app.add_flag("-v,--verbose", verbose);
  CLI11_PARSE(app, argc, argv);

  std::vector<StampedPose> recorded;
  if (!trajectory_file.empty()) {
    const io::PoseFile file = io::read_pose_file(trajectory_file);
    for (std::size_t i = 0; i < file.T_world_ins.size(); ++i)
      if (std::isfinite(file.t_s[i])) recorded.push_back({file.t_s[i], file.T_world_ins[i]});
  }

  std::vector<Run> runs;
  fmt::print("| seed | frames | |tx| cm | |ty| cm | |tz| cm | |roll| deg | |pitch| deg | |yaw| deg | stage s | cpu s | verdict\n");
  for (int seed = first_seed; seed < first_seed + seeds; ++seed) {
    sim::SimConfig config;
    config.seed = static_cast<std::uint64_t>(seed);
    config.lidar_model = lidar;
    config.azimuth_step_deg = azimuth_step;
    config.duration_s = duration;
    config.init_rot_err_deg = init_rot;
    config.init_trans_err_m = init_trans;
    config.scene = scene == "feature-poor" ? sim::SceneKind::kFeaturePoor : sim::SceneKind::kIntersection;
    config.trajectory = trajectory == "straight"     ? sim::TrajectoryKind::kStraight
                        : trajectory == "standstill" ? sim::TrajectoryKind::kStandstill
                                                     : sim::TrajectoryKind::kFigure8;
    if (!recorded.empty()) {
      config.trajectory = sim::TrajectoryKind::kRecorded;
      config.recorded_trajectory = recorded;
    }
    auto world = std::make_shared<const sim::World>(sim::build_world(config));
    const Dataset data = sim::world_dataset(world);
    // Render and reduce the frames the stage will pick up front (the stage's loading then costs
    // a copy, as a PCD decode would cost a read).
    const RoughConfig rough_config;
    const FrameStore store = make_frame_store(data, PipelineConfig{});
    const FrameGroups groups = rough_frame_groups(store, rough_config);
    for (const auto& g : groups) (void)store.thinned(g, rough_config.filter);
    const Iso3 T_true = world->T_ins_lidar_true;
    const std::clock_t cpu0 = std::clock();
    const RoughResult r = calibrate_rough(store, groups, world->T_ins_lidar_init, 0.0, rough_config);
    const double cpu_s = static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC;
    const ExtrinsicError e = extrinsic_error(r.T_ins_lidar, T_true);
    Run run;
    run.err << e.dt_m, e.drpy_deg;
    run.seconds = r.outcome.wall_time_s;
    run.cpu_s = cpu_s;
    run.verdict = r.observability.explanation;
    if (verbose) {
      for (const RoundLog& log : r.convergence) {
        const ExtrinsicError el = extrinsic_error(log.T_ins_lidar, T_true);
        fmt::print("    round {} windows {:3d} planes {:6d} residuals {:7d} cost {:9.3f} | rot {:.3f} {:.3f} {:.3f} deg "
                   "| t {:.3f} {:.3f} {:.3f} m | build {:.2f} s solve {:.2f} s\n",
                   log.round, log.windows, log.planes, log.residuals, log.cost, el.drpy_deg.x(), el.drpy_deg.y(),
                   el.drpy_deg.z(), el.dt_m.x(), el.dt_m.y(), el.dt_m.z(), log.build_s, log.solve_s);
      }
      fmt::print("    load {:.2f} s; shift at target tx ty tz r p y (mm): {:.2f} {:.2f} {:.2f} {:.2f} {:.2f} {:.2f}\n",
                 r.load_time_s, r.observability.shift_at_target_m(0) * 1e3, r.observability.shift_at_target_m(1) * 1e3,
                 r.observability.shift_at_target_m(2) * 1e3, r.observability.shift_at_target_m(3) * 1e3,
                 r.observability.shift_at_target_m(4) * 1e3, r.observability.shift_at_target_m(5) * 1e3);
      fmt::print("    sigma {:.4f} m, stddev tx ty tz {:.4f} {:.4f} {:.4f} m, rpy {:.4f} {:.4f} {:.4f} deg\n",
                 r.residual_sigma_m, r.observability.stddev(0), r.observability.stddev(1), r.observability.stddev(2),
                 r.observability.stddev(3) * kDegPerRad, r.observability.stddev(4) * kDegPerRad,
                 r.observability.stddev(5) * kDegPerRad);
    }
    fmt::print("| {:4d} | {:6d} | {:7.2f} | {:7.2f} | {:7.2f} | {:10.3f} | {:11.3f} | {:9.3f} | {:7.2f} | {:5.2f} | {}\n",
               seed, r.frames_used, run.err(0) * 100, run.err(1) * 100, run.err(2) * 100, run.err(3), run.err(4),
               run.err(5), run.seconds, run.cpu_s, run.verdict.substr(0, 40));
    std::fflush(stdout);
    runs.push_back(run);
  }
  Vec6 mae = Vec6::Zero(), worst = Vec6::Zero();
  double t_mean = 0.0, t_worst = 0.0, cpu_mean = 0.0;
  for (const Run& r : runs) {
    cpu_mean += r.cpu_s / static_cast<double>(runs.size());
    mae += r.err;
    worst = worst.cwiseMax(r.err);
    t_mean += r.seconds;
    t_worst = std::max(t_worst, r.seconds);
  }
  mae /= static_cast<double>(runs.size());
  t_mean /= static_cast<double>(runs.size());
  fmt::print("| MAE  |        | {:7.2f} | {:7.2f} | {:7.2f} | {:10.3f} | {:11.3f} | {:9.3f} | {:7.2f} |\n", mae(0) * 100,
             mae(1) * 100, mae(2) * 100, mae(3), mae(4), mae(5), t_mean);
  fmt::print("mean CPU time of the stage: {:.2f} s (wall time on an idle 2-core machine is about half)\n", cpu_mean);
  fmt::print("| max  |        | {:7.2f} | {:7.2f} | {:7.2f} | {:10.3f} | {:11.3f} | {:9.3f} | {:7.2f} |\n", worst(0) * 100,
             worst(1) * 100, worst(2) * 100, worst(3), worst(4), worst(5), t_worst);
  return 0;
}
