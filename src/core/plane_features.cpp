#include "core/plane_features.hpp"

#include "core/voxel_grid.hpp"

#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <climits>
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

namespace {

// Point indices grouped by root voxel, the groups in key order (x, then y, then z) and each in
// index order: the order the output keeps, so that it does not depend on hashing or threads.
struct RootVoxels {
  std::vector<std::uint32_t> order;                         // point indices, grouped
  std::vector<std::pair<std::size_t, std::size_t>> ranges;  // [begin, end) in order, per voxel
};

// A counting sort over the window's box of voxels when the box is small (a window spans at most a
// few hundred metres), else a comparison sort of 64-bit keys: the same groups in the same order.
RootVoxels group_by_root_voxel(std::span<const Vec3f> points, double inv, std::size_t min_points) {
  RootVoxels out;
  const std::size_t n = points.size();
  std::vector<VoxelCell> cells(n);
  VoxelCell lo{INT64_MAX, INT64_MAX, INT64_MAX}, hi{INT64_MIN, INT64_MIN, INT64_MIN};
  for (std::size_t i = 0; i < n; ++i) {
    const VoxelCell& c = cells[i] = voxel_cell(points[i], inv);
    lo = {std::min(lo.x, c.x), std::min(lo.y, c.y), std::min(lo.z, c.z)};
    hi = {std::max(hi.x, c.x), std::max(hi.y, c.y), std::max(hi.z, c.z)};
  }
  if (n == 0) return out;
  const std::int64_t w = hi.x - lo.x + 1, d = hi.y - lo.y + 1, h = hi.z - lo.z + 1;
  const double box = static_cast<double>(w) * static_cast<double>(d) * static_cast<double>(h);
  if (box <= std::max(4.0 * static_cast<double>(n), 65536.0) && box < 1e8) {
    // x-major dense index: its order is the key order.
    const auto dense = [&](const VoxelCell& c) {
      return static_cast<std::size_t>(((c.x - lo.x) * d + (c.y - lo.y)) * h + (c.z - lo.z));
    };
    std::vector<std::uint32_t> start(static_cast<std::size_t>(box) + 1, 0);
    for (const VoxelCell& c : cells) ++start[dense(c) + 1];
    for (std::size_t k = 1; k < start.size(); ++k) start[k] += start[k - 1];
    for (std::size_t k = 0; k + 1 < start.size(); ++k)
      if (start[k + 1] - start[k] >= min_points) out.ranges.emplace_back(start[k], start[k + 1]);
    out.order.resize(n);
    for (std::size_t i = 0; i < n; ++i) out.order[start[dense(cells[i])]++] = static_cast<std::uint32_t>(i);
    return out;
  }
  struct Keyed {
    std::uint64_t key;
    std::uint32_t index;
  };
  std::vector<Keyed> keyed(n);
  for (std::size_t i = 0; i < n; ++i) keyed[i] = {voxel_key(cells[i]), static_cast<std::uint32_t>(i)};
  cells = {};
  tbb::parallel_sort(keyed.begin(), keyed.end(), [](const Keyed& a, const Keyed& b) {
    return a.key < b.key || (a.key == b.key && a.index < b.index);
  });
  out.order.resize(n);
  for (std::size_t b = 0; b < n;) {
    std::size_t e = b + 1;
    while (e < n && keyed[e].key == keyed[b].key) ++e;
    if (e - b >= min_points) out.ranges.emplace_back(b, e);
    b = e;
  }
  for (std::size_t i = 0; i < n; ++i) out.order[i] = keyed[i].index;
  return out;
}

}  // namespace

std::vector<Plane> extract_planes(std::span<const Vec3f> points, const PlaneFeatureConfig& config) {
  const double inv = 1.0 / config.root_voxel_m;
  const RootVoxels roots = group_by_root_voxel(points, inv, config.min_points);
  std::vector<std::vector<Plane>> per_root(roots.ranges.size());
  tbb::parallel_for(std::size_t{0}, roots.ranges.size(), [&](std::size_t r) {
    const auto [b, e] = roots.ranges[r];
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
