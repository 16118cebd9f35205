// Point-to-plane ICP on a synthetic scene of planes: two scans of the same scene from different poses.
#include <random>

#include <gtest/gtest.h>

#include "core/scan_registration.hpp"
#include "core/voxel_grid.hpp"

namespace insalign {
namespace {

// Points on a ground plane, building walls at several angles and a few boxes, in the world frame.
std::vector<Vec3> plane_scene(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.01);
  std::vector<Vec3> pts;
  for (int i = 0; i < 6000; ++i) pts.push_back({25 * u(rng), 25 * u(rng), noise(rng)});  // ground
  const struct { Vec3 origin, along; double len; } walls[] = {
      {{-15, 10, 0}, Vec3(1, 0.2, 0).normalized(), 25}, {{12, -14, 0}, Vec3(0.3, 1, 0).normalized(), 25},
      {{-14, -12, 0}, Vec3(1, -0.6, 0).normalized(), 15}, {{5, 5, 0}, Vec3(-0.8, 1, 0).normalized(), 6}};
  for (const auto& w : walls)
    for (int i = 0; i < 3000; ++i) {
      const double s = (0.5 + 0.5 * u(rng)) * w.len, h = (0.5 + 0.5 * u(rng)) * 6.0;
      const Vec3 n = Vec3(-w.along.y(), w.along.x(), 0);
      pts.push_back(w.origin + s * w.along + Vec3(0, 0, h) + noise(rng) * n);
    }
  return pts;
}

std::vector<Vec3> observe(const std::vector<Vec3>& world, const Iso3& T_world_sensor, std::mt19937& rng) {
  std::bernoulli_distribution keep(0.6);  // each scan sees a different random subset
  std::vector<Vec3> out;
  const Iso3 T_sensor_world = T_world_sensor.inverse();
  for (const Vec3& p : world)
    if (keep(rng)) out.push_back(T_sensor_world * p);
  return out;
}

TEST(ScanRegistration, RecoversRelativeMotionOfPlaneScene) {
  for (unsigned seed : {1u, 2u, 3u}) {
    std::mt19937 rng(seed);
    const std::vector<Vec3> world = plane_scene(rng);
    const Iso3 T_world_a = make_transform({0, 0, 1.9}, {1, -2, 30});
    const Iso3 T_world_b = make_transform({1.5, 0.8, 1.95}, {0, -1, 42});
    const std::vector<Vec3> scan_a = observe(world, T_world_a, rng);
    const std::vector<Vec3> scan_b = voxel_centroids(observe(world, T_world_b, rng), 0.4);
    const Iso3 T_a_b_true = T_world_a.inverse() * T_world_b;
    const Iso3 T_a_b_init = T_a_b_true * make_transform({0.4, -0.3, 0.1}, {1, 1, 4});
    const ScanRegistrationResult reg = register_scans(scan_a, scan_b, T_a_b_init);
    ASSERT_TRUE(reg.converged) << "seed " << seed;
    const ExtrinsicError err = extrinsic_error(reg.T_target_source, T_a_b_true);
    EXPECT_LT(err.dt_norm_m, 0.02) << "seed " << seed;
    EXPECT_LT(err.angle_deg, 0.1) << "seed " << seed;
    EXPECT_LT(reg.rms_m, 0.03);
  }
}

TEST(ScanRegistration, TooFewPointsIsNotConverged) {
  const std::vector<Vec3> few = {Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};
  const ScanRegistrationResult reg = register_scans(few, few, Iso3::Identity());
  EXPECT_FALSE(reg.converged);
}

TEST(ScanRegistration, VoxelDownsampleKeepsOnePointPerVoxel) {
  const std::vector<Vec3> pts = {Vec3(0.1, 0.1, 0.1), Vec3(0.3, 0.3, 0.3), Vec3(1.2, 0.1, 0.1)};
  const std::vector<Vec3> out = voxel_centroids(pts, 1.0);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_NEAR(out[0].x(), 0.2, 1e-12);  // centroid of the first voxel
}


// The memo skips searches only when their answer is certain: a point drifting in small and large
// steps (as across ICP iterations) with a shrinking gate gets exactly what a fresh search gets,
// and most searches are skipped.
TEST(ScanRegistration, NearestWithMemoAnswersAsAFreshSearch) {
  std::mt19937 rng(7);
  const std::vector<Vec3> target = voxel_centroids(plane_scene(rng), 0.3);
  const PlaneTarget planes(target, 8, 0.08);
  std::normal_distribution<double> step(0.0, 1.0);
  std::uniform_real_distribution<double> u(-20.0, 20.0);
  int asked = 0, same = 0;
  for (int point = 0; point < 300; ++point) {
    Vec3 p(u(rng), u(rng), 3.0 + 0.1 * u(rng));
    NearestMemo memo;
    for (int it = 0; it < 20; ++it) {
      const double gate_m = std::max(0.3, 1.5 * std::pow(0.85, it));
      const double scale = it < 5 ? 0.2 : 0.002;  // large steps first, then small ones
      p += scale * Vec3(step(rng), step(rng), step(rng));
      NearestMemo fresh;
      const std::optional<std::size_t> expected = planes.nearest(p, gate_m, fresh);
      const Vec3 before = memo.p_searched;
      EXPECT_EQ(planes.nearest(p, gate_m, memo), expected) << "point " << point << " iteration " << it;
      ++asked;
      same += before == memo.p_searched;  // the memo's search was skipped
    }
  }
  EXPECT_GT(same, asked / 2);
}

// The map check's target fits normals in parallel only where the sweeps land (fit_normals): each
// the same as fitting all of them up front.
TEST(ScanRegistration, NormalsFittedInParallelAreTheUpFrontOnes) {
  std::mt19937 rng(3);
  const std::vector<Vec3> target = voxel_centroids(plane_scene(rng), 0.2);
  const PlaneTarget all(target, 8, 0.08, NormalFit::kUpFront);
  const PlaneTarget lazy(target, 8, 0.08, NormalFit::kOnDemand);
  std::uniform_int_distribution<std::uint32_t> pick(0, static_cast<std::uint32_t>(target.size() - 1));
  std::vector<std::uint32_t> asked = {NearestMemo::kNoIndex};
  for (int i = 0; i < 2000; ++i) asked.push_back(pick(rng));
  asked.push_back(asked.back());  // a repeat
  lazy.fit_normals(asked);
  int planar = 0;
  for (std::uint32_t i : asked) {
    if (i == NearestMemo::kNoIndex) continue;
    EXPECT_EQ(lazy.normal(i), all.normal(i)) << "point " << i;
    planar += !all.normal(i).isZero();
  }
  EXPECT_GT(planar, 1000);  // most scene points lie on a plane: the comparison is not of zeros
}

}  // namespace
}  // namespace insalign
