// The whole pipeline on a short simulated drive: each stage must earn its place.
#include <gtest/gtest.h>

#include <cmath>

#include "core/pipeline.hpp"
#include "sim/simulate.hpp"
#include "sim/world_dataset.hpp"

namespace insalign {
namespace {

// Unsynchronised clocks are what stage 1 cannot model (one pose per sweep, no offset): it lands
// centimetres off. Stage 2 must find the offset and improve on stage 1's real output.
TEST(Pipeline, Stage2ImprovesStage1WhenTheClocksDiffer) {
  sim::SimConfig sc;
  sc.seed = 5;
  sc.duration_s = 40.0;
  sc.azimuth_step_deg = 1.0;
  sc.time_offset_s = 0.035;
  const auto world = std::make_shared<const sim::World>(sim::build_world(sc));
  const Dataset data = sim::world_dataset(world);  // starts from the simulator's 20 deg / 0.5 m guess
  PipelineConfig config;
  config.repeatability.segments = 2;
  const FrameStore store = make_frame_store(data, config);
  // Work beside the repeatability study (the report's maps) sees the final extrinsic.
  int beside_calls = 0;
  Iso3 T_beside = Iso3::Identity();
  double offset_beside = NAN;
  const CalibrationResult r = run_calibration(store, config, {}, [&](const CalibrationResult& before) {
    ++beside_calls;
    T_beside = before.T_ins_lidar;
    offset_beside = before.time_offset_s;
  });
  EXPECT_EQ(beside_calls, 1);
  // The start is the data's hand-eye solution on a turning drive: stage 1 skips its rounds of
  // one-group windows (they bring a far start into the basin), and its last (stage 2 follows).
  EXPECT_TRUE(start_is_near(r.init)) << r.init.explanation;
  EXPECT_EQ(r.rough.convergence.size() - (r.rough.tz_estimated ? 1 : 0), multi_group_rounds(config.rough.rounds).size() - 1);
  EXPECT_TRUE(T_beside.isApprox(r.T_ins_lidar, 0.0));
  EXPECT_EQ(offset_beside, r.time_offset_s);
  ASSERT_TRUE(r.refine.has_value());
  const ExtrinsicError rough = extrinsic_error(r.rough.T_ins_lidar, world->T_ins_lidar_true);
  const ExtrinsicError refined = extrinsic_error(r.refine->T_ins_lidar, world->T_ins_lidar_true);
  EXPECT_LT(refined.dt_m.head<2>().norm(), rough.dt_m.head<2>().norm());
  EXPECT_LT(refined.dt_m.head<2>().maxCoeff(), 0.01);
  EXPECT_LT(refined.drpy_deg.maxCoeff(), 0.03);
  EXPECT_NEAR(r.time_offset_s, sc.time_offset_s, 0.002);
  for (const std::string& w : r.warnings) EXPECT_EQ(w.find("stage 2 moved"), std::string::npos) << w;
  // The reported stddev is never below what the segments' disagreement shows.
  const auto& segments = r.repeatability.segments;
  ASSERT_EQ(segments.size(), 2u);
  ASSERT_TRUE(segments[0].ok && segments[1].ok) << segments[0].message << segments[1].message;
  for (int i : {0, 1, 3, 4, 5})
    EXPECT_GE(r.stddev[i], r.repeatability.spread[i] / (1.128 * std::sqrt(2.0)) - 1e-12) << i;
  // Sweeps are decoded once however many stages and segments read them.
  EXPECT_LE(r.frames_decoded, data.frames.frames.size());
  std::printf("segments ok: %d %d; rough: %.1f mm, %.4f deg; refined: %.1f mm, %.4f deg; offset %.2f ms\n",
              int(segments[0].ok), int(segments[1].ok),
              1e3 * rough.dt_m.head<2>().norm(), rough.angle_deg, 1e3 * refined.dt_m.head<2>().norm(),
              refined.angle_deg, 1e3 * r.time_offset_s);
}

// Stages 1 and 2 keep tz fixed, and the car rolls in turns: a tz error then shows as a sideways
// shift that the lateral lever arm absorbs. The pipeline fixes tz (stage 3) before stage 2, so
// with perfect poses the horizontal lever arm comes out right although the guess had tz 0.4 m off.
TEST(Pipeline, TzErrorOfTheGuessDoesNotLeakIntoTheHorizontalLeverArm) {
  sim::SimConfig sc;
  sc.seed = 8;
  sc.duration_s = 40.0;
  sc.azimuth_step_deg = 1.0;
  sc.speed_kmh = 20.0;  // ~1.2 deg of body roll in the turns
  sc.ins_noise_scale = 0.0;
  const auto world = std::make_shared<const sim::World>(sim::build_world(sc));
  Dataset data = sim::world_dataset(world);
  Iso3 T_guess = world->T_ins_lidar_true;
  T_guess.translation() += Vec3(0.02, -0.02, 0.4);
  T_guess.linear() = so3_exp(Vec3(1.0, -1.0, 2.0) * kRadPerDeg) * T_guess.linear();
  data.T_ins_lidar_init = T_guess;
  PipelineConfig config;
  config.repeatability.segments = 0;
  const FrameStore store = make_frame_store(data, config);
  const CalibrationResult r = run_calibration(store, config);
  ASSERT_TRUE(r.z.determined()) << r.z.outcome.message;
  const ExtrinsicError rough = extrinsic_error(r.rough.T_ins_lidar, world->T_ins_lidar_true);
  const ExtrinsicError final_error = extrinsic_error(r.T_ins_lidar, world->T_ins_lidar_true);
  std::printf("horizontal lever arm error: stage 1 (tz 0.4 m off) %.2f mm, final %.2f mm; tz %.1f mm\n",
              1e3 * rough.dt_m.head<2>().norm(), 1e3 * final_error.dt_m.head<2>().norm(), 1e3 * final_error.dt_m[2]);
  EXPECT_LT(final_error.dt_m.head<2>().norm(), 0.001);
  EXPECT_LT(std::abs(final_error.dt_m[2]), 0.01);
}

}  // namespace
}  // namespace insalign
