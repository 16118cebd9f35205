// Crispness measures of a stitched point map: the fewer voxels a map occupies, or the thinner its
// local planes, the better the sweeps that built it line up. Stage 2 minimises these.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/geometry.hpp"
#include "core/voxel_grid.hpp"  // voxel_downsample, used with these measures

namespace insalign {

/// Space occupancy (the paper's measure): number of distinct voxels of edge voxel_m that hold at
/// least one point, the grid shifted by grid_shift_m. Parallel (TBB); the input is not modified.
std::size_t count_occupied_voxels(const std::vector<Vec3f>& p_world, double voxel_m,
                                  const Vec3f& grid_shift_m = Vec3f::Zero());

/// The same for double-precision points (the initialisation's scores), as a double.
double occupancy_score(const std::vector<Vec3>& p_world, double voxel_m);

/// Occupancy averaged over two grids staggered by half a voxel along the diagonal: a surface that
/// happens to lie on a voxel boundary of one grid lies mid-voxel in the other, which removes most
/// of the count's dependence on where the grid falls.
double staggered_occupancy(const std::vector<Vec3f>& p_world, double voxel_m);

/// Local planes of a map: the points are binned into voxels of edge voxel_m; a voxel whose points
/// are planar (smallest covariance eigenvalue below max_planarity times the middle one) becomes a
/// plane, one that is not is split into octants down to min_voxel_m and each tried again.
struct PlaneThicknessConfig {
  double voxel_m = 1.0;          ///< voxel edge, metres
  double min_voxel_m = 1.0;      ///< split non-planar voxels down to this edge (= voxel_m: no split)
  int min_points = 10;           ///< fewer points: voxel skipped
  double max_planarity = 0.05;   ///< lambda_min / lambda_mid above this: not a plane, skipped
};

/// One fitted plane; its points are point_index[first, first + count) of LocalPlanes.
struct LocalPlane {
  Vec3 normal = Vec3::UnitZ();
  Vec3 centroid = Vec3::Zero();
  double lambda_min = 0.0;       ///< mean squared point-to-plane distance, m^2
  std::uint32_t first = 0, count = 0;
};
struct LocalPlanes {
  std::vector<LocalPlane> planes;
  std::vector<std::uint32_t> point_index;  ///< indices into the input points
};
LocalPlanes fit_local_planes(const std::vector<Vec3f>& p_world, const PlaneThicknessConfig& config = {});

/// Plane thickness of a map (the smallest-eigenvalue cost of BALM, as a distance).
struct PlaneThickness {
  std::size_t planes = 0;        ///< planar voxels found
  std::size_t points = 0;        ///< points in them
  double rms_m = 0.0;            ///< sqrt(sum(count_i * lambda_min_i) / points): point-to-plane RMS
};
PlaneThickness plane_thickness(const std::vector<Vec3f>& p_world, const PlaneThicknessConfig& config = {});

}  // namespace insalign
