#include "core/plane_features.hpp"

#include <gtest/gtest.h>

#include <random>

namespace insalign {
namespace {

// Points on a rectangle patch of a plane with normal n through c, plus Gaussian noise.
void add_patch(std::vector<Vec3f>& pts, const Vec3& c, const Vec3& n, double half_m, int count, double noise_m,
               std::mt19937& rng) {
  const Vec3 u = n.unitOrthogonal();
  const Vec3 v = n.cross(u);
  std::uniform_real_distribution<double> uni(-half_m, half_m);
  std::normal_distribution<double> gauss(0.0, noise_m);
  for (int i = 0; i < count; ++i) pts.push_back((c + uni(rng) * u + uni(rng) * v + gauss(rng) * n).cast<float>());
}

TEST(PlaneFeatures, FindsTheNormalsAndCentresOfSyntheticPlanes) {
  std::mt19937 rng(7);
  std::vector<Vec3f> pts;
  // A floor, a wall and a tilted roof in separate root voxels.
  const Vec3 n_tilt = Vec3(0.0, std::sin(0.5), std::cos(0.5));
  add_patch(pts, Vec3(1.0, 1.0, 0.5), Vec3::UnitZ(), 0.9, 2000, 0.01, rng);
  add_patch(pts, Vec3(5.0, 1.0, 1.0), Vec3::UnitX(), 0.9, 2000, 0.01, rng);
  add_patch(pts, Vec3(9.0, 1.0, 1.0), n_tilt, 0.6, 2000, 0.01, rng);
  PlaneFeatureConfig config;
  config.root_voxel_m = 2.0;
  const std::vector<Plane> planes = extract_planes(pts, config);
  ASSERT_GE(planes.size(), 3u);
  // Every plane's normal is one of the three, and its centre lies on that plane.
  std::size_t points_in_planes = 0;
  for (const Plane& p : planes) {
    const Vec3 expected = p.centre.x() < 3.0 ? Vec3::UnitZ() : (p.centre.x() < 7.0 ? Vec3::UnitX() : n_tilt);
    const Vec3 on_plane = p.centre.x() < 3.0 ? Vec3(1, 1, 0.5) : (p.centre.x() < 7.0 ? Vec3(5, 1, 1) : Vec3(9, 1, 1));
    EXPECT_GT(std::abs(p.normal.dot(expected)), std::cos(1.0 * kRadPerDeg));
    EXPECT_LT(std::abs(expected.dot(p.centre - on_plane)), 0.01);
    EXPECT_LT(p.thickness_m, 0.02);
    points_in_planes += p.point_indices.size();
  }
  EXPECT_GT(points_in_planes, pts.size() * 9 / 10);
}

TEST(PlaneFeatures, SplitsACornerIntoItsTwoPlanes) {
  std::mt19937 rng(3);
  std::vector<Vec3f> pts;
  // Floor and wall meeting inside one 2 m root voxel: not planar at the root, planar after splits.
  add_patch(pts, Vec3(1.0, 1.0, 0.25), Vec3::UnitZ(), 0.95, 4000, 0.005, rng);
  add_patch(pts, Vec3(1.0, 0.25, 1.0), Vec3::UnitY(), 0.95, 4000, 0.005, rng);
  PlaneFeatureConfig config;
  config.root_voxel_m = 2.0;
  config.max_depth = 3;
  const std::vector<Plane> planes = extract_planes(pts, config);
  int floor = 0, wall = 0;
  for (const Plane& p : planes) {
    if (std::abs(p.normal.z()) > 0.999) ++floor;
    else if (std::abs(p.normal.y()) > 0.999) ++wall;
    else ADD_FAILURE() << "plane with normal " << p.normal.transpose();
  }
  EXPECT_GT(floor, 0);
  EXPECT_GT(wall, 0);
}

TEST(PlaneFeatures, RejectsLinesAndScatter) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> uni(0.0, 1.9);
  std::normal_distribution<double> g(0.0, 0.005);
  std::vector<Vec3f> pts;
  for (int i = 0; i < 1000; ++i) pts.push_back(Vec3(0.5 + g(rng), 0.5 + g(rng), uni(rng)).cast<float>());  // a pole
  for (int i = 0; i < 1000; ++i) pts.push_back(Vec3(2.0 + uni(rng), uni(rng), uni(rng)).cast<float>());    // a bush
  // A few chance-flat clusters of the bush may pass; they must hold a negligible share.
  std::size_t in_planes = 0;
  for (const Plane& p : extract_planes(pts)) in_planes += p.point_indices.size();
  EXPECT_LT(in_planes, pts.size() / 20);
}

}  // namespace
}  // namespace insalign
