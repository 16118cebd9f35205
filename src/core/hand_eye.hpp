// Global initialisation, step 3: planar hand-eye calibration. LiDAR scan-to-scan motions
// (point-to-plane ICP, started from the INS motion through the coarse extrinsic) against the INS
// motions of the same frame pairs: R_ins0_ins1 t + t_ins0_ins1 = Rz(yaw) t_lev0_lev1 + t, linear
// in (tx, ty, cos yaw, sin yaw), solved robustly over many pairs.
#pragma once

#include <cstddef>
#include <utility>
#include <vector>

#include "core/frames.hpp"
#include "core/ground_level.hpp"
#include "core/pose_stream.hpp"
#include "core/scan_registration.hpp"

namespace insalign {

struct HandEyeConfig {
  int pairs = 24;                      ///< frame pairs registered (2/3 sharp turns, the rest long straights)
  double pair_dt_s = 0.5;              ///< time between the frames of a pair
  double min_pair_turn_deg = 4.0;      ///< pairs turning less only constrain yaw
  double max_angle_mismatch_deg = 1.5; ///< |INS turn - LiDAR turn| above this: pair rejected
  double max_residual_m = 0.15;        ///< pairs with a larger residual are dropped, then re-solved
  double target_voxel_m = 0.4;         ///< registration target (first frame of a pair) voxel
  double source_voxel_m = 0.8;         ///< registration source (second frame) voxel: few points suffice
  ScanRegistrationConfig icp = {.max_iterations = 20};
};

template <class V>
void visit_config(V& v, ScanRegistrationConfig& c) {
  v("max_iterations", c.max_iterations, "Gauss-Newton iterations");
  v("max_corr_dist_start_m", c.max_corr_dist_start_m, "correspondence gate at the start, m");
  v("max_corr_dist_end_m", c.max_corr_dist_end_m, "the gate shrinks to this, m");
  v("normal_neighbours", c.normal_neighbours, "neighbours for a target normal");
  v("max_plane_thickness_m", c.max_plane_thickness_m, "thicker neighbourhoods get no normal, m");
  v("huber_delta_m", c.huber_delta_m, "robust kernel scale, m");
  v("converged_step_m", c.converged_step_m, "stop when the update is below this (m and rad)");
  v("min_inliers", c.min_inliers, "fewer correspondences means not converged");
}
template <class V>
void visit_config(V& v, HandEyeConfig& c) {
  v("pairs", c.pairs, "frame pairs registered");
  v("pair_dt_s", c.pair_dt_s, "time between the frames of a pair, s");
  v("min_pair_turn_deg", c.min_pair_turn_deg, "pairs turning less only constrain yaw, deg");
  v("max_angle_mismatch_deg", c.max_angle_mismatch_deg, "|INS turn - LiDAR turn| above this rejects a pair, deg");
  v("max_residual_m", c.max_residual_m, "pairs with a larger residual are dropped, m");
  v("target_voxel_m", c.target_voxel_m, "registration target voxel, m");
  v("source_voxel_m", c.source_voxel_m, "registration source voxel, m");
  v.section("icp", c.icp);
}

/// Positions (into `frames`) of the pairs to register: the sharpest turns first, then the
/// longest straight motions (yaw), never overlapping; frames pair_dt_s apart (period_s per frame).
std::vector<std::pair<std::size_t, std::size_t>> hand_eye_pairs(const DriveFrames& frames, double period_s,
                                                                const HandEyeConfig& config);

/// One relative motion: the INS's in the levelled INS frame, the LiDAR's in the levelled LiDAR frame.
struct MotionPair {
  Iso3 T_insl0_insl1 = Iso3::Identity();
  Iso3 T_lev0_lev1 = Iso3::Identity();
  double t0_s = 0.0, t1_s = 0.0;  ///< the two sweeps' times, LiDAR clock
};

/// Each pair's INS motion between its sweeps' times shifted by time_offset_s (t_ins = t_lidar +
/// offset), in the levelled INS frame.
void set_ins_motions(std::vector<MotionPair>& pairs, const PoseStream& poses, const Levelling& level,
                     double time_offset_s);

/// Registers each pair (frames deskewed with T_ins_lidar_coarse, ICP started from the INS motion
/// through it) and returns the converged ones in the levelled frames.
std::vector<MotionPair> register_pairs(const std::vector<std::pair<const InitFrame*, const InitFrame*>>& pairs,
                                       const PoseStream& poses, const Iso3& T_ins_lidar_coarse,
                                       const Levelling& level, const HandEyeConfig& config);

struct PlanarHandEyeResult {
  double yaw_rad = 0.0;              ///< R_insl_lev = Rz(yaw)
  Eigen::Vector2d t_xy_m = Eigen::Vector2d::Zero();  ///< LiDAR origin in the levelled INS frame
  std::vector<bool> inlier;
  double rms_m = 0.0;
  bool valid = false;                ///< false: too few usable pairs
  bool lever_arm_observed = false;   ///< false: no turns among the inliers, t_xy left at zero
};
/// Least squares in (tx, ty, cos, sin) with the LiDAR height tz_m fixed; drops pairs whose turn
/// angles disagree or whose residual is large.
PlanarHandEyeResult solve_planar_hand_eye(const std::vector<MotionPair>& pairs, double tz_m,
                                          const HandEyeConfig& config = {});

}  // namespace insalign
