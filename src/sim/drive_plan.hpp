// Ordinary drives for the simulator: the streets a fleet car drives anyway (a city block, a street
// grid with turns both ways, a highway, a parking lot), as a path of straights and circular
// arcs, and a speed profile over it that accelerates, brakes for curves, and stops at lights.
#pragma once

#include <vector>

#include "core/geometry.hpp"
#include "sim/random.hpp"
#include "sim/scene.hpp"
#include "sim/simulate.hpp"

namespace insalign::sim {

/// A path sample every step_m of arc length: position, heading of travel, signed curvature (1/m,
/// positive = left).
struct PathPoint {
  double x = 0.0, y = 0.0, heading_rad = 0.0, curvature_per_m = 0.0;
};

/// The corners of a closed polygon (or an open polyline) rounded by circular arcs of radius_m,
/// sampled every step_m.
std::vector<PathPoint> rounded_polyline(const std::vector<Vec2>& corners, double radius_m, bool closed, double step_m);

/// One ordinary drive: its path (one loop; closed paths repeat) and how it is driven.
struct DrivePlan {
  std::vector<PathPoint> loop;  ///< one loop, every step_m
  bool closed = true;
  double cruise_mps = 8.0;
  double lateral_accel_mps2 = 2.0;  ///< curves are taken at most this fast
  double accel_mps2 = 1.2, decel_mps2 = 1.8;
  double stop_probability = 0.4;    ///< per corner: a light (red) before it
  double min_stop_s = 4.0, max_stop_s = 25.0;
};

/// The plan of an ordinary TrajectoryKind (kCityLoop, kUrbanGrid, kHighway, kParkingLot), at
/// cruise_kmh (0: the kind's own speed), long enough for duration_s. Throws std::invalid_argument
/// for another kind.
DrivePlan ordinary_plan(TrajectoryKind kind, double cruise_kmh, double duration_s, double step_m);

/// The speed profile on a grid of arc length (a stop holds two samples at one arc length, its
/// dwell apart): from standstill, for at least duration_s; stops before corners drawn with rng.
struct SpeedProfile {
  std::vector<double> t_s, s_m, v_mps, a_mps2;
  /// Arc length at tau_s (clamped to the profile), with the speed and longitudinal acceleration.
  double s_at(double tau_s, double& v_mps, double& a_mps2) const;
  double duration_s() const { return t_s.empty() ? 0.0 : t_s.back(); }
};
SpeedProfile plan_speed(const DrivePlan& plan, double duration_s, double step_m, Rng& rng);

}  // namespace insalign::sim
