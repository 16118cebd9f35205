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

inline VoxelCell voxel_cell(const Vec3& p_m, double inv_voxel_m) {
  return {static_cast<std::int64_t>(std::floor(p_m.x() * inv_voxel_m)),
          static_cast<std::int64_t>(std::floor(p_m.y() * inv_voxel_m)),
          static_cast<std::int64_t>(std::floor(p_m.z() * inv_voxel_m))};
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
