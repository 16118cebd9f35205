#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "core/occupancy.hpp"

namespace insalign {
namespace {

// Points on the plane z = 0.3 x + 1 over [0, 10]^2 with Gaussian noise along z.
std::vector<Vec3f> noisy_plane(std::size_t n, double sigma_m, double shift_m, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uni(0.0, 10.0);
  std::normal_distribution<double> noise(0.0, sigma_m);
  std::vector<Vec3f> p;
  for (std::size_t i = 0; i < n; ++i) {
    const double x = uni(rng), y = uni(rng);
    p.emplace_back(x, y, 0.3 * x + 1.0 + shift_m + noise(rng));
  }
  return p;
}

TEST(Occupancy, CountsDistinctVoxels) {
  std::vector<Vec3f> p = {{0.01f, 0.01f, 0.01f}, {0.04f, 0.02f, 0.03f}, {0.06f, 0.0f, 0.0f},
                          {-0.01f, 0.0f, 0.0f},  {100.0f, -3.0f, 2.0f}, {100.01f, -2.99f, 2.01f}};
  EXPECT_EQ(count_occupied_voxels(p, 0.05), 4u);
  EXPECT_EQ(count_occupied_voxels(p, 1.0), 3u);  // x = -0.01 is in its own 1 m voxel
  EXPECT_EQ(count_occupied_voxels({}, 0.1), 0u);
}

TEST(Occupancy, BlurredMapOccupiesMoreVoxels) {
  std::vector<Vec3f> sharp = noisy_plane(40000, 0.005, 0.0, 1);
  std::vector<Vec3f> blurred = sharp;
  const auto second = noisy_plane(40000, 0.005, 0.0, 2);
  const auto shifted = noisy_plane(40000, 0.005, 0.06, 2);
  sharp.insert(sharp.end(), second.begin(), second.end());
  blurred.insert(blurred.end(), shifted.begin(), shifted.end());
  EXPECT_LT(count_occupied_voxels(sharp, 0.05), count_occupied_voxels(blurred, 0.05));
}

TEST(Occupancy, PlaneThicknessMeasuresTheNoise) {
  const double sigma = 0.01;
  const auto p = noisy_plane(100000, sigma, 0.0, 3);
  const PlaneThickness t = plane_thickness(p);
  EXPECT_GT(t.planes, 80u);
  EXPECT_NEAR(t.rms_m, sigma / std::sqrt(1.0 + 0.09), 0.1 * sigma);  // noise along z, distance along the normal
  const LocalPlanes lp = fit_local_planes(p);
  ASSERT_FALSE(lp.planes.empty());
  const Vec3 n_true = Vec3(-0.3, 0.0, 1.0).normalized();
  const auto biggest = std::max_element(lp.planes.begin(), lp.planes.end(),
                                        [](const LocalPlane& a, const LocalPlane& b) { return a.count < b.count; });
  EXPECT_GT(std::abs(biggest->normal.dot(n_true)), 0.999);
  EXPECT_EQ(lp.point_index.size(), p.size());
}

TEST(Occupancy, NonPlanarVoxelsAreSplit) {
  // Two perpendicular planes meeting inside 2 m voxels: no 2 m voxel is planar, 0.5 m octants are.
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> uni(0.0, 8.0);
  std::vector<Vec3f> p;
  for (int i = 0; i < 60000; ++i) {
    const double a = uni(rng), b = uni(rng);
    p.emplace_back(a, b, 1.03f);
    p.emplace_back(a, 1.03f, b);
  }
  PlaneThicknessConfig c;
  c.voxel_m = 2.0;
  c.min_voxel_m = 2.0;
  const std::size_t unsplit = fit_local_planes(p, c).planes.size();
  c.min_voxel_m = 0.5;
  const std::size_t split = fit_local_planes(p, c).planes.size();
  EXPECT_GT(split, unsplit);
}

}  // namespace
}  // namespace insalign
