// `check` on a drive longer than its budget uses only the stretches it chose; the rest is left out
// of every stage, but that is the check's choice, not an INS fault. On a 4-minute city loop with
// an RTK-fixed INS (the budget cut to 90 s to keep the test short), nothing may blame the INS:
// no span in the result's `excluded`, no "the INS looks wrong" advice (it said "302.4 s of the
// drive, 6 stretches" on every 10-minute check before).
#include <gtest/gtest.h>

#include <string>

#include "core/check_run.hpp"
#include "sim/simulate.hpp"
#include "sim/world_dataset.hpp"

namespace insalign {
namespace {

TEST(CheckStretches, StretchesNotChosenDoNotBlameTheIns) {
  sim::SimConfig sc;
  sc.seed = 31;
  sc.trajectory = sim::TrajectoryKind::kCityLoop;
  sc.duration_s = 240.0;
  sc.azimuth_step_deg = 0.8;
  const auto world = std::make_shared<const sim::World>(sim::build_world(sc));
  Dataset data = sim::world_dataset(world);
  const sim::SimLidar& lidar = world->lidars.front();
  data.T_ins_lidar_init = lidar.T_ins_lidar_installed;
  data.time_offset_init_s = lidar.time_offset_s;
  const PipelineConfig pipeline;
  CheckRunConfig config;
  config.stretches.budget_s = 90.0;
  const CheckRun run = run_check(make_frame_store(data, pipeline), lidar.T_ins_lidar_installed, lidar.time_offset_s,
                                 pipeline, config);
  ASSERT_TRUE(run.result.has_value()) << run.why_unobservable;
  double used_s = 0.0;
  for (const Stretch& s : run.used) used_s += s.end_s - s.begin_s;
  EXPECT_LT(used_s, 0.6 * sc.duration_s);  // the check did leave most of the drive out
  EXPECT_TRUE(run.result->excluded.empty()) << run.result->excluded.front().reason;
  for (const std::string& w : run.findings.warnings) EXPECT_EQ(w.find("INS looks wrong"), std::string::npos) << w;
  EXPECT_NE(run.findings.verdict, CheckVerdict::kRecalibrate) << run.findings.message;
}

}  // namespace
}  // namespace insalign
