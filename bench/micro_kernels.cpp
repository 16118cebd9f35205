// Google Benchmark micro-benchmarks of the core's hot kernels, on a short simulated Pandar64 drive
// (seeded, rendered once per process): deskew of one sweep, plane features (voxel downsampling and
// adaptive voxelization), the stage-2 occupancy count, the stage-1 point-to-plane system and the
// stage-2 plane-thickness cost. Throughput is points per second (items) of wall time: most kernels
// run in parallel (TBB), so the CPU column counts only the main thread.
//
//   build-micro/bench/micro_kernels --benchmark_min_time=0.5
//
// Set-up: a figure-8 drive truncated to kDriveS seconds; the frames from kFirstFrame on (the car
// cruises by then, the start ramp lasts 3 s) are rendered up front and served from memory.
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstddef>
#include <map>
#include <memory>
#include <span>
#include <vector>

#include "core/dataset.hpp"
#include "core/deskew.hpp"
#include "core/moving_points.hpp"
#include "core/occupancy.hpp"
#include "core/plane_features.hpp"
#include "core/pipeline.hpp"
#include "core/refine.hpp"
#include "core/stitch.hpp"
#include "core/rough.hpp"
#include "core/scan_registration.hpp"
#include "sim/simulate.hpp"
#include "sim/world_dataset.hpp"

