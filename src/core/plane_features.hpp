// Plane features for point-to-plane registration: voxel downsampling and BALM-style adaptive
// voxelization (an octree split until each leaf is planar or too small).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "core/geometry.hpp"

namespace insalign {

struct PlaneFeatureConfig {
  double root_voxel_m = 2.0;         ///< edge of the top-level voxels, metres
  int max_depth = 3;                 ///< octree splits below the root (min voxel = root / 2^depth)
  double planarity_sigma_m = 0.05;   ///< planar when sqrt(smallest covariance eigenvalue) is below this
  double max_eigen_ratio = 0.1;      ///< and smallest / middle eigenvalue below this (rejects lines, blobs)
  std::size_t min_points = 8;        ///< voxels with fewer points are dropped, not split
};

/// A planar voxel: the plane fitted to its points and which points it holds.
struct Plane {
  Vec3 centre = Vec3::Zero();        ///< mean of the points
  Vec3 normal = Vec3::UnitZ();       ///< unit, eigenvector of the smallest covariance eigenvalue
  double thickness_m = 0.0;          ///< sqrt of the smallest covariance eigenvalue
  double voxel_size_m = 0.0;         ///< edge of the voxel it was found in
  std::vector<std::uint32_t> point_indices;  ///< into the input points
};

/// Adaptive voxelization of points (any frame): planar leaves of an octree rooted on a grid of
/// root_voxel_m cubes. Deterministic; parallel over root voxels.
std::vector<Plane> extract_planes(std::span<const Vec3f> points, const PlaneFeatureConfig& config = {});

/// Fit a plane (centre, normal, thickness) to a point set; false if fewer than 3 points.
bool fit_plane(std::span<const Vec3f> points, std::span<const std::uint32_t> indices, Plane& plane);

}  // namespace insalign
