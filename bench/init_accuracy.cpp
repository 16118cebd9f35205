// Global initialisation accuracy and runtime on simulated drives: for each seed a fresh scene, a
// random roof mount (yaw uniform over 360 deg, roll/pitch within 10 deg, anywhere on the roof) and
// alternating INS axes (x-forward, y-forward). Runs initialise_extrinsic without an init, then with
// inits that are wrong by a yaw of 180 deg, with x and y swapped (INS axis convention mixed up) and
// with the simulator's in-basin guess (20 deg, 0.5 m). Frames are rendered once into a cache before
// the timed run, so the time excludes ray casting. --rough also runs stage 1 from the data's start.
//
//   build/bench/init_accuracy --seeds 20 [--azimuth-step 0.2] [--duration 0] [--rough]
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <ctime>
#include <map>
#include <mutex>

#include "core/global_init.hpp"
#include "core/pipeline.hpp"
#include "core/rough.hpp"
#include "sim/world_dataset.hpp"

namespace {

using namespace insalign;

// Renders each frame once; later loads copy from the cache (thread-safe).
Dataset cached(Dataset data) {
  auto cache = std::make_shared<std::map<std::size_t, Sweep>>();
  auto mutex = std::make_shared<std::mutex>();
  auto load = data.frames.load;
  data.frames.load = [cache, mutex, load](std::size_t k) {
    {
      std::lock_guard<std::mutex> lock(*mutex);
      auto it = cache->find(k);
      if (it != cache->end()) return it->second;
    }
    Sweep s = load(k);
    std::lock_guard<std::mutex> lock(*mutex);
    return cache->emplace(k, std::move(s)).first->second;
  };
  return data;
}

Iso3 yaw_about_ins_z(const Iso3& T, double deg) {
  Iso3 Rz = Iso3::Identity();
  Rz.linear() = make_transform(Vec3::Zero(), {0, 0, deg}).linear();
  return Rz * T;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"global initialisation accuracy on simulated drives"};
  int seeds = 20, first_seed = 1;
  double azimuth_step = 0.2, duration = 0.0;
  bool rough = false, verbose = false;
  std::string lidar = "pandar64";
  app.add_option("--seeds", seeds);
  app.add_option("--first-seed", first_seed);
  app.add_option("--azimuth-step", azimuth_step);
  app.add_option("--duration", duration);
  app.add_option("--lidar", lidar);
  app.add_flag("--rough", rough, "also run stage 1 from the data's start");
  app.add_flag("-v,--verbose", verbose);
  CLI11_PARSE(app, argc, argv);