namespace insalign {
namespace {

constexpr double kDriveS = 6.0;          // simulated drive length, seconds (60 frames at 10 Hz)
constexpr std::size_t kFirstFrame = 36;  // first rendered frame: cruising, clear of the start ramp
constexpr std::size_t kWindowFrames = 6; // stage-1 window (a frame group of the default selection)

/// The rendered part of the drive, shared by every benchmark (built on first use).
struct Drive {
  std::shared_ptr<const sim::World> world;
  Dataset data;              ///< all frames of the drive; the rendered ones load from memory
  std::vector<Sweep> sweeps; ///< frames kFirstFrame.. of the drive, raw (motion-distorted)
  const Sweep& middle() const { return sweeps[sweeps.size() / 2]; }
  Iso3 T_ins_lidar() const { return world->T_ins_lidar_true; }
};

const Drive& drive() {
  static const Drive d = [] {
    sim::SimConfig config;
    config.seed = 1;
    config.lidar_model = "pandar64";
    config.duration_s = kDriveS;
    Drive out;
    out.world = std::make_shared<const sim::World>(sim::build_world(config));
    const std::size_t n = out.world->frame_count();
    out.sweeps.resize(n - kFirstFrame);
    tbb::parallel_for(std::size_t{0}, out.sweeps.size(),
                      [&](std::size_t k) { out.sweeps[k] = sim::render_sweep(*out.world, kFirstFrame + k); });
    out.data = sim::world_dataset(out.world);
    // Only the rendered frames are offered to the stages (the others would render on demand).
    out.data.frames = frame_source_from(out.sweeps);
    return out;
  }();
  return d;
}

/// One stage-1 window: each frame deskewed and voxel-downsampled in the LiDAR frame as the stage
/// does (0.4 m, 2.5-80 m range), the window stitched in the world with the true extrinsic, planes
/// found by adaptive voxelization, and each plane's points split by frame into observations.
struct Window {
  std::vector<Vec3f> p_world;          ///< the stitched window (input of extract_planes)
  PlaneFeatureConfig planes_config;
  std::vector<PlaneObservation> observations;
  std::size_t planes = 0, points = 0;  ///< planes seen by at least two frames, and their points
};

const Window& window() {
  static const Window w = [] {
    const Drive& d = drive();
    const RoughConfig rough;
    const RoughRound& round = rough.rounds.at(1);
    Window out;
    out.planes_config.root_voxel_m = round.root_voxel_m;
    out.planes_config.planarity_sigma_m = round.planarity_sigma_m;
    out.planes_config.max_depth = rough.max_depth;
    out.planes_config.max_eigen_ratio = rough.max_eigen_ratio;
    out.planes_config.min_points = rough.min_points_per_plane;
    std::vector<std::vector<Vec3f>> p_lidar(kWindowFrames);
    std::vector<Iso3> T_world_ins(kWindowFrames);
    std::vector<std::uint32_t> frame_of, index_in_frame;
    for (std::size_t f = 0; f < kWindowFrames; ++f) {
      const Sweep& s = d.sweeps[f];
      const std::vector<Vec3f> deskewed = deskew_sweep(s, d.data.poses, d.T_ins_lidar());
      for (std::uint32_t i : voxel_downsample_indices(std::span<const Vec3f>(deskewed), rough.filter.voxel_m)) {
        const float r = deskewed[i].norm();
        if (r >= VehicleConfig{}.body_radius_m && r <= rough.filter.max_range_m) p_lidar[f].push_back(deskewed[i]);
      }
      T_world_ins[f] = frame_pose(s, d.data.poses, 0.0);
      const Iso3 T_world_lidar = T_world_ins[f] * d.T_ins_lidar();
      for (std::size_t i = 0; i < p_lidar[f].size(); ++i) {
        out.p_world.push_back((T_world_lidar * p_lidar[f][i].cast<double>()).cast<float>());
        frame_of.push_back(static_cast<std::uint32_t>(f));
        index_in_frame.push_back(static_cast<std::uint32_t>(i));
      }
    }
    const std::vector<Plane> planes = extract_planes(out.p_world, out.planes_config);
    for (std::size_t j = 0; j < planes.size(); ++j) {
      std::map<std::uint32_t, PlaneObservation> by_frame;
      for (std::uint32_t idx : planes[j].point_indices) {
        PlaneObservation& o = by_frame[frame_of[idx]];
        o.plane = j;
        o.T_world_ins = T_world_ins[frame_of[idx]];
        o.p_lidar.push_back(p_lidar[frame_of[idx]][index_in_frame[idx]]);
      }
      if (by_frame.size() < rough.min_frames_per_plane) continue;
      ++out.planes;
      for (auto& [f, o] : by_frame) {
        out.points += o.p_lidar.size();
        out.observations.push_back(std::move(o));
      }
    }
    return out;
  }();
  return w;
}

/// The stage-2 map: the default frame reduction (0.15 m per frame, at most 10000 points), placed
/// in the world with the true extrinsic; a 1 mm final downsampling keeps every point.
const std::vector<Vec3f>& stage2_map() {
  static const std::vector<Vec3f> map = [] {
    const FrameStore store = make_frame_store(drive().data, PipelineConfig{});
    std::vector<std::size_t> all(drive().sweeps.size());
    for (std::size_t i = 0; i < all.size(); ++i) all[i] = i;
    return stitch_map(store, all, drive().T_ins_lidar(), 0.0, 0.001);
  }();
  return map;
}

void set_points(benchmark::State& state, std::size_t points) {
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) * static_cast<std::int64_t>(points));
  state.counters["points"] = static_cast<double>(points);
}

// --- Deskew ----------------------------------------------------------------------------------

void BM_DeskewSweep(benchmark::State& state) {
  const Drive& d = drive();
  const Sweep& s = d.middle();
  for (auto _ : state) benchmark::DoNotOptimize(deskew_sweep(s, d.data.poses, d.T_ins_lidar()));
  set_points(state, s.size());
}
BENCHMARK(BM_DeskewSweep)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_SweepToWorld(benchmark::State& state) {
  const Drive& d = drive();
  const Sweep& s = d.middle();
  for (auto _ : state) benchmark::DoNotOptimize(sweep_to_world(s, d.data.poses, d.T_ins_lidar()));
  set_points(state, s.size());
}
BENCHMARK(BM_SweepToWorld)->Unit(benchmark::kMillisecond)->UseRealTime();

// --- Plane features ----------------------------------------------------------------------------

