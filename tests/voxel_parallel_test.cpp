// The parallel paths of the voxel grid (big clouds: stitched maps, the time-offset scan's counts)
// give exactly what the one-thread definitions give: first point met per voxel, in input order,
// and the number of distinct keys.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <unordered_set>

#include "core/voxel_grid.hpp"

namespace insalign {
namespace {

std::vector<Vec3f> random_cloud(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-40.0f, 40.0f), z(-2.0f, 6.0f);
  std::vector<Vec3f> p(n);
  for (auto& q : p) q = Vec3f(u(rng), u(rng), z(rng));
  return p;
}

TEST(VoxelParallel, DownsampleOfABigCloudKeepsTheFirstPointPerVoxelInInputOrder) {
  const std::vector<Vec3f> p = random_cloud(1'200'000, 7);  // above the parallel threshold
  for (double voxel_m : {0.05, 0.3}) {
    std::vector<std::uint32_t> expected;
    std::unordered_set<std::uint64_t> seen;
    for (std::size_t i = 0; i < p.size(); ++i)
      if (seen.insert(voxel_key(p[i], 1.0 / voxel_m)).second) expected.push_back(static_cast<std::uint32_t>(i));
    EXPECT_EQ(voxel_downsample_indices(p, voxel_m), expected) << voxel_m;
  }
}

TEST(VoxelParallel, DistinctKeysCountedExactly) {
  const std::vector<Vec3f> p = random_cloud(500'000, 3);
  std::vector<std::uint64_t> keys;
  for (const Vec3f& q : p) keys.push_back(voxel_key(q, 1.0 / 0.1));
  std::vector<std::uint64_t> sorted = keys;
  std::sort(sorted.begin(), sorted.end());
  const auto distinct = static_cast<std::size_t>(std::unique(sorted.begin(), sorted.end()) - sorted.begin());
  EXPECT_EQ(count_distinct_keys(keys), distinct);
  EXPECT_EQ(count_distinct_keys({}), 0u);
  EXPECT_LT(distinct, keys.size());  // the cloud does repeat voxels
}

}  // namespace
}  // namespace insalign
