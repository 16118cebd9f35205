#include "core/occupancy.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "core/voxel_grid.hpp"

namespace insalign {
namespace {

// Mean and covariance of a set of points, in double around a local origin (float world
// coordinates of hundreds of metres would lose the millimetres otherwise).
struct Moments {
  Vec3 mean = Vec3::Zero();
  Mat3 cov = Mat3::Zero();
};
Moments moments(const std::vector<Vec3f>& points, const std::uint32_t* begin, const std::uint32_t* end) {
  const Vec3 origin = points[*begin].cast<double>();
  Vec3 sum = Vec3::Zero();
  Mat3 sum2 = Mat3::Zero();
  for (const std::uint32_t* it = begin; it != end; ++it) {
    const Vec3 d = points[*it].cast<double>() - origin;
    sum += d;
    sum2 += d * d.transpose();
  }
  const double n = static_cast<double>(end - begin);
  Moments m;
  const Vec3 mean_local = sum / n;
  m.mean = origin + mean_local;
  m.cov = sum2 / n - mean_local * mean_local.transpose();
  return m;
}

// Fits one voxel (or octant) and recurses into octants when it is not planar.
void fit_cell(const std::vector<Vec3f>& points, std::uint32_t* begin, std::uint32_t* end, const Vec3& center,
              double size_m, const PlaneThicknessConfig& config, std::uint32_t offset,
              std::vector<LocalPlane>& out) {
  const auto n = end - begin;
  if (n < config.min_points) return;
  const Moments m = moments(points, begin, end);
  Eigen::SelfAdjointEigenSolver<Mat3> es(m.cov);
  const Vec3 lambda = es.eigenvalues().cwiseMax(0.0);
  if (lambda(0) <= config.max_planarity * lambda(1)) {
    LocalPlane plane;
    plane.normal = es.eigenvectors().col(0);
    plane.centroid = m.mean;
    plane.lambda_min = lambda(0);
    plane.first = offset;
    plane.count = static_cast<std::uint32_t>(n);
    out.push_back(plane);
    return;
  }
  const double half = 0.5 * size_m;
  if (half < config.min_voxel_m * (1.0 - 1e-9)) return;
  // Octant of each point relative to the cell centre; group them (a counting sort, in the order
  // they came: a comparison sort was a sixth of stage 2's plane fits) and fit each.
  const auto octant = [&](std::uint32_t k) {
    const Vec3f& p = points[k];
    return (p.x() > center.x() ? 1 : 0) | (p.y() > center.y() ? 2 : 0) | (p.z() > center.z() ? 4 : 0);
  };
  std::array<std::uint32_t, 9> first{};
  thread_local std::vector<std::uint8_t> octants;
  thread_local std::vector<std::uint32_t> grouped;
  octants.resize(static_cast<std::size_t>(n));
  grouped.resize(static_cast<std::size_t>(n));
  for (std::ptrdiff_t i = 0; i < n; ++i) ++first[1 + (octants[i] = static_cast<std::uint8_t>(octant(begin[i])))];
  for (int o = 0; o < 8; ++o) first[o + 1] += first[o];
  std::array<std::uint32_t, 8> next;
  std::copy(first.begin(), first.end() - 1, next.begin());
  for (std::ptrdiff_t i = 0; i < n; ++i) grouped[next[octants[i]]++] = begin[i];
  std::copy(grouped.begin(), grouped.begin() + n, begin);  // before recursing: the buffers are reused
  for (int o = 0; o < 8; ++o) {
    if (first[o + 1] == first[o]) continue;
    const Vec3 child = center + 0.25 * size_m * Vec3((o & 1) ? 1 : -1, (o & 2) ? 1 : -1, (o & 4) ? 1 : -1);
    fit_cell(points, begin + first[o], begin + first[o + 1], child, half, config, offset + first[o], out);
  }
}

}  // namespace

std::size_t count_occupied_voxels(const std::vector<Vec3f>& p_world, double voxel_m, const Vec3f& grid_shift_m) {
  const double inv = 1.0 / voxel_m;
  std::vector<std::uint64_t> keys(p_world.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, p_world.size(), 8192), [&](const auto& r) {
    for (std::size_t i = r.begin(); i < r.end(); ++i) keys[i] = voxel_key(Vec3f(p_world[i] - grid_shift_m), inv);
  });
  return count_distinct_keys(keys);
}

double occupancy_score(const std::vector<Vec3>& p_world, double voxel_m) {
  std::vector<Vec3f> p(p_world.size());
  for (std::size_t i = 0; i < p.size(); ++i) p[i] = p_world[i].cast<float>();
  return static_cast<double>(count_occupied_voxels(p, voxel_m));
}

double staggered_occupancy(const std::vector<Vec3f>& p_world, double voxel_m) {
  const Vec3f half = Vec3f::Constant(static_cast<float>(0.5 * voxel_m));
  return 0.5 * static_cast<double>(count_occupied_voxels(p_world, voxel_m) +
                                   count_occupied_voxels(p_world, voxel_m, half));
}

LocalPlanes fit_local_planes(const std::vector<Vec3f>& p_world, const PlaneThicknessConfig& config) {
  VoxelGroups groups = group_by_voxel(p_world, config.voxel_m);
  const std::size_t runs = groups.size();
  std::vector<std::vector<LocalPlane>> per_run(runs);
  const double voxel = config.voxel_m;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, runs, 64), [&](const auto& r) {
    for (std::size_t k = r.begin(); k < r.end(); ++k) {
      std::uint32_t* b = groups.order.data() + groups.begin[k];
      std::uint32_t* e = groups.order.data() + groups.begin[k + 1];
      if (e - b < config.min_points) continue;
      const Vec3f& p = p_world[*b];
      const Vec3 center((std::floor(p.x() / voxel) + 0.5) * voxel, (std::floor(p.y() / voxel) + 0.5) * voxel,
                        (std::floor(p.z() / voxel) + 0.5) * voxel);
      fit_cell(p_world, b, e, center, voxel, config, static_cast<std::uint32_t>(groups.begin[k]), per_run[k]);
    }
  });
  LocalPlanes out;
  out.point_index = std::move(groups.order);
  for (auto& v : per_run) out.planes.insert(out.planes.end(), v.begin(), v.end());
  return out;
}

PlaneThickness plane_thickness(const std::vector<Vec3f>& p_world, const PlaneThicknessConfig& config) {
  const LocalPlanes lp = fit_local_planes(p_world, config);
  PlaneThickness out;
  double sum = 0.0;
  for (const LocalPlane& p : lp.planes) {
    out.points += p.count;
    sum += p.count * p.lambda_min;
  }
  out.planes = lp.planes.size();
  out.rms_m = out.points > 0 ? std::sqrt(sum / static_cast<double>(out.points)) : 0.0;
  return out;
}

}  // namespace insalign
