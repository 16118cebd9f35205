// Regular voxel grids shared by the stages: the integer cell of a point, one 64-bit key per cell,
// and downsampling to one point per cell.
#pragma once

#include <cmath>
#include <cstdint>
#include <span>
#include <tuple>
#include <vector>

#include "core/geometry.hpp"

namespace insalign {

/// Integer coordinates of a cube of the grid: cell = floor(p / voxel_m).
struct VoxelCell {
  std::int64_t x = 0, y = 0, z = 0;
  bool operator==(const VoxelCell&) const = default;
  bool operator<(const VoxelCell& o) const { return std::tie(x, y, z) < std::tie(o.x, o.y, o.z); }
};

/// floor(x) as an integer, for finite x well inside the int64 range: std::floor is a library call
/// on the baseline x86-64 target, and the grids below compute three per point.
inline std::int64_t floor_int(double x) {
  const auto i = static_cast<std::int64_t>(x);
  return i - (x < static_cast<double>(i));
}

inline VoxelCell voxel_cell(const Vec3& p_m, double inv_voxel_m) {
  return {floor_int(p_m.x() * inv_voxel_m), floor_int(p_m.y() * inv_voxel_m), floor_int(p_m.z() * inv_voxel_m)};
}
inline VoxelCell voxel_cell(const Vec3f& p_m, double inv_voxel_m) { return voxel_cell(Vec3(p_m.cast<double>()), inv_voxel_m); }

/// 21 bits per axis: +-1M cells, far beyond any drive at centimetre-to-metre voxels. Sorting by
/// key sorts by (x, y, z).
inline std::uint64_t voxel_key(const VoxelCell& c) {
  constexpr std::int64_t kOffset = std::int64_t{1} << 20;
  constexpr std::uint64_t kMask = (std::uint64_t{1} << 21) - 1;
  return ((static_cast<std::uint64_t>(c.x + kOffset) & kMask) << 42) |
         ((static_cast<std::uint64_t>(c.y + kOffset) & kMask) << 21) | (static_cast<std::uint64_t>(c.z + kOffset) & kMask);
}
inline std::uint64_t voxel_key(const Vec3f& p_m, double inv_voxel_m) { return voxel_key(voxel_cell(p_m, inv_voxel_m)); }
inline std::uint64_t voxel_key(const Vec3& p_m, double inv_voxel_m) { return voxel_key(voxel_cell(p_m, inv_voxel_m)); }

/// A set of voxel keys by open addressing: several times faster than std::unordered_set on the
/// per-point paths (downsampling, ray casting). Grows by doubling at half load.
class VoxelKeySet {
 public:
  explicit VoxelKeySet(std::size_t expected = 0) {
    std::size_t capacity = 16;
    while (capacity < 2 * expected) capacity <<= 1;
    table_.assign(capacity, kEmpty);
  }
  /// true when the key was not in the set yet.
  bool insert(std::uint64_t key) {
    std::size_t slot = find(key);
    if (table_[slot] == key) return false;
    if (2 * (size_ + 1) > table_.size()) {
      grow();
      slot = find(key);
    }
    table_[slot] = key;
    ++size_;
    return true;
  }
  bool contains(std::uint64_t key) const { return table_[find(key)] == key; }
  std::size_t size() const { return size_; }

 private:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};  // no voxel key has all 64 bits set
  std::size_t find(std::uint64_t key) const {
    const std::size_t mask = table_.size() - 1;
    std::size_t slot = (key * 0x9E3779B97F4A7C15ull) >> 20 & mask;
    while (table_[slot] != kEmpty && table_[slot] != key) slot = (slot + 1) & mask;
    return slot;
  }
  void grow() {
    std::vector<std::uint64_t> old(2 * table_.size(), kEmpty);
    old.swap(table_);
    for (std::uint64_t key : old)
      if (key != kEmpty) table_[find(key)] = key;
  }
  std::vector<std::uint64_t> table_;
  std::size_t size_ = 0;
};

/// Indices of one representative point per voxel_m cube: the first one met, so a kept point keeps
/// its own attributes (time); the result is in input order. voxel_m <= 0 keeps all.
std::vector<std::uint32_t> voxel_downsample_indices(std::span<const Vec3f> points, double voxel_m);

/// How many different keys (occupied voxels): exact, buckets by hash counted in parallel; about
/// 3x faster than sorting the keys (stage 2's time-offset scan counts a 1M-point map per step).
std::size_t count_distinct_keys(std::span<const std::uint64_t> keys);

/// The points of voxel_downsample_indices.
std::vector<Vec3f> voxel_downsample(std::span<const Vec3f> points, double voxel_m);

/// One point per occupied voxel: the centroid of its points; deterministic order (first met).
std::vector<Vec3> voxel_centroids(const std::vector<Vec3>& points, double voxel_m);

}  // namespace insalign
