// Global initialisation of the extrinsic: an estimate of T_ins_lidar good enough for stage 1, from the
// data alone (no initial guess), or a check of a user's guess against the data.
//
// Method (assumes only that the pose file's world z is up):
//  1. Levelling: the dominant ground plane below the LiDAR (RANSAC) in several frames against the INS
//     vertical gives the LiDAR's roll and pitch w.r.t. the INS.
//  2. Coarse yaw: map crispness (occupied voxels of a few stitched frames) for yaw candidates over
//     360 deg, on frames of a nearly straight stretch where the unknown lever arm does not matter.
//  3. Planar hand-eye: LiDAR scan-to-scan motions (point-to-plane ICP, started from the INS motion
//     through the coarse extrinsic) against INS motions; R_A t_X + t_A = R_X t_B + t_X is linear in
//     (cos yaw, sin yaw, tx, ty); robust least squares over many pairs.
//  4. z is unobservable from planar motion: from fiducials (ground height) if any, else a typical mount.
//  5. Given an init: score it against the data's candidate by map crispness over frames spread across
//     the drive; the data overrides the init only when clearly better in another basin.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/dataset.hpp"
#include "core/geometry.hpp"
#include "core/scan_registration.hpp"

namespace insalign {

struct GlobalInitConfig {
  // Frames and points.
  double min_range_m = 2.5;            ///< nearer points are the car body
  double max_range_m = 60.0;           ///< farther points are sparse and noisy
  double voxel_m = 0.3;                ///< downsampling voxel of every loaded frame
  int level_frames = 8;                ///< frames (spread over the drive) for the ground plane
  // Ground plane (RANSAC on points below the sensor).
  double ground_inlier_m = 0.08;       ///< plane distance of a ground inlier
  int ground_ransac_iterations = 200;
  double max_tilt_deg = 30.0;          ///< ground normal candidates farther than this from LiDAR z are rejected
  // Coarse yaw by crispness.
  double coarse_yaw_step_deg = 5.0;    ///< yaw candidates over 360 deg
  int coarse_frames = 9;               ///< frames of the straight stretch
  double coarse_stretch_m = 16.0;      ///< length of that stretch (metres travelled)
  double crispness_voxel_m = 0.5;      ///< voxel of the occupancy count
  double ground_clearance_m = 0.4;     ///< points this close to the ground plane are left out of scores
  // Hand-eye.
  int hand_eye_pairs = 24;             ///< frame pairs registered
  double pair_dt_s = 0.5;              ///< time between the frames of a pair
  double min_pair_turn_deg = 4.0;      ///< pairs turning less only constrain yaw (some are kept)
  double max_angle_mismatch_deg = 1.5; ///< |INS turn - LiDAR turn| above this: pair rejected
  double max_residual_m = 0.15;        ///< pairs with larger hand-eye residual are dropped, re-solved
  double icp_target_voxel_m = 0.4;     ///< registration target (first frame of a pair) voxel
  double icp_source_voxel_m = 0.8;     ///< registration source (second frame) voxel: few points suffice
  double coarse_voxel_m = 0.6;         ///< points of the coarse yaw search are thinned to this voxel
  ScanRegistrationConfig icp = {.max_iterations = 20};  ///< scan-to-scan registration
  // z (unobservable from planar motion).
  /// INS origin height above the ground when there are no fiducials: an INS in the trunk or cabin
  /// of a car sits about 1 m up (the NovAtel sample: trunk); stage 3 fixes z from fiducials.
  double ins_height_guess_m = 1.0;
  // Checking an init.
  int score_frames = 16;               ///< frames spread over the drive for the final scores
  /// The data overrides the init when the init's score (occupied voxels) exceeds the data
  /// candidate's by this factor and the two lie in different basins.
  double override_score_ratio = 1.05;
  double same_basin_rot_deg = 30.0;    ///< closer candidates share stage 1's basin (~20 deg, with margin)...
  double same_basin_trans_m = 1.0;     ///< ...if also this close in translation
  bool trust_init = false;             ///< true: return the init unchanged, no checks
};

struct InitCandidate {
  Iso3 T_ins_lidar = Iso3::Identity();
  double score = 0.0;   ///< occupied voxels of the stitched frames (lower is crisper)
  std::string label;    ///< "data", "init", "init-yaw+180", ...
};

struct GlobalInitResult {
  Iso3 T_ins_lidar = Iso3::Identity();  ///< the chosen start for stage 1
  std::string source;                   ///< "data" (no init given), "init" (confirmed or trusted), "data-overrides-init"
  std::string explanation;              ///< why: the scores
  std::vector<InitCandidate> candidates;
  double wall_time_s = 0.0;
  // Diagnostics.
  Vec3 ground_normal_lidar = Vec3::UnitZ();  ///< mean ground normal in the LiDAR frame
  double lidar_height_m = 0.0;               ///< LiDAR origin above the ground plane
  double ground_normal_spread_deg = 0.0;     ///< RMS angle of per-frame normals about the mean
  double coarse_yaw_deg = 0.0;               ///< best yaw of the crispness search
  int hand_eye_pairs_used = 0;
  bool lever_arm_observed = false;           ///< false: no turns, t_xy is a guess (zero)
  double hand_eye_rms_m = 0.0;
  int frames_loaded = 0;
  double load_s = 0.0, coarse_s = 0.0, hand_eye_s = 0.0, score_s = 0.0;  ///< wall time per phase
};

/// Throws UnobservableError when the data cannot give a start (no ground plane, no motion) and there
/// is no init; with an init the data cannot check, returns the init (source "init") and says why.
GlobalInitResult initialise_extrinsic(const Dataset& data, const std::optional<Iso3>& T_ins_lidar_init,
                                      const GlobalInitConfig& config = {});

// Pieces, exposed for tests.

struct GroundPlane {
  Vec3 normal = Vec3::UnitZ();  ///< unit, pointing up (towards the sensor)
  double height_m = 0.0;        ///< sensor origin above the plane
  int inliers = 0;
  bool valid = false;
};
/// Dominant plane below the sensor (RANSAC then least-squares refit), normal within max_tilt_deg of
/// the sensor's z. Deterministic for a given seed.
GroundPlane fit_ground_plane(const std::vector<Vec3>& p_lidar, const GlobalInitConfig& config,
                             unsigned seed = 1);

/// Rotation R_level with R_level * normal_lidar = z, the smallest such rotation (no yaw added).
Mat3 levelling_rotation(const Vec3& normal_lidar);

/// A relative motion pair for planar hand-eye: A in the INS frame, B in the levelled LiDAR frame.
struct MotionPair {
  Iso3 T_ins0_ins1 = Iso3::Identity();
  Iso3 T_lev0_lev1 = Iso3::Identity();
};
struct PlanarHandEyeResult {
  double yaw_rad = 0.0;  ///< R_ins_lev = Rz(yaw)
  Eigen::Vector2d t_xy_m = Eigen::Vector2d::Zero();
  std::vector<bool> inlier;
  double rms_m = 0.0;
  bool valid = false;    ///< false: too few usable pairs
  bool lever_arm_observed = false;  ///< false: no turns among the inliers, t_xy left at zero
};
/// Solve (R_A - I) t_X + t_A = Rz(yaw) t_B in x, y by linear least squares in (tx, ty, cos, sin),
/// with t_X's z fixed to tz_m; drops pairs whose turn angles disagree or whose residual is large.
PlanarHandEyeResult solve_planar_hand_eye(const std::vector<MotionPair>& pairs, double tz_m,
                                          const GlobalInitConfig& config = {});

/// Occupied voxels of the points (fewer = crisper map).
double occupancy_score(const std::vector<Vec3>& p_world, double voxel_m);

}  // namespace insalign
