// Crispness measures of a stitched point map: the fewer voxels a map occupies, or the thinner its
// local planes, the better the sweeps that built it line up. Stage 2 minimises these.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/geometry.hpp"

namespace insalign {

/// Key of the voxel of edge voxel_m holding p (21 bits per axis, wraps beyond +-1 km/voxel_m*1e3).
std::uint64_t voxel_key(const Vec3f& p, float inv_voxel_m);

/// Space occupancy (the paper's measure): number of distinct voxels of edge voxel_m that hold at
/// least one point. Parallel (TBB); the input is not modified.
std::size_t count_occupied_voxels(const std::vector<Vec3f>& p_world, double voxel_m);

/// Indices of one representative point per voxel of edge voxel_m (the first in input order), so
/// that per-point attributes (times) can be kept alongside. Order of the result: input order.
std::vector<std::size_t> voxel_downsample_indices(const std::vector<Vec3f>& points, double voxel_m);

/// The points of voxel_downsample_indices.
std::vector<Vec3f> voxel_downsample(const std::vector<Vec3f>& points, double voxel_m);

/// Local plane thickness of a map: the points are binned into voxels of edge voxel_m; every voxel
/// with at least min_points points whose covariance is planar (smallest eigenvalue below
/// max_planarity times the middle one) contributes its smallest eigenvalue, i.e. the mean squared
/// distance of its points to their best-fit plane.
struct PlaneThicknessConfig {
  double voxel_m = 1.0;          ///< voxel edge, metres
  int min_points = 10;           ///< fewer points: voxel skipped
  double max_planarity = 0.05;   ///< lambda_min / lambda_mid above this: not a plane, skipped
};
struct PlaneThickness {
  std::size_t planes = 0;        ///< planar voxels found
  std::size_t points = 0;        ///< points in them
  double rms_m = 0.0;            ///< sqrt(sum(n_i * lambda_min_i) / points): point-to-plane RMS
};
PlaneThickness plane_thickness(const std::vector<Vec3f>& p_world, const PlaneThicknessConfig& config = {});

}  // namespace insalign
