// The simulated world's geometry: a ground plane plus upright boxes, vertical cylinders and spheres
// under a bounding-volume hierarchy, and lane markings painted on the ground (intensity only).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <vector>

#include "core/geometry.hpp"
#include "sim/simulate.hpp"

namespace insalign::sim {

using Vec2 = Eigen::Vector2d;

/// z = z0_m + slope_x * x + slope_y * y (world frame).
struct GroundPlane {
  double z0_m = 0.0, slope_x = 0.0, slope_y = 0.0;
  double z_at(double x, double y) const { return z0_m + slope_x * x + slope_y * y; }
  Vec3 normal() const { return Vec3(-slope_x, -slope_y, 1.0).normalized(); }
};

enum class BoxKind : std::uint8_t { kBuilding, kWall, kCurb, kCar };

/// Upright box rotated about z (buildings, walls, curbs, cars).
struct Box {
  Vec3 center_m = Vec3::Zero();
  double yaw_rad = 0.0;
  Vec3 half_m = Vec3::Ones();
  float reflectivity = 0.4f;
  BoxKind kind = BoxKind::kBuilding;  ///< what it stands for (tests pick surfaces by it)
};
struct Cylinder {  ///< vertical (poles, trunks)
  Vec2 center_m = Vec2::Zero();
  double z0_m = 0.0, z1_m = 1.0, radius_m = 0.1;
  float reflectivity = 0.4f;
};
struct Sphere {  ///< foliage blobs
  Vec3 center_m = Vec3::Zero();
  double radius_m = 0.5;
  float reflectivity = 0.3f;
};
/// A painted rectangle on the ground (high intensity, no geometry).
struct Marking {
  Vec2 center_m = Vec2::Zero();
  double yaw_rad = 0.0, half_length_m = 1.5, half_width_m = 0.075;
};

struct RayHit {
  double range_m = 0.0;
  Vec3 normal = Vec3::UnitZ();  ///< unit, world frame
  float reflectivity = 0.0f;
};

struct Scene {
  GroundPlane ground;
  std::vector<Box> boxes;
  std::vector<Cylinder> cylinders;
  std::vector<Sphere> spheres;
  std::vector<Marking> markings;

  /// Builds the BVH and the marking grid; call after filling the primitives.
  void finalize();
  /// First hit along origin + s * dir (dir unit) with s in (0, max_range_m]. Thread-safe.
  std::optional<RayHit> cast(const Vec3& origin, const Vec3& dir, double max_range_m) const;
  bool on_marking(double x, double y) const;
  std::size_t primitive_count() const { return boxes.size() + cylinders.size() + spheres.size(); }

  // Acceleration structures (filled by finalize()).
  struct Node {
    Eigen::Vector3f lo, hi;
    std::uint32_t first_or_right = 0;  ///< leaf: first ref; inner: right child (left = this + 1)
    std::uint32_t count = 0;           ///< 0 for an inner node
  };
  struct PrimRef {
    std::uint32_t kind : 2;
    std::uint32_t index : 30;
  };
  std::vector<Node> nodes;
  std::vector<PrimRef> refs;
  Vec2 marking_grid_origin_m = Vec2::Zero();
  double marking_cell_m = 2.0;
  int marking_nx = 0, marking_ny = 0;
  std::vector<std::vector<std::uint32_t>> marking_cells;
};

/// One ray (dir unit) against one primitive: the entry distance in (1e-6, t_max] and the outward
/// unit normal there. A ray starting inside a box does not hit it (a sensor never sits inside
/// geometry); cylinders have no caps.
bool hit_box(const Box& box, const Vec3& origin, const Vec3& dir, double t_max, double& t_out, Vec3& n_out);
bool hit_cylinder(const Cylinder& cylinder, const Vec3& origin, const Vec3& dir, double t_max, double& t_out, Vec3& n_out);

/// A seeded scene around the driven path (world xy samples): nothing closer to the path than the
/// corridor half-width, buildings not axis-aligned, clutter and markings. Scene kind per config.
/// density: how many times the usual number of objects (a long path: proportional to its length).
Scene make_scene(SceneKind kind, std::uint64_t seed, const std::vector<Vec2>& path_xy, const GroundPlane& ground,
                 double density = 1.0);

}  // namespace insalign::sim
