// Points on moving things (core/moving_points.hpp): on a drive through 20 cars and 30 people the
// mask finds the simulator's mover points (precision and recall against its per-point ground
// truth), leaves the static street alone on a drive without traffic, and the calibration with
// the mask stays within the stated bounds, tz from the fiducials included.
#include <gtest/gtest.h>

#include <memory>

#include "core/moving_points.hpp"
#include "core/pipeline.hpp"
#include "mover_score.hpp"
#include "sim/simulate.hpp"
#include "sim/world_dataset.hpp"

namespace insalign {
namespace {

sim::SimConfig drive(int traffic, int pedestrians) {
  sim::SimConfig sc;
  sc.seed = 3;
  sc.azimuth_step_deg = 1.0;
  sc.duration_s = 60.0;
  sc.traffic = traffic;
  sc.pedestrians = pedestrians;
  return sc;
}


TEST(MovingPoints, StaticStreetIsLeftAlone) {
  const auto world = std::make_shared<const sim::World>(sim::build_world(drive(0, 0)));
  const Dataset data = sim::world_dataset(world);
  const PipelineConfig config;
  const FrameStore store = make_frame_store(data, config);
  MovingPointsResult r;
  const auto mask = find_moving_points(store, world->T_ins_lidar_true, 0.0, config.moving, r);
  ASSERT_TRUE(mask);
  const testing::MoverScore s = testing::mover_score(*world, 0, *mask);
  std::printf("static street: %.2f%% of the points taken for movers\n", 100.0 * s.fp / s.all);
  EXPECT_LT(static_cast<double>(s.fp) / s.all, 0.01) << "static points taken for movers";
}

TEST(MovingPoints, TrafficIsMaskedAndTheResultStaysWithinBounds) {
  const auto world = std::make_shared<const sim::World>(sim::build_world(drive(20, 30)));
  const Dataset data = sim::world_dataset(world);
  PipelineConfig config;
  config.repeatability.segments = 0;
  const CalibrationResult r = run_calibration(make_frame_store(data, config), config);
  ASSERT_TRUE(r.moving.applied && r.moving.mask);
  const testing::MoverScore s = testing::mover_score(*world, 0, *r.moving.mask);
  const ExtrinsicError e = extrinsic_error(r.T_ins_lidar, world->T_ins_lidar_true);
  std::printf("movers %.2f%% of points: precision %.3f recall %.3f; |t| %.1f %.1f %.1f mm |rpy| %.4f %.4f %.4f deg\n",
              100.0 * (s.tp + s.fn) / s.all, s.precision(), s.recall(), 1e3 * e.dt_m.x(), 1e3 * e.dt_m.y(),
              1e3 * e.dt_m.z(), e.drpy_deg.x(), e.drpy_deg.y(), e.drpy_deg.z());
  ASSERT_GT(s.tp + s.fn, s.all / 200) << "the drive meets traffic";
  EXPECT_GT(s.recall(), 0.85);
  EXPECT_GT(s.precision(), 0.6);
  EXPECT_LT(e.drpy_deg.maxCoeff(), 0.03);
  EXPECT_LT(e.dt_m.head<2>().maxCoeff(), 0.01);
  // tz from the fiducials: within what drives without traffic give (issue 17: 27 mm worst of seven;
  // this drive's scene gives 20 mm without traffic at this resolution, bench/RESULTS.md).
  EXPECT_LT(e.dt_m.z(), 0.027);
  EXPECT_TRUE(r.z.determined());
}

}  // namespace
}  // namespace insalign
