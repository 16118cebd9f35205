// Moving traffic: movers are seen, their points are flagged and move between frames while the
// static points stay; movers never overlap the ego vehicle or the static scene; vehicles drive
// both ways and people cross the road.
#include <gtest/gtest.h>

#include <cmath>
#include <unordered_set>
#include <vector>

#include "sim/scene.hpp"
#include "sim/simulate.hpp"
#include "sim/traffic.hpp"

namespace insalign::sim {
namespace {

SimConfig traffic_config() {
  SimConfig c;
  c.seed = 3;
  c.azimuth_step_deg = 0.8;
  c.ins_noise_scale = 0.0;
  c.traffic = 20;
  c.pedestrians = 30;
  return c;
}

const World& traffic_world() {
  static const World world = build_world(traffic_config());
  return world;
}

// World points of a frame within 25 m (true poses, per-point time), split by the mover flag.
void world_points(const World& w, std::size_t k, std::vector<Vec3>& statics, std::vector<Vec3>& movers) {
  std::vector<std::uint8_t> flag;
  const Sweep s = render_sweep(w, k, &flag);
  ASSERT_EQ(flag.size(), s.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s.p_lidar[i].norm() > 25.0f) continue;  // sparse far away: neighbourhoods say little
    const double t = s.t_end_s + s.dt_s[i] + w.config.time_offset_s;
    const Vec3 p = w.poses_true.T_world_ins(t) * w.T_ins_lidar_true * s.p_lidar[i].cast<double>();
    (flag[i] ? movers : statics).push_back(p);
  }
}

struct VoxelSet {
  double size_m;
  std::unordered_set<long long> keys;
  static long long key(long long x, long long y, long long z) { return (x * 73856093) ^ (y * 19349663) ^ (z * 83492791); }
  void add(const Vec3& p) { keys.insert(key(cell(p.x()), cell(p.y()), cell(p.z()))); }
  long long cell(double v) const { return static_cast<long long>(std::floor(v / size_m)); }
  bool near(const Vec3& p) const {  // the point's voxel or a neighbour holds a point
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz)
          if (keys.count(key(cell(p.x()) + dx, cell(p.y()) + dy, cell(p.z()) + dz))) return true;
    return false;
  }
};

double fraction_near(const std::vector<Vec3>& pts, const std::vector<Vec3>& other, double voxel_m) {
  VoxelSet set{voxel_m, {}};
  for (const Vec3& p : other) set.add(p);
  std::size_t near = 0;
  for (const Vec3& p : pts) near += set.near(p);
  return pts.empty() ? 0.0 : static_cast<double>(near) / static_cast<double>(pts.size());
}

TEST(SimTraffic, MoverPointsAreFlaggedAndMoveWhileStaticPointsStay) {
  const World& w = traffic_world();
  ASSERT_GE(w.traffic->movers.size(), 45u) << "most of the 50 movers find room";
  std::size_t frames_with_movers = 0;
  for (std::size_t k : {150u, 400u, 700u}) {
    std::vector<Vec3> s0, m0, s1, m1;
    world_points(w, k, s0, m0);
    world_points(w, k + 5, s1, m1);  // half a second later
    if (m0.size() < 100 || m1.size() < 100) continue;
    ++frames_with_movers;
    // The street stays where it was; the movers do not (0.2 m voxels, their neighbours count).
    const double statics = fraction_near(s0, s1, 0.2), movers = fraction_near(m0, m1, 0.2);
    EXPECT_GT(statics, 0.8) << "frame " << k;
    EXPECT_LT(movers, 0.5) << "frame " << k;
    EXPECT_LT(movers, 0.5 * statics) << "frame " << k;
    RecordProperty("static_" + std::to_string(k), std::to_string(statics));
    RecordProperty("mover_" + std::to_string(k), std::to_string(movers));
  }
  EXPECT_GE(frames_with_movers, 2u);
}

TEST(SimTraffic, FlaggedPointsLieOnAMoverAtTheirOwnTime) {
  const World& w = traffic_world();
  std::vector<std::uint8_t> flag;
  const std::size_t k = 400;
  const Sweep s = render_sweep(w, k, &flag);
  std::vector<PlacedMover> placed;
  std::size_t checked = 0, on_surface = 0;
  for (std::size_t i = 0; i < s.size(); i += 7) {
    if (!flag[i]) continue;
    const double t = s.t_end_s + s.dt_s[i];
    const Vec3 p = w.poses_true.T_world_ins(t) * w.T_ins_lidar_true * s.p_lidar[i].cast<double>();
    w.traffic->place(t, w.scene->ground, placed);
    double nearest = 1e9;
    for (const PlacedMover& m : placed) nearest = std::min(nearest, (p - m.center_m).norm() - m.radius_m);
    ++checked;
    on_surface += nearest < 0.1;  // range noise 2 cm
  }
  ASSERT_GT(checked, 20u);
  EXPECT_EQ(on_surface, checked);
}

