// Moving traffic for the simulated street: vehicles in the lanes beside the driven path, cyclists
// in the bike lanes, pedestrians on the sidewalks and crossing. Each mover follows a route at a
// constant speed and exists only while on it; routes are checked against the static scene, the
// ego vehicle and each other so that nothing drives through anything. Ray casting places the
// movers at each ray's own time, so they smear as a spinning LiDAR sees them.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "core/geometry.hpp"
#include "sim/scene.hpp"

namespace insalign::sim {

enum class MoverKind : std::uint8_t { kCar, kVan, kCyclist, kPedestrian };

struct Mover {
  MoverKind kind = MoverKind::kCar;
  std::vector<Vec2> route_xy;     ///< world polyline, about 0.5 m steps
  std::vector<double> route_s_m;  ///< cumulative length along route_xy
  double speed_mps = 1.0;
  double t_start_s = 0.0;         ///< INS clock: at route_xy.front() then
  Vec3 half_m = Vec3::Ones();     ///< half length, half width, half height (pedestrian: radius, radius)
  float reflectivity = 0.4f;
  double t_end_s() const { return t_start_s + route_s_m.back() / speed_mps; }
};

struct MoverPose {
  Vec2 xy = Vec2::Zero();
  double yaw_rad = 0.0;
};
/// Where the mover is at t (INS clock); nullopt before it starts or after it ends its route.
std::optional<MoverPose> mover_pose(const Mover& mover, double t_s);

/// A mover's geometry at one instant, with a bounding sphere for cheap culling.
struct PlacedMover {
  Box boxes[2];
  int n_boxes = 0;             ///< 0: a cylinder (pedestrian)
  Cylinder cylinder;
  Vec3 center_m = Vec3::Zero();
  double radius_m = 0.0;
};

struct Traffic {
  std::vector<Mover> movers;
  /// The movers present at t, standing on `ground`, appended to `out` (cleared first).
  void place(double t_s, const GroundPlane& ground, std::vector<PlacedMover>& out) const;
};

/// Nearest hit on the candidates along origin + s * dir with s in (0, max_range_m]. Thread-safe.
std::optional<RayHit> cast_movers(const std::vector<PlacedMover>& candidates, const Vec3& origin, const Vec3& dir,
                                  double max_range_m);

/// The ego vehicle's body at an INS time: centre (world xy), heading, half length and width.
struct EgoFootprint {
  std::function<MoverPose(double t_s)> pose;
  Vec2 half_m = Vec2(2.35, 0.95);
};

struct TrafficRequest {
  int vehicles = 0;            ///< cars and vans
  int people = 0;              ///< pedestrians and cyclists
  std::vector<Vec2> path_xy;   ///< one pass of the driven path (the scene's corridor)
  double t_begin_s = 0.0, t_end_s = 0.0;  ///< the drive, INS clock
  std::uint64_t seed = 1;
};

/// Seeded traffic. A mover that finds no free route after many tries is left out, so the result
/// may hold fewer than requested (the caller reports how many).
Traffic make_traffic(const TrafficRequest& request, const Scene& scene, const EgoFootprint& ego);

}  // namespace insalign::sim
