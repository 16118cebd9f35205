// The accuracy gate under ctest: the whole pipeline on a few simulated drives at reduced
// resolution, from the simulator's 20 deg / 0.5 m wrong guess, asserting the bounds the README
// states for every run (bench/paper_tables measures the full-resolution numbers).
#include <gtest/gtest.h>

#include "core/pipeline.hpp"
#include "sim/simulate.hpp"
#include "sim/world_dataset.hpp"

namespace insalign {
namespace {

class AccuracyGate : public ::testing::TestWithParam<int> {};

TEST_P(AccuracyGate, EveryRunWithinTheStatedBounds) {
  sim::SimConfig sc;
  sc.seed = static_cast<std::uint64_t>(GetParam());
  sc.azimuth_step_deg = 0.8;  // 450 columns instead of 1800: a quarter of the points
  sc.duration_s = 75.0;       // one and a half figure-8s
  const auto world = std::make_shared<const sim::World>(sim::build_world(sc));
  const Dataset data = sim::world_dataset(world);
  PipelineConfig config;
  config.repeatability.segments = 0;
  const FrameStore store = make_frame_store(data, config);
  const CalibrationResult r = run_calibration(store, config);
  const ExtrinsicError e = extrinsic_error(r.T_ins_lidar, world->T_ins_lidar_true);
  std::printf("seed %d: |t| %.1f %.1f %.1f mm, |rpy| %.4f %.4f %.4f deg, offset %.2f ms, %.1f s\n", GetParam(),
              1e3 * e.dt_m.x(), 1e3 * e.dt_m.y(), 1e3 * e.dt_m.z(), e.drpy_deg.x(), e.drpy_deg.y(), e.drpy_deg.z(),
              1e3 * r.time_offset_s, r.wall_time_s);
  // Stage 2's bounds (every run): 0.03 deg per axis, 1 cm in x and y; stage 3's: tz within 2 cm.
  EXPECT_LT(e.drpy_deg.maxCoeff(), 0.03);
  EXPECT_LT(e.dt_m.head<2>().maxCoeff(), 0.01);
  EXPECT_LT(e.dt_m.z(), 0.02);
  EXPECT_LT(std::abs(r.time_offset_s - sc.time_offset_s), 0.002);
  for (bool d : r.determined) EXPECT_TRUE(d);
}

INSTANTIATE_TEST_SUITE_P(Seeds, AccuracyGate, ::testing::Values(21, 22, 23));

}  // namespace
}  // namespace insalign
