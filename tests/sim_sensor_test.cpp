// Simulator facts: sensor models, sweep timing, determinism, mount, INS noise, scene layout.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "sim/scene.hpp"
#include "sim/simulate.hpp"

namespace insalign::sim {
namespace {

SimConfig small_config(std::uint64_t seed = 7) {
  SimConfig c;
  c.seed = seed;
  c.duration_s = 0.5;
  c.azimuth_step_deg = 1.0;
  return c;
}

TEST(SimLidarModel, BeamTables) {
  const LidarModel p = lidar_model("pandar64");
  ASSERT_EQ(p.elevation_deg.size(), 64u);
  EXPECT_DOUBLE_EQ(p.elevation_deg.front(), 15.0);
  EXPECT_DOUBLE_EQ(p.elevation_deg.back(), -25.0);
  for (std::size_t i = 1; i < p.elevation_deg.size(); ++i) EXPECT_LT(p.elevation_deg[i], p.elevation_deg[i - 1]);
  // Denser near the horizon than at the edges.
  EXPECT_LT(p.elevation_deg[20] - p.elevation_deg[21], 0.2);
  EXPECT_GT(p.elevation_deg[0] - p.elevation_deg[1], 3.0);
  EXPECT_GT(p.elevation_deg[62] - p.elevation_deg[63], 5.0);

  const LidarModel h = lidar_model("hdl32");
  ASSERT_EQ(h.elevation_deg.size(), 32u);
  EXPECT_NEAR(h.elevation_deg.front(), 10.67, 1e-9);
  EXPECT_NEAR(h.elevation_deg.back(), -30.67, 1e-9);

  const LidarModel o = lidar_model("os1-64");
  ASSERT_EQ(o.elevation_deg.size(), 64u);
  EXPECT_NEAR(o.elevation_deg.front(), 16.6, 1e-9);
  EXPECT_NEAR(o.elevation_deg.back(), -16.6, 1e-9);

  const LidarModel v = lidar_model("vlp16");
  ASSERT_EQ(v.elevation_deg.size(), 16u);
  EXPECT_NEAR(v.elevation_deg.front(), 15.0, 1e-9);
  EXPECT_NEAR(v.elevation_deg.back(), -15.0, 1e-9);

  for (const std::string& name : lidar_model_names()) EXPECT_EQ(lidar_model(name).name, name);
  EXPECT_THROW(lidar_model("vlp16x"), std::invalid_argument);
}

TEST(SimSweep, TimingRingsAndRanges) {
  const SimDataset sim = simulate(small_config());
  ASSERT_EQ(sim.sweeps.size(), 5u);
  for (std::size_t k = 0; k < sim.sweeps.size(); ++k) {
    const Sweep& s = sim.sweeps[k];
    ASSERT_GT(s.size(), 5000u);
    ASSERT_EQ(s.dt_s.size(), s.size());
    ASSERT_EQ(s.ring.size(), s.size());
    ASSERT_EQ(s.intensity.size(), s.size());
    // Frame time = end of sweep = latest point time; the sweep covers one revolution before it.
    EXPECT_FLOAT_EQ(*std::max_element(s.dt_s.begin(), s.dt_s.end()), 0.0f);
    EXPECT_GE(*std::min_element(s.dt_s.begin(), s.dt_s.end()), -0.1f);
    EXPECT_LT(*std::min_element(s.dt_s.begin(), s.dt_s.end()), -0.099f);
    EXPECT_TRUE(std::is_sorted(s.dt_s.begin(), s.dt_s.end()));
    EXPECT_EQ(s.name, frame_name(s.t_end_s));
    EXPECT_NEAR(std::stod(s.name), s.t_end_s, 1e-6);
    if (k > 0) {
      EXPECT_NEAR(s.t_end_s - sim.sweeps[k - 1].t_end_s, 0.1, 1e-6);
    }
    for (std::size_t i = 0; i < s.size(); ++i) {
      ASSERT_LT(s.ring[i], 64);
      ASSERT_GE(s.intensity[i], 0.0f);
      ASSERT_LE(s.intensity[i], 255.0f);
      ASSERT_LE(s.p_lidar[i].norm(), 120.0f);
    }
  }
  // Every ring fires: 64 distinct rings present.
  std::vector<int> seen(64, 0);
  for (auto r : sim.sweeps[0].ring) seen[r] = 1;
  EXPECT_EQ(std::count(seen.begin(), seen.end(), 1), 64);
}

TEST(SimSweep, DeterministicPerSeed) {
  const SimDataset a = simulate(small_config(3));
  const SimDataset b = simulate(small_config(3));
  const SimDataset c = simulate(small_config(4));
  ASSERT_EQ(a.sweeps.size(), b.sweeps.size());
  for (std::size_t k = 0; k < a.sweeps.size(); ++k) {
    ASSERT_EQ(a.sweeps[k].size(), b.sweeps[k].size());
    for (std::size_t i = 0; i < a.sweeps[k].size(); ++i) {
      ASSERT_EQ(a.sweeps[k].p_lidar[i], b.sweeps[k].p_lidar[i]);
      ASSERT_EQ(a.sweeps[k].intensity[i], b.sweeps[k].intensity[i]);
    }
  }
  EXPECT_TRUE(a.T_ins_lidar_true.isApprox(b.T_ins_lidar_true));
  EXPECT_FALSE(a.T_ins_lidar_true.isApprox(c.T_ins_lidar_true));
  EXPECT_NE(a.sweeps[0].size(), c.sweeps[0].size());
}

TEST(SimWorld, InitialGuessHasExactlyTheRequestedError) {
  SimConfig cfg = small_config();
  cfg.init_rot_err_deg = 20.0;
  cfg.init_trans_err_m = 0.5;
  const World w = build_world(cfg);
  const ExtrinsicError e = extrinsic_error(w.T_ins_lidar_init, w.T_ins_lidar_true);
  EXPECT_NEAR(e.angle_deg, 20.0, 1e-9);
  EXPECT_NEAR(e.dt_norm_m, 0.5, 1e-12);
}

TEST(SimWorld, RoofMountIsPhysical) {
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    SimConfig cfg = small_config(seed);
    cfg.ins_noise_scale = 0.0;
    const World w = build_world(cfg);
    EXPECT_GE(w.ins_height_m, 0.5);
    EXPECT_LE(w.ins_height_m, 1.0);
    const Iso3 T_world_lidar = w.poses_true.T_world_ins(w.frame_times_s[0]) * w.T_ins_lidar_true;
    const Vec3 p = T_world_lidar.translation();
    const double height = p.z() - w.scene->ground.z_at(p.x(), p.y());
    EXPECT_GT(height, 1.75) << "seed " << seed;
    EXPECT_LT(height, 2.25) << "seed " << seed;
    // Roll and pitch of the LiDAR relative to the (nearly level) vehicle within ~10 deg.
    const Vec3 z_lidar_world = T_world_lidar.linear().col(2);
    EXPECT_GT(z_lidar_world.z(), std::cos(15.0 * kRadPerDeg));
  }
  SimConfig given = small_config();
  given.T_ins_lidar = make_transform(Vec3(1, 0.2, 1.3), Vec3(1, 2, 90));
  EXPECT_TRUE(build_world(given).T_ins_lidar_true.isApprox(*given.T_ins_lidar));
}

TEST(SimWorld, Figure8RollAndInsAxes) {
  SimConfig cfg;  // full default drive (no rendering here, only the trajectory)
  cfg.seed = 11;
  World w = build_world(cfg);
  EXPECT_GT(w.frame_count(), 900u);
  EXPECT_LT(w.frame_count(), 1300u);
  double max_roll = 0.0, max_pitch = 0.0;
  double total_turn = 0.0, last_yaw = 0.0;
  for (std::size_t k = 0; k < w.frame_count(); ++k) {
    const Vec3 rpy = rpy_from_rotation(w.poses_true.T_world_ins(w.frame_times_s[k]).linear()) * kDegPerRad;
    max_roll = std::max(max_roll, std::abs(rpy.x()));
    max_pitch = std::max(max_pitch, std::abs(rpy.y()));
    if (k > 0) total_turn += std::abs(std::remainder(rpy.z() - last_yaw, 360.0));
    last_yaw = rpy.z();
  }
  EXPECT_GT(max_roll, 0.4);
  EXPECT_LT(max_roll, 2.0);
  EXPECT_LT(max_pitch, 1.5);
  EXPECT_GT(total_turn, 3 * 360.0);  // three figure-8s turn through far more than a full circle

  // NovAtel axes: the vehicle moves along the INS +y axis.
  cfg.ins_axes = InsAxes::kYForward;
  w = build_world(cfg);
  const double t = w.frame_times_s[300];
  const Iso3 a = w.poses_true.T_world_ins(t), b = w.poses_true.T_world_ins(t + 0.1);
  const Vec3 v_ins = a.linear().transpose() * (b.translation() - a.translation());
  EXPECT_GT(v_ins.y(), 0.3);
  EXPECT_LT(std::abs(v_ins.x()), 0.05 * v_ins.y());
}

TEST(SimWorld, InsNoiseMatchesItsClass) {
  SimConfig cfg = small_config();
  cfg.duration_s = 60.0;
  World w = build_world(cfg);
  const auto rep = dense_reported_poses(w, 100.0);
  ASSERT_GT(rep.size(), 5000u);
  double sum_sq = 0.0, yaw_sq = 0.0;
  double max_pos = 0.0;
  for (const StampedPose& p : rep) {
    const Iso3 T_true = w.poses_true.T_world_ins(p.t_s);
    const Vec3 d = p.T_world_ins.translation() - T_true.translation();
    sum_sq += d.squaredNorm() / 3.0;
    max_pos = std::max(max_pos, d.norm());
    const Vec3 rpy = rpy_from_rotation(T_true.linear().transpose() * p.T_world_ins.linear()) * kDegPerRad;
    yaw_sq += rpy.z() * rpy.z();
  }
  const double pos_rms = std::sqrt(sum_sq / rep.size()), yaw_rms = std::sqrt(yaw_sq / rep.size());
  EXPECT_GT(pos_rms, 0.008);
  EXPECT_LT(pos_rms, 0.05);
  EXPECT_LT(max_pos, 0.2);
  EXPECT_NEAR(yaw_rms, 0.03, 0.006);

  cfg.ins_noise_scale = 0.0;
  w = build_world(cfg);
  for (const StampedPose& p : frame_poses(w, {w.frame_times_s[10]}))
    EXPECT_TRUE(p.T_world_ins.isApprox(w.poses_true.T_world_ins(w.frame_times_s[10]), 1e-12));
}

TEST(SimScene, VariesWithSeedAndKeepsTheCorridorClear) {
  SimConfig cfg = small_config(21);
  const World a = build_world(cfg);
  cfg.seed = 22;
  const World b = build_world(cfg);
  ASSERT_GT(a.scene->boxes.size(), 20u);
  ASSERT_GT(a.scene->spheres.size(), 50u);
  EXPECT_NE(a.scene->boxes.size(), b.scene->boxes.size());
  // Buildings are not all axis-aligned with each other.
  int off_grid = 0;
  for (const Box& box : a.scene->boxes) {
    const double r = std::remainder(box.yaw_rad - a.scene->boxes.front().yaw_rad, 3.14159265358979 / 2);
    if (std::abs(r) > 0.05) ++off_grid;
  }
  EXPECT_GT(off_grid, 3);
  // Along the whole default drive nothing stands within 2.5 m of the INS at 1 m above ground.
  SimConfig full;
  full.seed = 21;
  const World w = build_world(full);
  for (double t = w.poses_true.t_begin(); t < w.poses_true.t_end(); t += 0.5) {
    const Vec3 p = w.poses_true.T_world_ins(t).translation();
    const Vec3 o(p.x(), p.y(), w.scene->ground.z_at(p.x(), p.y()) + 1.0);
    for (int k = 0; k < 16; ++k) {
      const double a16 = k * 3.14159265358979 / 8;
      const auto hit = w.scene->cast(o, Vec3(std::cos(a16), std::sin(a16), 0.0), 2.5);
      EXPECT_FALSE(hit.has_value()) << "obstacle at t=" << t;
    }
  }
  // Fiducials on free ground next to the path.
  ASSERT_EQ(w.fiducials.size(), 6u);
  for (const Fiducial& f : w.fiducials)
    EXPECT_NEAR(f.p_world.z(), w.scene->ground.z_at(f.p_world.x(), f.p_world.y()), 0.03);
}

TEST(SimWorld, RejectsBadConfig) {
  SimConfig c = small_config();
  c.azimuth_step_deg = 0.0;
  EXPECT_THROW(build_world(c), std::invalid_argument);
  c = small_config();
  c.lidar_model = "nope";
  EXPECT_THROW(build_world(c), std::invalid_argument);
  c = small_config();
  c.trajectory = TrajectoryKind::kRecorded;
  EXPECT_THROW(build_world(c), std::invalid_argument);
}

TEST(SimWorld, RecordedTrajectoryIsFollowed) {
  // A synthetic "recording" in NovAtel axes: a 40 m arc at 4 m/s, 10 Hz.
  SimConfig c = small_config();
  c.trajectory = TrajectoryKind::kRecorded;
  c.duration_s = 0.0;
  for (int i = 0; i < 100; ++i) {
    const double t = 100.0 + 0.1 * i, a = 0.01 * i;  // 4 m/s on a 40 m radius
    Iso3 T_world_ins = Iso3::Identity();
    const double heading = a;  // vehicle heading along the arc
    T_world_ins.linear() = rotation_from_rpy(Vec3(0, 0, heading - 3.14159265358979 / 2));
    T_world_ins.translation() = Vec3(40 * std::sin(a), 40 * (1 - std::cos(a)), 5.0);
    c.recorded_trajectory.push_back({t, T_world_ins});
  }
  c.ins_axes = InsAxes::kXForward;
  const World w = build_world(c);
  EXPECT_NEAR(static_cast<double>(w.frame_count()), 99.0, 1.0);
  // Re-expressed in x-forward axes: the motion is along +x of the INS.
  const Iso3 a = w.poses_true.T_world_ins(w.frame_times_s[50]), b = w.poses_true.T_world_ins(w.frame_times_s[51]);
  const Vec3 v = a.linear().transpose() * (b.translation() - a.translation());
  EXPECT_GT(v.x(), 0.3);
  EXPECT_LT(std::abs(v.y()), 0.05 * v.x());
  // Recentred on the first pose.
  EXPECT_LT(w.poses_true.T_world_ins(w.poses_true.t_begin()).translation().head<2>().norm(), 0.1);
}

}  // namespace
}  // namespace insalign::sim
