// What an INS position random walk leaves in stage 2's estimate (random_walk_stddev): the
// trajectory correction measures a drifting INS's walk, and the DOFs it keeps from stage 2 (the
// horizontal lever arm, the time offset) carry it. On drifting drives a 20 mm lever-arm change
// read as 5-10 mm at a stated 4-7 mm (bench/results/check.md) without it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "core/refine.hpp"

namespace insalign {
namespace {

using Vec7 = Eigen::Matrix<double, 7, 1>;
using Shift = Eigen::Matrix<double, 7, 3>;

RefineResult random_sensitivities(std::mt19937& rng, int frames) {
  std::uniform_real_distribution<double> gap(0.2, 3.0);
  std::normal_distribution<double> n(0.0, 1.0);
  RefineResult r;
  double t = 1.7e9;
  for (int f = 0; f < frames; ++f) {
    r.ins_shift_t_s.push_back(t += gap(rng));
    Shift S;
    for (int i = 0; i < 7; ++i)
      for (int a = 0; a < 3; ++a) S(i, a) = n(rng) * (1.0 + 0.1 * i);
    r.ins_shift.push_back(S);
  }
  std::shuffle(r.ins_shift_t_s.begin(), r.ins_shift_t_s.end(), rng);  // frames need not come in time order
  return r;
}

// Walks drawn with the rate that gives the stated RMS about their mean over the span move the
// estimate by what the function says.
TEST(RandomWalkStddev, IsWhatWalksOfThatSizeLeave) {
  std::mt19937 rng(11);
  const RefineResult r = random_sensitivities(rng, 60);
  const auto [t_min, t_max] = std::minmax_element(r.ins_shift_t_s.begin(), r.ins_shift_t_s.end());
  const double span = *t_max - *t_min;
  const Vec3 rms(0.03, 0.02, 0.005);
  const Vec7 expected = random_walk_stddev(r, rms, span);

  std::vector<std::size_t> order(r.ins_shift.size());
  for (std::size_t f = 0; f < order.size(); ++f) order[f] = f;
  std::sort(order.begin(), order.end(), [&](auto a, auto b) { return r.ins_shift_t_s[a] < r.ins_shift_t_s[b]; });
  const Vec3 q = 6.0 * rms.cwiseAbs2() / span;
  std::normal_distribution<double> n(0.0, 1.0);
  constexpr int kWalks = 4000;
  Vec7 sum_sq = Vec7::Zero();
  Vec3 rms_sq = Vec3::Zero();
  for (int w = 0; w < kWalks; ++w) {
    Vec3 e = Vec3::Constant(5.0);  // any start: a shift common to all frames moves nothing
    Vec7 dx = Vec7::Zero();
    std::vector<Vec3> walk;
    for (std::size_t k = 0; k < order.size(); ++k) {
      if (k > 0) {
        const double dt = r.ins_shift_t_s[order[k]] - r.ins_shift_t_s[order[k - 1]];
        for (int a = 0; a < 3; ++a) e[a] += std::sqrt(q[a] * dt) * n(rng);
      }
      walk.push_back(e);
    }
    Vec3 mean = Vec3::Zero();
    for (const Vec3& v : walk) mean += v / static_cast<double>(walk.size());
    for (std::size_t k = 0; k < order.size(); ++k) dx += r.ins_shift[order[k]] * (walk[k] - mean);
    sum_sq += dx.cwiseAbs2();
    Vec3 var = Vec3::Zero();
    for (const Vec3& v : walk) var += (v - mean).cwiseAbs2() / static_cast<double>(walk.size());
    rms_sq += var;
  }
  const Vec7 measured = (sum_sq / kWalks).cwiseSqrt();
  for (int i = 0; i < 7; ++i) EXPECT_NEAR(measured[i] / expected[i], 1.0, 0.06) << "DOF " << i;
  // The walks' RMS about their mean is about the size asked for (frames are not evenly spaced).
  const Vec3 walk_rms = (rms_sq / kWalks).cwiseSqrt();
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(walk_rms[a] / rms[a], 1.0, 0.15) << "axis " << a;
}

TEST(RandomWalkStddev, ASensitivityCommonToAllFramesLeavesNothing) {
  std::mt19937 rng(3);
  RefineResult r = random_sensitivities(rng, 30);
  for (Shift& S : r.ins_shift) S = r.ins_shift.front();
  EXPECT_LT(random_walk_stddev(r, Vec3(0.05, 0.05, 0.05), 100.0).maxCoeff(), 1e-12);
}

TEST(RandomWalkStddev, NothingWithoutSensitivitiesOrSpan) {
  std::mt19937 rng(5);
  const RefineResult r = random_sensitivities(rng, 20);
  EXPECT_EQ(random_walk_stddev(RefineResult{}, Vec3(0.05, 0.05, 0.05), 100.0), Vec7::Zero());
  EXPECT_EQ(random_walk_stddev(r, Vec3(0.05, 0.05, 0.05), 0.0), Vec7::Zero());
  EXPECT_EQ(random_walk_stddev(r, Vec3::Zero(), 100.0), Vec7::Zero());
}

}  // namespace
}  // namespace insalign
