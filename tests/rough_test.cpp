#include "core/rough.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <random>

#include "test_world.hpp"
#include "sim/world_dataset.hpp"

namespace insalign {
namespace {

using testing::Drive;

// Observations of a few planes from several poses, for the derivative checks.
std::vector<PlaneObservation> synthetic_observations(const Iso3& T_ins_lidar, double noise_m) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  std::normal_distribution<double> gauss(0.0, noise_m);
  struct WorldPlane {
    Vec3 c, n;
  };
  const std::vector<WorldPlane> planes{{Vec3(5, 0, 0), Vec3::UnitZ()},
                                       {Vec3(8, 3, 2), Vec3(1, 0.3, 0).normalized()},
                                       {Vec3(-4, 6, 1), Vec3(0.2, 1, 0.1).normalized()},
                                       {Vec3(0, -7, 3), Vec3(0.5, -1, 0.4).normalized()}};
  std::vector<Iso3> T_world_ins;
  for (int k = 0; k < 5; ++k)
    T_world_ins.push_back(make_transform(Vec3(1.5 * k, 0.5 * k * k * 0.2, 0.02 * k), Vec3(0.5 * k, -0.3 * k, 25.0 * k)));
  std::vector<PlaneObservation> obs;
  for (std::size_t j = 0; j < planes.size(); ++j) {
    const Vec3 u = planes[j].n.unitOrthogonal(), v = planes[j].n.cross(u);
    for (const Iso3& T_wi : T_world_ins) {
      PlaneObservation o;
      o.plane = j;
      o.T_world_ins = T_wi;
      const Iso3 T_lidar_world = (T_wi * T_ins_lidar).inverse();
      for (int i = 0; i < 30; ++i) {
        const Vec3 p_world = planes[j].c + 2.0 * uni(rng) * u + 2.0 * uni(rng) * v + gauss(rng) * planes[j].n;
        o.p_lidar.push_back((T_lidar_world * p_world).cast<float>());
      }
      obs.push_back(std::move(o));
    }
  }
  return obs;
}

TEST(Rough, AnalyticGradientMatchesNumericDifferentiation) {
  const Iso3 T_true = testing::roof_mount(30.0);
  const auto obs = synthetic_observations(T_true, 0.01);
  // Away from the optimum so the gradient is not ~0; a large robust scale keeps weights ~1.
  const Iso3 T = testing::perturbed(T_true, 1.0, 0.05, 4);
  const double scale = 100.0;
  const PointPlaneSystem sys = point_plane_system(obs, T, scale);
  const double h = 1e-6;
  for (int i = 0; i < 6; ++i) {
    Vec6 d = Vec6::Zero();
    d(i) = h;
    const double cp = point_plane_system(obs, perturb_in_ins_frame(T, d), scale).cost;
    const double cm = point_plane_system(obs, perturb_in_ins_frame(T, -d), scale).cost;
    const double numeric_half_gradient = (cp - cm) / (4.0 * h);
    EXPECT_NEAR(sys.gradient(i), numeric_half_gradient, 1e-4 * std::max(1.0, std::abs(numeric_half_gradient)))
        << "DOF " << i;
  }
}

TEST(Rough, GaussNewtonHessianMatchesNumericAtZeroResidual) {
  const Iso3 T_true = testing::roof_mount(-70.0);
  const auto obs = synthetic_observations(T_true, 0.0);
  const double scale = 100.0;
  const PointPlaneSystem sys = point_plane_system(obs, T_true, scale);
  // At zero residual J^T J is the exact Hessian of cost / 2 (planes eliminated): differentiate the
  // analytic half gradient numerically.
  const double h = 1e-6;
  Mat6 numeric;
  for (int i = 0; i < 6; ++i) {
    Vec6 d = Vec6::Zero();
    d(i) = h;
    numeric.col(i) = (point_plane_system(obs, perturb_in_ins_frame(T_true, d), scale).gradient -
                      point_plane_system(obs, perturb_in_ins_frame(T_true, -d), scale).gradient) /
                     (2.0 * h);
  }
  EXPECT_LT((sys.hessian - numeric).norm(), 1e-4 * sys.hessian.norm()) << sys.hessian << "\n\n" << numeric;
  EXPECT_LT(sys.sigma_m, 1e-6);
}

TEST(Rough, ConvergesFromTwentyDegreesAndHalfAMetreOnAFigureEight) {
  for (double yaw : {135.0}) {
    const auto drive = testing::town_drive(Drive::kFigure8, testing::roof_mount(yaw), 240, 2);
    const Iso3 init = testing::perturbed(drive.T_ins_lidar_true, 20.0, 0.5, static_cast<unsigned>(yaw) + 1);
    const FrameStore store = testing::store_of(drive.data);
    const RoughResult r = calibrate_rough(store, rough_frame_groups(store), init, 0.0);
    const ExtrinsicError e = extrinsic_error(r.T_ins_lidar, drive.T_ins_lidar_true);
    for (const auto& log : r.convergence) {
      const ExtrinsicError el = extrinsic_error(log.T_ins_lidar, drive.T_ins_lidar_true);
      std::printf("round %d: planes %zu residuals %zu cost %.4f  rot %.3f %.3f %.3f deg  t %.3f %.3f %.3f m\n",
                  log.round, log.planes, log.residuals, log.cost, el.drpy_deg.x(), el.drpy_deg.y(), el.drpy_deg.z(),
                  el.dt_m.x(), el.dt_m.y(), el.dt_m.z());
    }
    std::printf("yaw %.0f: %.2f s, frames %zu, sigma %.4f m, verdict: %s\n", yaw, r.outcome.wall_time_s, r.frames_used,
                r.residual_sigma_m, r.observability.explanation.c_str());
    EXPECT_LT(e.drpy_deg.maxCoeff(), 0.2) << "yaw " << yaw;
    EXPECT_LT(e.dt_m.x(), 0.03) << "yaw " << yaw;
    EXPECT_LT(e.dt_m.y(), 0.03) << "yaw " << yaw;
    EXPECT_FALSE(r.tz_estimated);
    EXPECT_NEAR(r.T_ins_lidar.translation().z(), init.translation().z(), 1e-12);
  }
}

TEST(Rough, ConvergesOnAShortReducedResolutionSimulatedDrive) {
  sim::SimConfig config;
  config.seed = 4;
  config.duration_s = 45.0;         // a little over one loop of the figure-8
  config.azimuth_step_deg = 1.0;    // 360 columns instead of 1800
  config.init_rot_err_deg = 20.0;
  config.init_trans_err_m = 0.5;
  auto world = std::make_shared<const sim::World>(sim::build_world(config));
  const Dataset data = sim::world_dataset(world);
  const FrameStore store = testing::store_of(data);
  const RoughResult r = calibrate_rough(store, rough_frame_groups(store), world->T_ins_lidar_init, 0.0);
  const ExtrinsicError e = extrinsic_error(r.T_ins_lidar, world->T_ins_lidar_true);
  const ExtrinsicError e0 = extrinsic_error(world->T_ins_lidar_init, world->T_ins_lidar_true);
  std::printf("start %.1f deg %.2f m -> rot %.3f %.3f %.3f deg, t %.2f %.2f %.2f cm in %.2f s; %s\n", e0.angle_deg,
              e0.dt_norm_m, e.drpy_deg.x(), e.drpy_deg.y(), e.drpy_deg.z(), e.dt_m.x() * 100, e.dt_m.y() * 100,
              e.dt_m.z() * 100, r.outcome.wall_time_s, r.observability.explanation.c_str());
  EXPECT_GT(e0.angle_deg, 19.0);
  EXPECT_LT(e.drpy_deg.maxCoeff(), 0.2);
  EXPECT_LT(e.dt_m.x(), 0.03);
  EXPECT_LT(e.dt_m.y(), 0.03);
  // Planar driving: tz is the only DOF the data leaves open, and it is kept, not guessed.
  EXPECT_EQ(r.observability.determined, (std::array<bool, 6>{true, true, false, true, true, true}))
      << r.observability.explanation;
  EXPECT_FALSE(unobservable_reason(r.observability).has_value());
  EXPECT_EQ(r.outcome.status, StageStatus::kOk) << r.outcome.message;
  EXPECT_DOUBLE_EQ(r.T_ins_lidar.translation().z(), world->T_ins_lidar_init.translation().z());
}

}  // namespace
// A near start skips the first rounds of one-group windows; a schedule of only those is kept.
TEST(RoughSchedule, MultiGroupRoundsStartAtTheFirstRoundOfSeveralGroups) {
  const std::vector<RoughRound> all = default_rough_schedule();
  const std::vector<RoughRound> kept = multi_group_rounds(all);
  ASSERT_FALSE(kept.empty());
  EXPECT_NE(kept.front().window_groups, 1);
  EXPECT_LT(kept.size(), all.size());
  for (std::size_t k = 0; k < kept.size(); ++k) EXPECT_EQ(kept[k].root_voxel_m, all[all.size() - kept.size() + k].root_voxel_m);
  for (std::size_t k = 0; k < all.size() - kept.size(); ++k) EXPECT_EQ(all[k].window_groups, 1);
  const std::vector<RoughRound> local = {all.front(), all.front()};
  EXPECT_EQ(multi_group_rounds(local).size(), 2u);
}

// Stage 2 following leaves out the last round only, and only when the config says so.
TEST(RoughSchedule, Stage2FollowingSkipsTheLastRound) {
  RoughConfig config;
  const std::vector<RoughRound>& all = config.rounds;
  const std::vector<RoughRound> near = multi_group_rounds(all);
  EXPECT_EQ(pipeline_rounds(config, false, false).size(), all.size());
  EXPECT_EQ(pipeline_rounds(config, true, false).size(), near.size());
  const std::vector<RoughRound> before_stage2 = pipeline_rounds(config, false, true);
  ASSERT_EQ(before_stage2.size(), all.size() - 1);
  EXPECT_EQ(before_stage2.back().root_voxel_m, all[all.size() - 2].root_voxel_m);
  EXPECT_EQ(pipeline_rounds(config, true, true).size(), near.size() - 1);
  config.rounds = {all.back()};
  EXPECT_EQ(pipeline_rounds(config, true, true).size(), 1u);  // never none
  config.rounds = all;
  config.stage2_skips_last_round = false;
  config.near_start_skips_single_group_rounds = false;
  EXPECT_EQ(pipeline_rounds(config, true, true).size(), all.size());
}

}  // namespace insalign
