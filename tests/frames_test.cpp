#include "core/frames.hpp"

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

}  // namespace
}  // namespace insalign