// Points along a footprint's outline, every 0.25 m.
std::vector<Vec2> outline(const MoverPose& pose, const Vec2& half) {
  std::vector<Vec2> out;
  const Vec2 u(std::cos(pose.yaw_rad), std::sin(pose.yaw_rad)), v(-u.y(), u.x());
  for (double a = -half.x(); a <= half.x() + 1e-9; a += 0.25)
    for (double b : {-half.y(), half.y()}) out.push_back(pose.xy + a * u + b * v);
  for (double b = -half.y(); b <= half.y() + 1e-9; b += 0.25)
    for (double a : {-half.x(), half.x()}) out.push_back(pose.xy + a * u + b * v);
  return out;
}
bool inside(const Vec2& q, const MoverPose& pose, const Vec2& half) {
  const Vec2 d = q - pose.xy;
  const Vec2 u(std::cos(pose.yaw_rad), std::sin(pose.yaw_rad)), v(-u.y(), u.x());
  return std::abs(d.dot(u)) < half.x() && std::abs(d.dot(v)) < half.y();
}

void expect_no_overlap(const World& w) {
  const Iso3 T_ins_vehicle = w.T_vehicle_ins.inverse();
  const Vec2 ego_half(2.35, 0.95);
  std::size_t samples = 0;
  for (double t = w.frame_times_s.front(); t < w.frame_times_s.back(); t += 0.25) {
    const Iso3 T_world_vehicle = w.poses_true.T_world_ins(t) * T_ins_vehicle;
    const Vec3 c = T_world_vehicle * Vec3(1.25, 0, 0), x = T_world_vehicle.linear().col(0);
    const MoverPose ego{c.head<2>(), std::atan2(x.y(), x.x())};
    for (const Mover& m : w.traffic->movers) {
      const auto pose = mover_pose(m, t);
      if (!pose) continue;
      ++samples;
      const Vec2 half = m.half_m.head<2>();
      for (const Vec2& q : outline(*pose, half)) ASSERT_FALSE(inside(q, ego, ego_half)) << "mover in the ego at t=" << t;
      for (const Vec2& q : outline(ego, ego_half)) ASSERT_FALSE(inside(q, *pose, half)) << "ego in a mover at t=" << t;
      // No static geometry within the mover's body: rays from its centre to its corners.
      const double zg = w.scene->ground.z_at(pose->xy.x(), pose->xy.y());
      for (const Vec2& corner : outline(*pose, half)) {
        const Vec2 d = corner - pose->xy;
        if (d.norm() < 1e-6) continue;
        const Vec3 dir(d.x() / d.norm(), d.y() / d.norm(), 0.0);
        for (double z : {0.5, 1.2}) {
          const auto hit = w.scene->cast(Vec3(pose->xy.x(), pose->xy.y(), zg + z), dir, d.norm());
          ASSERT_FALSE(hit.has_value()) << "static geometry inside a mover at t=" << t;
        }
      }
    }
  }
  EXPECT_GT(samples, 1000u);
}

TEST(SimTraffic, MoversNeverOverlapTheEgoOrTheStaticScene) {
  expect_no_overlap(traffic_world());
  SimConfig c = traffic_config();
  c.seed = 9;  // a parked car next to a sidewalk once held a pedestrian here
  expect_no_overlap(build_world(c));
}

TEST(SimTraffic, VehiclesDriveBothWaysAndPeopleCrossTheRoad) {
  const World& w = traffic_world();
  int with = 0, against = 0, crossing = 0, vehicles = 0, people = 0;
  for (const Mover& m : w.traffic->movers) {
    const bool vehicle = m.kind == MoverKind::kCar || m.kind == MoverKind::kVan;
    vehicles += vehicle;
    people += !vehicle;
    const double speed_kmh = m.speed_mps * 3.6;
    if (vehicle) {
      EXPECT_GE(speed_kmh, 15.0);
      EXPECT_LE(speed_kmh, 40.0);
    } else {
      EXPECT_GE(m.speed_mps, 1.0);
      EXPECT_LE(m.speed_mps, 6.0);
    }
    // Direction relative to the ego's path: compare with the ego's motion at the nearest pose.
    const Vec2 a = m.route_xy[m.route_xy.size() / 2 - 1], b = m.route_xy[m.route_xy.size() / 2];
    double best = 1e9, cos_dir = 0.0, min_path_m = 1e9;
    for (double t = w.poses_true.t_begin(); t < w.poses_true.t_end(); t += 0.5) {
      const Vec3 p = w.poses_true.T_world_ins(t).translation();
      const Vec3 q = w.poses_true.T_world_ins(std::min(t + 0.5, w.poses_true.t_end())).translation();
      for (const Vec2& r : m.route_xy) min_path_m = std::min(min_path_m, (r - p.head<2>()).norm());
      const double d = (p.head<2>() - a).norm();
      if (d < best && (q - p).norm() > 0.5) {
        best = d;
        cos_dir = (b - a).normalized().dot((q - p).head<2>().normalized());
      }
    }
    if (vehicle) (cos_dir > 0 ? with : against)++;
    if (!vehicle && min_path_m < 1.5) ++crossing;
  }
  EXPECT_GE(vehicles, 18);
  EXPECT_GE(people, 27);
  EXPECT_GE(with, 3);
  EXPECT_GE(against, 3);
  EXPECT_GE(crossing, 3);
}

TEST(SimTraffic, NoTrafficMeansNoMoverPoints) {
  SimConfig c;
  c.duration_s = 0.2;
  c.azimuth_step_deg = 2.0;
  const World w = build_world(c);
  EXPECT_TRUE(w.traffic->movers.empty());
  std::vector<std::uint8_t> flag;
  const Sweep s = render_sweep(w, 0, &flag);
  EXPECT_EQ(flag.size(), s.size());
  EXPECT_EQ(std::count(flag.begin(), flag.end(), 1), 0);
}

}  // namespace
}  // namespace insalign::sim
