#include "core/plane_features.hpp"

#include "core/voxel_grid.hpp"

#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>

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
    sum_sq += p * p.transpose();
  }
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
  // Sort point indices by root voxel so that the output order does not depend on hashing. 16 B per
  // point (the cell is recomputed from a range's first point): stage 1's whole-drive windows hold
  // millions of points, and this array is part of its peak memory.
  struct Keyed {
    std::uint64_t key;
    std::uint32_t index;
  };
  std::vector<Keyed> keyed(points.size());
  tbb::parallel_for(std::size_t{0}, points.size(), [&](std::size_t i) {
    keyed[i] = {voxel_key(points[i], inv), static_cast<std::uint32_t>(i)};
  });
  tbb::parallel_sort(keyed.begin(), keyed.end(), [](const Keyed& a, const Keyed& b) {
    return a.key < b.key || (a.key == b.key && a.index < b.index);
  });
  std::vector<std::pair<std::size_t, std::size_t>> ranges;  // [begin, end) per root voxel
  for (std::size_t b = 0; b < keyed.size();) {
    std::size_t e = b + 1;
    while (e < keyed.size() && keyed[e].key == keyed[b].key) ++e;
    if (e - b >= config.min_points) ranges.emplace_back(b, e);
    b = e;
  }
  std::vector<std::vector<Plane>> per_root(ranges.size());
  tbb::parallel_for(std::size_t{0}, ranges.size(), [&](std::size_t r) {
    const auto [b, e] = ranges[r];
    std::vector<std::uint32_t> indices(e - b);
    for (std::size_t i = b; i < e; ++i) indices[i - b] = keyed[i].index;
    const VoxelCell k = voxel_cell(points[keyed[b].index], inv);
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
