// Several LiDARs on one vehicle: the --rig specification and the mount presets, placed where such
// sensors sit on real cars and randomised per seed.
#pragma once

#include <string>
#include <vector>

#include "core/geometry.hpp"
#include "sim/random.hpp"
#include "sim/scene.hpp"

namespace insalign::sim {

/// The ego vehicle's body (vehicle frame: x forward from the INS, which sits near the rear axle;
/// heights above the ground): movers keep clear of it, mounts sit outside or above it, and in a
/// rig it blocks rays (it returns no points: real pipelines crop the car body anyway).
struct EgoBody {
  static constexpr double kRearM = -1.1, kFrontM = 3.6, kHalfWidthM = 0.95, kBottomM = 0.2, kTopM = 1.55;
  /// As a box in the vehicle frame, for an INS ins_height_m above the ground.
  static Box box(double ins_height_m);
};

/// One entry of "name:model[@mount][/rate_hz]".
struct RigLidarSpec {
  std::string name;           ///< folder name: letters, digits, '-', '_'
  std::string model;          ///< lidar_model() name
  std::string mount = "roof"; ///< mount_presets()
  double frame_rate_hz = 0.0; ///< 0: SimConfig::frame_rate_hz
};

/// "top:pandar64,left:vlp16@left,right:vlp16@right,front:os1-64@front/20". Throws
/// std::invalid_argument naming the bad entry (unknown mount, duplicate name, bad rate...).
std::vector<RigLidarSpec> parse_rig(const std::string& spec);

/// roof (centre, any yaw, roll/pitch within 10 deg: the single-LiDAR default), left / right (a
/// mirror 1.0-1.2 m high, or in 30 % of draws a roof edge 1.7-1.95 m high; yawed outward 45-90 deg,
/// tilted down 10-25 deg: from a mirror mostly ground and its own side, from a roof edge also the
/// far side over the roof), front (bumper, 0.45-0.6 m
/// high, tilted down 2-8 deg), rear (the same at the back, facing backwards), roof-front (front
/// edge of the roof facing forward, tilted down 3-10 deg: where solid-state LiDARs go).
std::vector<std::string> mount_presets();

/// A random mount of the preset in the vehicle frame (x forward, y left, z up, origin at the INS,
/// which is ins_height_m above the ground and near the rear axle).
Iso3 random_vehicle_mount(const std::string& preset, Rng& rng, double ins_height_m);

}  // namespace insalign::sim