void BM_VoxelDownsampleSweep(benchmark::State& state) {
  const Sweep& s = drive().middle();
  const double voxel_m = static_cast<double>(state.range(0)) / 100.0;
  for (auto _ : state) benchmark::DoNotOptimize(voxel_downsample_indices(std::span<const Vec3f>(s.p_lidar), voxel_m));
  set_points(state, s.size());
}
BENCHMARK(BM_VoxelDownsampleSweep)->Arg(15)->Arg(40)->ArgName("voxel_cm")->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_ExtractPlanesSweep(benchmark::State& state) {
  const Sweep& s = drive().middle();
  PlaneFeatureConfig config;
  config.root_voxel_m = static_cast<double>(state.range(0)) / 100.0;
  std::size_t planes = 0;
  for (auto _ : state) {
    const std::vector<Plane> p = extract_planes(s.p_lidar, config);
    planes = p.size();
    benchmark::DoNotOptimize(p.data());
  }
  set_points(state, s.size());
  state.counters["planes"] = static_cast<double>(planes);
}
BENCHMARK(BM_ExtractPlanesSweep)->Arg(100)->Arg(200)->ArgName("root_cm")->Unit(benchmark::kMillisecond)->UseRealTime();

// Stage 1's use: planes of a stitched window of downsampled frames.
void BM_ExtractPlanesRoughWindow(benchmark::State& state) {
  const Window& w = window();
  for (auto _ : state) benchmark::DoNotOptimize(extract_planes(w.p_world, w.planes_config));
  set_points(state, w.p_world.size());
}
BENCHMARK(BM_ExtractPlanesRoughWindow)->Unit(benchmark::kMillisecond)->UseRealTime();

// --- Stage-2 occupancy -------------------------------------------------------------------------

void BM_CountOccupiedVoxels(benchmark::State& state) {
  const std::vector<Vec3f>& map = stage2_map();
  const double voxel_m = static_cast<double>(state.range(0)) / 100.0;
  std::size_t occupied = 0;
  for (auto _ : state) {
    occupied = count_occupied_voxels(map, voxel_m);
    benchmark::DoNotOptimize(occupied);
  }
  set_points(state, map.size());
  state.counters["voxels"] = static_cast<double>(occupied);
}
BENCHMARK(BM_CountOccupiedVoxels)->Arg(10)->Arg(20)->ArgName("voxel_cm")->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_StaggeredOccupancy(benchmark::State& state) {
  const std::vector<Vec3f>& map = stage2_map();
  for (auto _ : state) benchmark::DoNotOptimize(staggered_occupancy(map, 0.1));
  set_points(state, map.size());
}
BENCHMARK(BM_StaggeredOccupancy)->Unit(benchmark::kMillisecond)->UseRealTime();

// --- Stage 1: point-to-plane cost, gradient and Gauss-Newton Hessian ----------------------------

void BM_RoughPointPlaneSystem(benchmark::State& state) {
  const Window& w = window();
  const Iso3 T = drive().T_ins_lidar();
  const double robust_scale_m = RoughConfig{}.rounds.at(1).robust_scale_m;
  for (auto _ : state) benchmark::DoNotOptimize(point_plane_system(w.observations, T, robust_scale_m));
  set_points(state, w.points);
  state.counters["planes"] = static_cast<double>(w.planes);
  state.counters["clusters"] = static_cast<double>(w.observations.size());
}
BENCHMARK(BM_RoughPointPlaneSystem)->Unit(benchmark::kMillisecond)->UseRealTime();

// --- Scan registration's target: kd-tree, normals, nearest planar point -----------------------

// A map-check target (the stage-2 map thinned to 10 cm, normals fitted up front: its kd-tree's
// k-nearest searches), then the nearest planar target point of every map point shifted by 3 cm
// (a registration's correspondences).
void BM_PlaneTargetNormalsNearest(benchmark::State& state) {
  std::vector<Vec3> points;
  for (const Vec3f& p : voxel_downsample(stage2_map(), 0.1)) points.push_back(p.cast<double>());
  std::size_t found = 0;
  for (auto _ : state) {
    const PlaneTarget target(points, 10, 0.05);
    found = 0;
    for (const Vec3& p : points) found += target.nearest_planar(p + Vec3(0.03, 0.0, 0.0), 0.5).has_value();
    benchmark::DoNotOptimize(found);
  }
  set_points(state, points.size());
  state.counters["found"] = static_cast<double>(found);
}
BENCHMARK(BM_PlaneTargetNormalsNearest)->Unit(benchmark::kMillisecond)->UseRealTime();

