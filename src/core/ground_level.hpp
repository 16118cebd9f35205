// Global initialisation, step 1: levelling. The dominant ground plane below the LiDAR in several
// frames, against the INS vertical of the same frames, gives the LiDAR's roll and pitch
// relative to the INS, and the LiDAR's height above the ground.
#pragma once

#include <string>
#include <vector>

#include "core/geometry.hpp"
#include "core/sweep.hpp"

namespace insalign {

struct GroundConfig {
  int level_frames = 8;              ///< frames (spread over the drive) whose ground planes are averaged
  double inlier_m = 0.08;            ///< plane distance of a ground inlier
  int ransac_iterations = 200;
  /// Ground normal candidates farther than this from the LiDAR's z are rejected; 180: any mount
  /// (upside down, rolled onto its side), the ground told from walls by staying put across frames.
  double max_tilt_deg = 180.0;
  int candidates = 3;                ///< planes tried as the ground per frame (the largest first)
  double clearance_m = 0.4;          ///< points this close to the ground are left out of crispness scores
};

template <class V>
void visit_config(V& v, GroundConfig& c) {
  v("level_frames", c.level_frames, "frames (spread over the drive) for the ground plane");
  v("inlier_m", c.inlier_m, "RANSAC ground-plane inlier distance, m");
  v("ransac_iterations", c.ransac_iterations, "RANSAC iterations for the ground plane");
  v("max_tilt_deg", c.max_tilt_deg, "ground normals farther than this from LiDAR z are rejected (180: any mount), deg");
  v("candidates", c.candidates, "planes tried as the ground per frame, largest first");
  v("clearance_m", c.clearance_m, "points this close to the ground plane are left out of scores, m");
}

struct GroundPlane {
  Vec3 normal_lidar = Vec3::UnitZ();  ///< unit, pointing up (towards the sensor)
  double height_m = 0.0;              ///< sensor origin above the plane
  int inliers = 0;
  bool valid = false;
};

/// The largest planes 0.3-6 m from the sensor within 25 m of it (RANSAC, each refitted by least
/// squares, then its points taken away), normals towards the sensor and within max_tilt_deg of
/// its z: up to config.candidates, largest first. Deterministic for a given seed.
std::vector<GroundPlane> ground_candidates(const std::vector<Vec3>& p_lidar, const GroundConfig& config,
                                           unsigned seed = 1);
/// The largest of them.
GroundPlane fit_ground_plane(const std::vector<Vec3>& p_lidar, const GroundConfig& config, unsigned seed = 1);

/// R_lev_lidar with R_lev_lidar * normal_lidar = z: the smallest such rotation (no yaw added).
Mat3 levelling_rotation(const Vec3& normal_lidar);

/// A frame the initialisation works on: thinned sweep, its pose, its ground.
struct InitFrame {
  std::size_t index = 0;                 ///< into the dataset's frames
  Sweep sweep;                           ///< thinned, raw (not deskewed) LiDAR points
  Iso3 T_world_ins = Iso3::Identity();   ///< at the frame time
  GroundPlane ground;                    ///< chosen by level_lidar among the candidates
  std::vector<GroundPlane> ground_candidates;
  std::vector<char> off_ground;          ///< per point: farther than the clearance from the ground
};

struct Levelling {
  bool ok = false;
  std::string message;                   ///< why not
  Mat3 R_lev_lidar = Mat3::Identity();   ///< levels the LiDAR: the ground normal to z
  /// The INS may itself sit tilted on the vehicle: the levelled INS frame insl has z along the
  /// mean vertical seen in the INS frame.
  Mat3 R_ins_insl = Mat3::Identity();
  Vec3 normal_lidar = Vec3::UnitZ();     ///< mean ground normal in the LiDAR frame
  double lidar_height_m = 0.0;           ///< LiDAR origin above the ground
  double normal_spread_deg = 0.0;        ///< RMS angle of the per-frame normals about the mean
  int planes_used = 0;
};

/// The extrinsic from a levelled pose: T_ins_lidar = T_ins_insl * [Rz(yaw), (t_xy, tz)] * R_lev_lidar,
/// with yaw, t_xy and tz in the levelled INS frame.
Iso3 T_ins_lidar_levelled(const Levelling& level, double yaw_rad, const Eigen::Vector2d& t_xy_insl_m, double tz_insl_m);

/// Picks the ground among the frames' candidates (the plane whose normal and height in the LiDAR
/// frame most frames share: a wall turns with the car, the ground does not), averages the frames'
/// ground normals (those within 3 deg of the component-wise median; other frames lose their
/// `ground.valid`) and marks every frame's off-ground points.
Levelling level_lidar(const std::vector<InitFrame*>& frames, const GroundConfig& config);

}  // namespace insalign