  fmt::print("{:>4} {:>4} {:>7} | {:>6} {:>6} {:>6} {:>6} {:>6} | {:>5} {:>5} | {:>6} {:>6} {:>6} | {}\n", "seed",
             "ins", "yaw_gt", "ang", "rp", "yaw", "dxy", "dz", "t_s", "t2_s", "init180", "initxy", "initok",
             rough ? "stage1: ang dxy (deg, m)" : "");
  double worst_ang = 0, worst_xy = 0, worst_t = 0, sum_t = 0;
  int recovered = 0, kept = 0, runs = 0;
  double worst_rough_ang = 0, worst_rough_xy = 0;
  for (int seed = first_seed; seed < first_seed + seeds; ++seed) {
    sim::SimConfig config;
    config.seed = static_cast<std::uint64_t>(seed);
    config.azimuth_step_deg = azimuth_step;
    config.duration_s = duration;
    config.lidar_model = lidar;
    config.ins_axes = seed % 2 ? sim::InsAxes::kXForward : sim::InsAxes::kYForward;
    auto world = std::make_shared<const sim::World>(sim::build_world(config));
    const Dataset data = cached(sim::world_dataset(world));
    const FrameStore store = make_frame_store(data, PipelineConfig{});
    const Iso3 T_true = world->T_ins_lidar_true;

    initialise_extrinsic(store, std::nullopt);  // renders the frames it needs into the cache
    const std::clock_t cpu0 = std::clock();
    const GlobalInitResult res = initialise_extrinsic(store, std::nullopt);
    const double cpu_s = static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC;
    const ExtrinsicError err = extrinsic_error(res.T_ins_lidar, T_true);
    const double dxy = err.dt_m.head<2>().norm();

    Iso3 init_xy = T_true;  // INS axis convention mixed up: x_init = y, y_init = -x
    init_xy = yaw_about_ins_z(T_true, -90.0);
    const GlobalInitResult r180 = initialise_extrinsic(store, yaw_about_ins_z(T_true, 180.0));
    const GlobalInitResult rxy = initialise_extrinsic(store, init_xy);
    const GlobalInitResult rok = initialise_extrinsic(store, world->T_ins_lidar_init);
    const auto ok_override = [&](const GlobalInitResult& r) {
      const ExtrinsicError e = extrinsic_error(r.T_ins_lidar, T_true);
      return r.source == InitSource::kDataOverridesInit && e.angle_deg < 20 && e.dt_m.head<2>().norm() < 0.5;
    };
    recovered += ok_override(r180) + ok_override(rxy);
    kept += rok.source == InitSource::kInit;

    std::string rough_text;
    if (rough) {
      const RoughResult rr = calibrate_rough(store, rough_frame_groups(store, {}, res.time_offset_s), res.T_ins_lidar,
                                              res.time_offset_s);
      const ExtrinsicError e = extrinsic_error(rr.T_ins_lidar, T_true);
      rough_text = fmt::format("{:.3f} {:.3f}", e.angle_deg, e.dt_m.head<2>().norm());
      worst_rough_ang = std::max(worst_rough_ang, e.angle_deg);
      worst_rough_xy = std::max(worst_rough_xy, e.dt_m.head<2>().norm());
    }
    const double yaw_gt = rpy_from_rotation(T_true.linear()).z() * kDegPerRad;
    fmt::print("{:>4} {:>4} {:>7.1f} | {:>6.2f} {:>6.2f} {:>6.2f} {:>6.3f} {:>6.3f} | {:>5.2f} {:>5.2f} | {:>6} {:>6} {:>6} | {}\n",
               seed, seed % 2 ? "xfwd" : "yfwd", yaw_gt, err.angle_deg, std::max(err.drpy_deg.x(), err.drpy_deg.y()),
               err.drpy_deg.z(), dxy, err.dt_m.z(), res.outcome.wall_time_s, r180.outcome.wall_time_s,
               ok_override(r180) ? "ok" : enum_name(r180.source), ok_override(rxy) ? "ok" : enum_name(rxy.source),
               rok.source == InitSource::kInit ? "kept" : enum_name(rok.source), rough_text);
    if (verbose)
      fmt::print("     cpu {:.2f} s; wall: load {:.2f} coarse {:.2f} hand-eye {:.2f} score {:.2f}\n", cpu_s, res.load_s,
                 res.coarse_s, res.hand_eye_s, res.score_s);
    if (verbose) fmt::print("     {}\n     init180: {}\n", res.explanation, r180.explanation);
    worst_ang = std::max(worst_ang, err.angle_deg);
    worst_xy = std::max(worst_xy, dxy);
    worst_t = std::max(worst_t, res.outcome.wall_time_s);
    sum_t += res.outcome.wall_time_s;
    ++runs;
  }
  fmt::print("worst: rotation {:.2f} deg, horizontal translation {:.3f} m; time mean {:.2f} s, max {:.2f} s\n",
             worst_ang, worst_xy, sum_t / runs, worst_t);
  fmt::print("wrong inits recovered {}/{}, correct inits kept {}/{}\n", recovered, 2 * runs, kept, runs);
  if (rough) fmt::print("stage 1 from the data's start: worst {:.3f} deg, {:.3f} m horizontal\n", worst_rough_ang, worst_rough_xy);
  return 0;
}