// --- Stage 2: plane-thickness cost -------------------------------------------------------------

// The cost value with its planes re-found from the map (what the first Gauss-Newton iterations of
// the continuous method fit), with the stage's default plane parameters.
void BM_PlaneThicknessStage2Map(benchmark::State& state) {
  const std::vector<Vec3f>& map = stage2_map();
  const PlaneThicknessConfig config = plane_thickness_config(RefineConfig{});
  PlaneThickness result;
  for (auto _ : state) {
    result = plane_thickness(map, config);
    benchmark::DoNotOptimize(result);
  }
  set_points(state, map.size());
  state.counters["planes"] = static_cast<double>(result.planes);
}
BENCHMARK(BM_PlaneThicknessStage2Map)->Unit(benchmark::kMillisecond)->UseRealTime();

// The Gauss-Newton normal equations of the continuous method are internal to refine.cpp; the
// smallest public entry point is the whole stage. Run with a fixed number of iterations, no time
// offset (so no occupancy scan), starting at the truth; one evaluation = place the map, (re)fit or
// refresh planes, build the 7x7 system. The frames are reduced once, before timing; the
// cost of one evaluation is the difference between the 4- and 1-iteration runs divided by 3.
void BM_RefineContinuousStage(benchmark::State& state) {
  const Drive& d = drive();
  RefineConfig config;
  config.method = RefineMethod::kContinuous;
  config.estimate_time_offset = false;
  config.max_iterations = static_cast<int>(state.range(0));
  config.converged_rot_deg = 0.0;
  config.converged_trans_m = 0.0;
  RefineResult r;
  const FrameStore store = make_frame_store(d.data, PipelineConfig{});
  const std::vector<std::size_t> frames = refine_frames(store, config, 0.0, 0.0);
  (void)store.thinned(frames, config.filter);
  for (auto _ : state) {
    r = refine_extrinsic(store, frames, d.T_ins_lidar(), 0.0, config);
    benchmark::DoNotOptimize(r.T_ins_lidar);
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) *
                          static_cast<std::int64_t>(r.points_used) * r.evaluations);
  state.counters["points"] = static_cast<double>(r.points_used);
  state.counters["frames"] = static_cast<double>(r.frames_used);
  state.counters["evals"] = static_cast<double>(r.evaluations);
  state.counters["planes"] = static_cast<double>(r.planes_used);
}
BENCHMARK(BM_RefineContinuousStage)->Arg(1)->Arg(4)->ArgName("iterations")->Unit(benchmark::kMillisecond)->UseRealTime();

// The moving-point mask (rays of every rendered frame through the evidence voxels) on one thread,
// so that the time is the work, whatever else the machine runs. Items: ray samples are not
// counted; points of the sample frames are.
void BM_MovingPointsMask(benchmark::State& state) {
  const Drive& d = drive();
  const FrameStore store = make_frame_store(d.data, PipelineConfig{});
  std::vector<std::size_t> frames;
  for (std::size_t i = kFirstFrame; i < d.data.frames.frames.size(); ++i) frames.push_back(i);
  store.load(frames);
  const tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
  MovingPointsConfig config;
  MovingPointsResult r;
  for (auto _ : state) {
    benchmark::DoNotOptimize(find_moving_points(store, d.T_ins_lidar(), 0.0, config, r));
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) * static_cast<std::int64_t>(r.points_checked));
  state.counters["frames"] = static_cast<double>(r.frames_used);
  state.counters["voxels_judged"] = static_cast<double>(r.voxels_judged);
}
BENCHMARK(BM_MovingPointsMask)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace insalign

BENCHMARK_MAIN();
