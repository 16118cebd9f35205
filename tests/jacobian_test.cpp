// The hand-written Jacobians of stage 2 (plane thickness with its time-offset column) and of the
// scan registration checked against central differences of their own costs.
#include <gtest/gtest.h>

#include <random>

#include "core/refine.hpp"
#include "core/scan_registration.hpp"
#include "test_world.hpp"

namespace insalign {
namespace {

TEST(Jacobian, Stage2GradientMatchesNumericDifferentiationIncludingTheTimeOffset) {
  testing::WorldSpec spec;
  spec.T_ins_lidar = testing::roof_mount(40.0);
  spec.frames = 120;
  spec.lidar.noise_m = 0.0;
  const testing::TestDrive drive = testing::make_test_drive(spec);
  const FrameStore store = testing::store_of(drive.data);
  RefineConfig config;
  config.huber_m = 1e3;  // plain least squares: the cost is differentiable everywhere
  config.max_frames = 30;
  const std::vector<std::size_t> frames = refine_frames(store, config, 0.0, 0.05);
  // Away from the optimum, so the gradient is far from zero.
  const Iso3 T0 = testing::perturbed(drive.T_ins_lidar_true, 0.3, 0.03, 4);
  const double offset0 = 0.004;
  const double h[7] = {1e-4, 1e-4, 1e-4, 2e-6, 2e-6, 2e-6, 1e-5};
  std::vector<std::pair<Iso3, double>> states = {{T0, offset0}};
  for (int i = 0; i < 7; ++i) {
    for (double sign : {+1.0, -1.0}) {
      Vec6 d = Vec6::Zero();
      if (i < 6) d[i] = sign * h[i];
      states.push_back({perturb_in_ins_frame(T0, d), offset0 + (i == 6 ? sign * h[i] : 0.0)});
    }
  }
  const std::vector<RefineSystem> sys = refine_systems(store, frames, states, config);
  ASSERT_GT(sys[0].points, 1000u);
  for (int i = 0; i < 7; ++i) {
    const double numeric = 0.5 * (sys[1 + 2 * i].cost - sys[2 + 2 * i].cost) / (2.0 * h[i]);
    const double analytic = sys[0].gradient[i];
    std::printf("parameter %d: analytic %.6g numeric %.6g\n", i, analytic, numeric);
    EXPECT_NEAR(analytic, numeric, 0.005 * std::abs(numeric) + 1e-3) << "parameter " << i;
  }
}

TEST(Jacobian, ScanRegistrationGradientMatchesNumericDifferentiation) {
  std::mt19937 rng(3);
  std::normal_distribution<double> n01(0.0, 1.0);
  std::vector<Vec3> p_source, q_target, n_target;
  for (int i = 0; i < 300; ++i) {
    p_source.push_back(Vec3(10 * n01(rng), 10 * n01(rng), 2 * n01(rng)));
    q_target.push_back(p_source.back() + 0.2 * Vec3(n01(rng), n01(rng), n01(rng)));
    n_target.push_back(Vec3(n01(rng), n01(rng), n01(rng)).normalized());
  }
  const Iso3 T0 = make_transform(Vec3(0.3, -0.2, 0.1), Vec3(2.0, -1.0, 5.0));
  const double huber = 1e3;
  const PointToPlaneSystem base = point_to_plane_system(p_source, q_target, n_target, T0, huber);
  for (int i = 0; i < 6; ++i) {
    auto cost_at = [&](double step) {
      Vec6 d = Vec6::Zero();
      d[i] = step;
      Iso3 left = Iso3::Identity();  // T <- exp([rho; omega]) T, the registration's perturbation
      left.linear() = so3_exp(d.tail<3>());
      left.translation() = d.head<3>();
      return point_to_plane_system(p_source, q_target, n_target, left * T0, huber).cost;
    };
    const double h = 1e-6;
    const double numeric = (cost_at(h) - cost_at(-h)) / (2 * h);
    EXPECT_NEAR(base.gradient[i], numeric, 1e-5 * std::max(1.0, std::abs(numeric))) << "parameter " << i;
    // Gauss-Newton: the Hessian is J^T J, exact for residuals linear in the perturbation's first order.
    EXPECT_GT(base.hessian(i, i), 0.0);
  }
}

}  // namespace
}  // namespace insalign
