#include "core/voxel_grid.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <unordered_map>

namespace insalign {
namespace {

TEST(VoxelGrid, CellsFloorTowardsMinusInfinity) {
  EXPECT_EQ(voxel_cell(Vec3(-0.01, 0.0, 0.99), 1.0), (VoxelCell{-1, 0, 0}));
  EXPECT_EQ(voxel_cell(Vec3f(0.3f, -0.3f, 1.0f), 4.0), (VoxelCell{1, -2, 4}));
}

TEST(VoxelGrid, KeysSeparateNeighboursAndSortLikeCells) {
  const VoxelCell a{-3, 5, 7}, b{-3, 5, 8}, c{-2, -100, 0};
  EXPECT_NE(voxel_key(a), voxel_key(b));
  EXPECT_LT(voxel_key(a), voxel_key(b));
  EXPECT_LT(voxel_key(b), voxel_key(c));
  EXPECT_EQ(voxel_key(Vec3f(0.05f, 0.05f, 0.05f), 10.0), voxel_key(Vec3(0.09, 0.01, 0.0), 10.0));
}

TEST(VoxelGrid, DownsampleKeepsTheFirstPointPerVoxelInInputOrder) {
  const std::vector<Vec3f> pts{{0.01f, 0.01f, 0.01f}, {0.02f, 0.02f, 0.02f}, {0.3f, 0.0f, 0.0f}, {-0.01f, 0.0f, 0.0f},
                               {0.24f, 0.24f, 0.24f}};
  EXPECT_EQ(voxel_downsample_indices(pts, 0.25), (std::vector<std::uint32_t>{0, 2, 3}));
  EXPECT_EQ(voxel_downsample_indices(pts, 0.0).size(), pts.size());
  const std::vector<Vec3f> kept = voxel_downsample(pts, 0.25);
  ASSERT_EQ(kept.size(), 3u);
  EXPECT_EQ(kept[1], pts[2]);
}

// Through many doublings, with keys that collide in the low bits (neighbouring cells), the flat
// map holds what std::unordered_map holds.
// Grouping by voxel is sorting (key, index) pairs: on a compact cloud (the counting sort over its
// box) and on ones spread far wider than it has points (the radix sort over its box's bits).
TEST(VoxelGrid, GroupsAreSortedKeyIndexPairs) {
  std::mt19937 rng(7);
  for (const float spread_m : {30.0f, 300.0f, 30000.0f}) {  // counting sort, 32-bit and 64-bit radix
    std::uniform_real_distribution<float> u(-spread_m, spread_m);
    std::vector<Vec3f> pts(20000);
    for (Vec3f& p : pts) p = Vec3f(u(rng), u(rng), 0.01f * u(rng));
    for (std::size_t i = 0; i < 2000; ++i) pts.push_back(pts[i * 7] + Vec3f(0.01f, 0.0f, 0.0f));  // shared voxels
    std::vector<std::pair<std::uint64_t, std::uint32_t>> sorted;
    for (std::uint32_t i = 0; i < pts.size(); ++i) sorted.emplace_back(voxel_key(pts[i], 1.0 / 0.5), i);
    std::sort(sorted.begin(), sorted.end());
    const VoxelGroups groups = group_by_voxel(pts, 0.5);
    ASSERT_EQ(groups.order.size(), pts.size());
    for (std::size_t i = 0; i < pts.size(); ++i) ASSERT_EQ(groups.order[i], sorted[i].second) << spread_m << " " << i;
    std::size_t runs = 0;
    for (std::size_t i = 0; i < sorted.size(); ++i) runs += i == 0 || sorted[i].first != sorted[i - 1].first;
    ASSERT_EQ(groups.size(), runs) << spread_m;
    for (std::size_t k = 0; k < groups.size(); ++k) {
      EXPECT_EQ(sorted[groups.begin[k]].first, sorted[groups.begin[k + 1] - 1].first);
      if (k > 0) {
        EXPECT_NE(sorted[groups.begin[k]].first, sorted[groups.begin[k] - 1].first);
      }
    }
  }
}

TEST(VoxelGrid, KeyMapAgreesWithAnUnorderedMapThroughGrowth) {
  std::mt19937_64 rng(5);
  std::uniform_int_distribution<int> cell(-40, 40);
  VoxelKeyMap<int> flat;  // starts at 16 slots
  std::unordered_map<std::uint64_t, int> reference;
  for (int i = 0; i < 20000; ++i) {
    const std::uint64_t key = voxel_key(VoxelCell{cell(rng), cell(rng), cell(rng) / 8});
    flat[key] += i % 7;
    reference[key] += i % 7;
  }
  ASSERT_EQ(flat.size(), reference.size());
  for (const auto& [key, value] : reference) {
    const int* found = flat.find(key);
    ASSERT_NE(found, nullptr);
    EXPECT_EQ(*found, value);
  }
  std::size_t visited = 0;
  flat.for_each([&](std::uint64_t key, int value) {
    ++visited;
    EXPECT_EQ(reference.at(key), value);
  });
  EXPECT_EQ(visited, reference.size());
  EXPECT_EQ(flat.find(voxel_key(VoxelCell{1000, 0, 0})), nullptr);
}

}  // namespace
}  // namespace insalign
