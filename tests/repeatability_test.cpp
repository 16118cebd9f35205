// The repeatability study's segments: each must settle on its own data, not echo its start.
#include <gtest/gtest.h>

#include "core/repeatability.hpp"
#include "test_world.hpp"

namespace insalign {
namespace {

// Three figure-8 loops, one per segment, with exact poses and a "full result" 2 cm and 0.1 deg
// off the truth: whatever a segment runs, it must end near the truth, away from that start (every
// rotation bound below is under 0.1 deg: a segment that kept its start fails).
struct Study {
  testing::TestDrive drive;
  FrameStore store;
  RepeatabilityInputs in;

  Study()
      : drive(testing::town_drive(testing::Drive::kFigure8, testing::roof_mount(30.0), 720, 3)),
        store(testing::store_of(drive.data)) {
    const PipelineConfig config;
    in.rough_groups = rough_frame_groups(store, config.rough);
    in.refine_frames = refine_frames(store, config.refine, 0.0, refine_margin_s(config.refine));
    in.T_ins_lidar_full = testing::perturbed(drive.T_ins_lidar_true, 0.1, 0.02, 7);
    in.T_ins_lidar_full.translation().z() = drive.T_ins_lidar_true.translation().z();  // stage 3's tz
    in.T_ins_lidar_start = in.T_ins_lidar_full;
    in.max_speed_mps = 6.0;
  }

  RepeatabilityResult run(int rough_rounds) const {
    const PipelineConfig config;
    RepeatabilityConfig study = config.repeatability;
    study.rough_rounds = rough_rounds;
    return run_repeatability(store, in, config.rough, config.refine, study);
  }
};

void expect_segments_near_truth(const RepeatabilityResult& r, const Iso3& T_true, double trans_m, double rot_deg) {
  ASSERT_EQ(r.segments.size(), 3u);
  ASSERT_EQ(r.segments_ok, 3);
  for (const SegmentResult& s : r.segments) {
    const ExtrinsicError e = extrinsic_error(s.T_ins_lidar, T_true);
    EXPECT_LT(e.dt_m.head<2>().norm(), trans_m) << s.t_begin_s;
    EXPECT_LT(e.angle_deg, rot_deg) << s.t_begin_s;
  }
}

TEST(Repeatability, SegmentsSettleOnTheirOwnData) {
  const Study study;
  // The default: stage 2 alone from the full result; then with stage 1's last round first.
  const RepeatabilityResult alone = study.run(0), one_round = study.run(1);
  expect_segments_near_truth(alone, study.drive.T_ins_lidar_true, 0.005, 0.02);
  expect_segments_near_truth(one_round, study.drive.T_ins_lidar_true, 0.005, 0.02);
  // Both measure the same thing: their spreads agree to a fraction of the error they bound.
  for (int i : {0, 1}) EXPECT_NEAR(alone.spread[i], one_round.spread[i], 0.002) << i;
  for (int i : {3, 4, 5}) EXPECT_NEAR(alone.spread[i], one_round.spread[i], 0.01 * kRadPerDeg) << i;
}

TEST(Repeatability, SegmentsWithoutStage2RunStage1) {
  Study study;
  study.in.refine_frames.clear();
  const RepeatabilityResult r = study.run(0);
  // Stage 1's last round alone is coarser than stage 2, but it has left the start.
  expect_segments_near_truth(r, study.drive.T_ins_lidar_true, 0.015, 0.08);
}

}  // namespace
}  // namespace insalign
