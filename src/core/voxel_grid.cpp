#include "core/voxel_grid.hpp"

#include <unordered_map>

namespace insalign {

std::vector<std::uint32_t> voxel_downsample_indices(std::span<const Vec3f> points, double voxel_m) {
  std::vector<std::uint32_t> kept;
  if (voxel_m <= 0.0) {
    kept.resize(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) kept[i] = static_cast<std::uint32_t>(i);
    return kept;
  }
  const double inv = 1.0 / voxel_m;
  // Open addressing on packed keys: several times faster than std::unordered_set per sweep.
  std::size_t capacity = 1024;
  while (capacity < 2 * points.size()) capacity <<= 1;
  constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
  std::vector<std::uint64_t> table(capacity, kEmpty);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const std::uint64_t key = voxel_key(points[i], inv);
    std::size_t slot = (key * 0x9E3779B97F4A7C15ull) >> 20 & (capacity - 1);
    while (table[slot] != kEmpty && table[slot] != key) slot = (slot + 1) & (capacity - 1);
    if (table[slot] == kEmpty) {
      table[slot] = key;
      kept.push_back(static_cast<std::uint32_t>(i));
    }
  }
  return kept;
}

std::vector<Vec3f> voxel_downsample(std::span<const Vec3f> points, double voxel_m) {
  std::vector<Vec3f> out;
  for (std::uint32_t i : voxel_downsample_indices(points, voxel_m)) out.push_back(points[i]);
  return out;
}

std::vector<Vec3> voxel_centroids(const std::vector<Vec3>& points, double voxel_m) {
  const double inv = 1.0 / voxel_m;
  std::unordered_map<std::uint64_t, std::uint32_t> slot;
  slot.reserve(points.size());
  std::vector<Vec3> sum;
  std::vector<int> count;
  for (const Vec3& p : points) {
    auto [it, inserted] = slot.try_emplace(voxel_key(p, inv), static_cast<std::uint32_t>(sum.size()));
    if (inserted) {
      sum.push_back(p);
      count.push_back(1);
    } else {
      sum[it->second] += p;
      ++count[it->second];
    }
  }
  for (std::size_t i = 0; i < sum.size(); ++i) sum[i] /= static_cast<double>(count[i]);
  return sum;
}

}  // namespace insalign
