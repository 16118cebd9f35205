#include "core/frames.hpp"

#include "core/frame_store.hpp"
#include "core/refine.hpp"

#include <gtest/gtest.h>

namespace insalign {
namespace {

// A straight drive of n frames, one metre apart.
DriveFrames straight(std::size_t n) {
  DriveFrames d;
  for (std::size_t i = 0; i < n; ++i) {
    d.index.push_back(i);
    d.t_end_s.push_back(0.1 * static_cast<double>(i));
    d.motion_m.push_back(static_cast<double>(i));
    d.T_world_ins.push_back(Iso3(Eigen::Translation3d(static_cast<double>(i), 0.0, 0.0)));
  }
  return d;
}

TEST(SpreadOverMotion, PicksTheSliceCentres) {
  EXPECT_EQ(spread_over_motion(straight(101), 4), (std::vector<std::size_t>{13, 38, 63, 88}));
}

TEST(SpreadOverMotion, PrefersADecodedFrameInsideItsSliceOnly) {
  DriveFrames d = straight(101);
  d.decoded.assign(d.size(), 0);
  // Slices [0, 25], [25, 50], [50, 75], [75, 100]: each takes its decoded frame, however far
  // from the centre, and never one of another slice.
  d.decoded[20] = 1;
  d.decoded[45] = 1;
  d.decoded[51] = 1;
  d.decoded[99] = 1;
  EXPECT_EQ(spread_over_motion(d, 4), (std::vector<std::size_t>{20, 45, 51, 99}));
  d.decoded.assign(d.size(), 0);
  d.decoded[60] = 1;  // the third slice's only decoded frame; the others keep their centres
  EXPECT_EQ(spread_over_motion(d, 4), (std::vector<std::size_t>{13, 38, 60, 88}));
}

// The trajectory correction's frames: stage 2's and more at equal steps of motion between them.
TEST(FillBetween, AddsFramesAtEqualMotionStepsBetweenTheGivenOnes) {
  DriveFrames d = straight(101);
  for (std::size_t i = 0; i < d.size(); ++i) d.index[i] = 1000 + 2 * i;  // dataset indices are not positions
  const std::vector<std::size_t> stage2 = {1000 + 2 * 13, 1000 + 2 * 38, 1000 + 2 * 63, 1000 + 2 * 88};
  EXPECT_EQ(fill_between(d, stage2, 0), stage2);
  // Halfway: 25.5 and 50.5 m round to the nearer frame (25 and 50: ties keep the earlier one).
  EXPECT_EQ(fill_between(d, stage2, 1), (std::vector<std::size_t>{1026, 1050, 1076, 1100, 1126, 1150, 1176}));
  EXPECT_EQ(fill_between(d, {1000 + 2 * 13, 1000 + 2 * 38}, 4),
            (std::vector<std::size_t>{1026, 1036, 1046, 1056, 1066, 1076}));
  // Neighbours leave no room: no repeats, nothing beyond them; a frame not in the drive is dropped.
  EXPECT_EQ(fill_between(d, {1000, 1002, 1004, 7}, 3), (std::vector<std::size_t>{1000, 1002, 1004}));
  // Uneven motion (a stop): the steps are of motion, not of frames.
  DriveFrames stop = straight(11);
  for (std::size_t i = 0; i < stop.size(); ++i) stop.motion_m[i] = i <= 5 ? 0.1 * static_cast<double>(i) : 0.5 + (i - 5.0);
  EXPECT_EQ(fill_between(stop, {0, 10}, 1), (std::vector<std::size_t>{0, 7, 10}));  // 2.75 m: frame 7 (2.5 m), not 5
}

// A straight 10 m/s drive of 101 frames at 10 Hz, poses at 100 Hz, empty sweeps.
Dataset straight_dataset() {
  Dataset data;
  std::vector<Sweep> sweeps(101);
  for (std::size_t i = 0; i < sweeps.size(); ++i) sweeps[i].t_end_s = 1.0 + 0.1 * static_cast<double>(i);
  data.frames = frame_source_from(std::move(sweeps));
  std::vector<StampedPose> poses;
  for (int k = 0; k <= 1200; ++k) poses.push_back({0.01 * k, Iso3(Eigen::Translation3d(0.1 * k, 0.0, 0.0))});
  data.poses = PoseStream(std::move(poses));
  return data;
}

TEST(CheckSample, TakesTheDecodedFramesWhenThereAreEnough) {
  const Dataset data = straight_dataset();
  const FrameStore store(data, SweepFilter{});
  EXPECT_EQ(check_sample(store, 10).size(), 10u);  // nothing decoded: spread over every frame
  const std::vector<std::size_t> used = {10, 11, 12, 13, 50, 51, 52, 90};
  store.load(used);
  EXPECT_EQ(check_sample(store, 10), used);  // at least n / 2 decoded, at most n: all of them
  // More than n: n of them, evenly in time order.
  EXPECT_EQ(check_sample(store, 4), (std::vector<std::size_t>{10, 12, 50, 52}));
  const std::vector<std::size_t> spread = check_sample(store, 40);  // fewer than n / 2: every frame's
  EXPECT_GE(spread.size(), 36u);
  EXPECT_LE(spread.front(), 3u);
  EXPECT_GE(spread.back(), 97u);
  EXPECT_EQ(store.frames_decoded(), used.size());
}

// Stage 2 takes its slices' centres whatever is decoded: frames pulled toward stage 1's groups
// cost yaw accuracy (bench/RESULTS.md, paper_tables before and after).
TEST(RefineFrames, DoNotFollowTheDecodedFrames) {
  const Dataset data = straight_dataset();
  const FrameStore store(data, SweepFilter{});
  RefineConfig config;
  config.max_frames = 10;
  config.min_motion_m = 0.1;
  const std::vector<std::size_t> fresh = refine_frames(store, config, 0.0, 0.0);
  ASSERT_EQ(fresh.size(), 10u);
  std::vector<std::size_t> near;
  for (std::size_t i : fresh) near.push_back(i + 2);
  store.load(near);
  EXPECT_EQ(refine_frames(store, config, 0.0, 0.0), fresh);
}

// A fast drive gets more frames than max_frames, so that they lie at most max_spacing_m apart
// (their near fields overlap): the straight drive is 100 m long, a frame every metre.
TEST(RefineFrames, NoFartherApartThanMaxSpacing) {
  const Dataset data = straight_dataset();
  const FrameStore store(data, SweepFilter{});
  RefineConfig config;
  config.max_frames = 4;
  config.max_spacing_m = 0.0;
  EXPECT_EQ(refine_frames(store, config, 0.0, 0.0).size(), 4u);
  config.max_spacing_m = 50.0;  // 4 frames are closer than that already
  EXPECT_EQ(refine_frames(store, config, 0.0, 0.0).size(), 4u);
  config.max_spacing_m = 10.0;
  const std::vector<std::size_t> picked = refine_frames(store, config, 0.0, 0.0);
  EXPECT_GE(picked.size(), 10u);
  for (std::size_t k = 1; k < picked.size(); ++k) EXPECT_LE(picked[k] - picked[k - 1], 11u) << k;
}

// The straight drive with frames told apart by extra points (frame i has i % 5 + 1 more).
Dataset distinct_frames_dataset() {
  Dataset data = straight_dataset();
  auto load = data.frames.load;
  data.frames.load = [load](std::size_t i) {
    Sweep s = load(i);
    for (std::size_t k = 0; k <= i % 5; ++k) s.p_lidar.emplace_back(float(i), float(k), 1.0f);
    return s;
  };
  return data;
}

// forget() drops what a step no longer needs, keeps what it is told to, and a forgotten frame
// decodes again, the same, when a later reader asks for it.
TEST(FrameStoreForget, KeepsWhatItIsToldAndDecodesTheRestAgain) {
  const Dataset data = distinct_frames_dataset();
  const FrameStore store(data, SweepFilter{});
  store.load({3, 4, 7});
  const Sweep before = store.reduced(7);
  store.forget({4});
  EXPECT_FALSE(store.is_decoded(3));
  EXPECT_TRUE(store.is_decoded(4));
  EXPECT_FALSE(store.is_decoded(7));
  EXPECT_EQ(store.frames_decoded(), 3u);
  const Sweep& again = store.reduced(7);  // decoded again: counted again
  EXPECT_EQ(store.frames_decoded(), 4u);
  ASSERT_EQ(again.size(), before.size());
  for (std::size_t k = 0; k < again.size(); ++k) EXPECT_EQ(again.p_lidar[k], before.p_lidar[k]);
  store.forget();
  for (std::size_t i : {3, 4, 7}) EXPECT_FALSE(store.is_decoded(i)) << i;
}

// thinned(..., keep_decoded = false): what is not decoded yet is decoded for the call only (the
// trajectory correction's frames), what is stays; the copies equal the stored path's.
TEST(FrameStoreThinned, WithoutKeepingDecodesForTheCallOnly) {
  const Dataset data = distinct_frames_dataset();
  const FrameStore store(data, SweepFilter{});
  store.load({4});
  const std::vector<Sweep> transient = store.thinned({3, 4}, SweepFilter{}, /*keep_decoded=*/false);
  EXPECT_FALSE(store.is_decoded(3));
  EXPECT_TRUE(store.is_decoded(4));
  EXPECT_EQ(store.frames_decoded(), 2u);  // 4 once, 3 for the call
  const std::vector<Sweep> stored = store.thinned({3, 4}, SweepFilter{});
  EXPECT_TRUE(store.is_decoded(3));
  for (std::size_t f : {0u, 1u}) {
    ASSERT_EQ(transient[f].size(), stored[f].size());
    for (std::size_t k = 0; k < stored[f].size(); ++k) EXPECT_EQ(transient[f].p_lidar[k], stored[f].p_lidar[k]);
  }
}

}  // namespace
}  // namespace insalign
