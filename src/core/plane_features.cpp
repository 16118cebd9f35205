#include "core/plane_features.hpp"

#include "core/voxel_grid.hpp"

#include <tbb/parallel_for.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

namespace insalign {
namespace {

struct Moments {
  Vec3 mean = Vec3::Zero();
  Mat3 cov = Mat3::Zero();
};

Moments moments_of(std::span<const Vec3f> points, std::span<const std::uint32_t> indices) {
  Moments m;
  Vec3 sum = Vec3::Zero();
  Mat3 sum_sq = Mat3::Zero();
  for (std::uint32_t i : indices) {
    const Vec3 p = points[i].cast<double>();
    sum += p;
    add_outer_upper(sum_sq, p);
  }
  mirror_upper(sum_sq);
  const double n = static_cast<double>(indices.size());
  m.mean = sum / n;
  m.cov = sum_sq / n - m.mean * m.mean.transpose();
  return m;
}

void split_recursive(std::span<const Vec3f> points, std::vector<std::uint32_t> indices, const Vec3& corner,
                     double size, int depth, const PlaneFeatureConfig& config, std::vector<Plane>& out) {
  if (indices.size() < config.min_points) return;
  const Moments m = moments_of(points, indices);
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(m.cov);
  const Vec3 lambda = eig.eigenvalues().cwiseMax(0.0);  // ascending
  const bool planar = lambda(0) < config.planarity_sigma_m * config.planarity_sigma_m &&
                      lambda(0) < config.max_eigen_ratio * lambda(1);
  if (planar) {
    Plane plane;
    plane.centre = m.mean;
    plane.normal = eig.eigenvectors().col(0).normalized();
    plane.thickness_m = std::sqrt(lambda(0));
    plane.voxel_size_m = size;
    plane.point_indices = std::move(indices);
    out.push_back(std::move(plane));
    return;
  }
  if (depth >= config.max_depth) return;
  const double half = 0.5 * size;
  std::array<std::vector<std::uint32_t>, 8> children;
  const Vec3 mid = corner + Vec3::Constant(half);
  for (std::uint32_t i : indices) {
    const Vec3f& p = points[i];
    const int c = (p.x() >= mid.x() ? 1 : 0) | (p.y() >= mid.y() ? 2 : 0) | (p.z() >= mid.z() ? 4 : 0);
    children[c].push_back(i);
  }
  for (int c = 0; c < 8; ++c) {
    const Vec3 child_corner = corner + Vec3((c & 1) ? half : 0.0, (c & 2) ? half : 0.0, (c & 4) ? half : 0.0);
    split_recursive(points, std::move(children[c]), child_corner, half, depth + 1, config, out);
  }
}

}  // namespace

bool fit_plane(std::span<const Vec3f> points, std::span<const std::uint32_t> indices, Plane& plane) {
  if (indices.size() < 3) return false;
  const Moments m = moments_of(points, indices);
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(m.cov);
  plane.centre = m.mean;
  plane.normal = eig.eigenvectors().col(0).normalized();
  plane.thickness_m = std::sqrt(std::max(0.0, eig.eigenvalues()(0)));
  return true;
}

std::vector<Plane> extract_planes(std::span<const Vec3f> points, const PlaneFeatureConfig& config) {
  const double inv = 1.0 / config.root_voxel_m;
  // Grouped in key order, so that the output does not depend on hashing or threads.
  const VoxelGroups roots = group_by_voxel(points, config.root_voxel_m);
  std::vector<std::size_t> kept;  // root voxels with enough points
  for (std::size_t r = 0; r < roots.size(); ++r)
    if (roots.begin[r + 1] - roots.begin[r] >= config.min_points) kept.push_back(r);
  std::vector<std::vector<Plane>> per_root(kept.size());
  tbb::parallel_for(std::size_t{0}, kept.size(), [&](std::size_t r) {
    const std::size_t b = roots.begin[kept[r]], e = roots.begin[kept[r] + 1];
    std::vector<std::uint32_t> indices(roots.order.begin() + static_cast<std::ptrdiff_t>(b),
                                      roots.order.begin() + static_cast<std::ptrdiff_t>(e));
    const VoxelCell k = voxel_cell(points[indices.front()], inv);
    const Vec3 corner = Vec3(static_cast<double>(k.x), static_cast<double>(k.y), static_cast<double>(k.z)) *
                        config.root_voxel_m;
    split_recursive(points, std::move(indices), corner, config.root_voxel_m, 0, config, per_root[r]);
  });
  std::vector<Plane> planes;
  for (auto& v : per_root)
    for (auto& p : v) planes.push_back(std::move(p));
  return planes;
}

}  // namespace insalign
