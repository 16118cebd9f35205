// Several LiDARs to one INS in one run (a rig): the INS's bad stretches left out of every LiDAR
// (its status before any stage, the reference LiDAR's checks after stage 1) and each LiDAR's
// points on moving things masked, as for one LiDAR; each LiDAR its own start and stage 1, then one
// joint stage 2 over the LiDARs whose maps overlap (all their points in one map, each through its
// own extrinsic and time offset, so a sparse side LiDAR is tied to the dense roof map), stage 3 per
// LiDAR, per-DOF verdicts per LiDAR and the LiDAR-to-LiDAR transforms with their uncertainty.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "core/frame_store.hpp"
#include "core/pipeline.hpp"

namespace insalign {

/// A LiDAR's stage 1 checked against the reference LiDAR's map (JointConfig::map_check).
struct RigMapCheck {
  std::string reference;  ///< the LiDAR whose map it was registered to; empty: not checked
  bool converged = false;  ///< the registration found enough of the map (false: they share too little)
  Iso3 T_ins_lidar_map = Iso3::Identity();  ///< the extrinsic that fits the map best (its tz: stage 1's)
  double moved_rot_deg = 0.0;  ///< the map's extrinsic against stage 1's: rotation...
  double moved_xy_m = 0.0;     ///< ...and x, y
  /// The sweeps' point-to-plane RMS on the map at stage 1's extrinsic / the map's, each at the
  /// map's tz (tz is stage 3's to find)...
  double rms_before_m = 0.0, rms_after_m = 0.0;
  double rms_restarted_m = 0.0;  ///< ...and at stage 1 run again from the map's (0: not run)
  bool restarted = false;      ///< stage 1 was run again from the map's extrinsic and that was kept
  bool map_start = false;      ///< stage 1 (not determined alone) went back: stage 2 starts from the map's
};

/// What the rig run adds to one LiDAR's CalibrationResult.
struct RigLidar {
  std::string name;
  CalibrationResult result;        ///< as run_calibration returns it (refine: its part of the joint stage 2)
  std::size_t group = 0;           ///< LiDARs with the same group were refined in one map
  std::vector<std::string> joint_with;  ///< the other LiDARs of its group (empty: refined alone)
  std::string joint_note;          ///< "refined jointly with ..." or "overlaps no other LiDAR: refined alone"
  RigMapCheck map_check;
  /// The LiDAR whose checks after stage 1 found the INS spans left out of every LiDAR (the one
  /// whose stage 1 found the most planes; empty: ins_screen.from_lidar off). result.ins_screen
  /// holds its checks.
  std::string ins_checks_by;
  /// The LiDAR whose rays gave the rig's one evidence of moving things (MovingPointsConfig::
  /// rig_shared; empty: its own mask, or none).
  std::string moving_space_by;
  /// Per DOF: determined by stage 1 alone (what a single-LiDAR run would say), and by the rig.
  std::array<bool, 6> determined_alone{};
  /// Stage 2's formal stddev (m, rad), marginal of the joint covariance (before any widening).
  Vec6 formal_stddev = Vec6::Constant(std::numeric_limits<double>::infinity());
  /// Joint with relative tz (JointConfig::relative_tz): the member whose tz stayed fixed in stage
  /// 2 (itself for the anchor; empty when refined alone or tz was held per LiDAR) and stage 2's
  /// stddev of this LiDAR's tz relative to it (m; 0 for the anchor): the formal one, at least
  /// 1.5 mm (rig.cpp), widened by the joint segments' spread.
  std::string tz_anchor;
  double tz_relative_stddev_m = std::numeric_limits<double>::infinity();
  /// Shared stage 3 replaced this LiDAR's tz: what its own stage 3 gave (NaN otherwise).
  double own_stage3_tz_m = std::numeric_limits<double>::quiet_NaN();
  bool tz_from_anchor = false;  ///< tz = the joint height relative to the anchor + the rig's stage-3 change (median)
};

/// T_a_b = T_ins_a^-1 T_ins_b (maps LiDAR b's coordinates into LiDAR a's) with its uncertainty.
struct LidarPair {
  std::size_t a = 0, b = 0;
  Iso3 T_a_b = Iso3::Identity();
  /// 1-sigma [tx ty tz (m, in frame a), rotation about a's x y z (rad)]: the LiDARs' final
  /// stddevs with the joint stage 2's correlations (independent across groups); +inf where a
  /// DOF of either LiDAR is not determined.
  Vec6 stddev = Vec6::Constant(std::numeric_limits<double>::infinity());
  Mat6 covariance = Mat6::Zero();  ///< of that 6-vector (rotation as R' = exp(phi) R_a_b)
};

struct RigResult {
  std::vector<RigLidar> lidars;
  /// overlap[a][b]: occupied voxels (config.refine.joint) shared by a's and b's stage-1 maps over
  /// the smaller map's count.
  std::vector<std::vector<double>> overlap;
  std::vector<std::size_t> map_voxels;  ///< per LiDAR: occupied voxels of its stage-1 map (that measure)
  std::vector<LidarPair> pairs;    ///< every a < b
  std::vector<std::string> warnings;
  double joint_wall_time_s = 0.0;  ///< stage 2 over all groups
  double wall_time_s = 0.0;
};

/// Work on LiDAR `lidar` that needs its final extrinsic but no stddev (its report's pictures): run
/// once per LiDAR beside the repeatability study (its own, or its joint group's).
using RigBeside = std::function<void(std::size_t lidar, const CalibrationResult& r)>;

/// Calibrates every LiDAR of the rig (stores[i] named names[i], each with its own poses, clock
/// and initial guess). Throws UnobservableError naming the LiDAR when one cannot be determined
/// even jointly (tz alone is reported, not thrown, as for one LiDAR), InputError on mismatched
/// arguments. progress gets "<name>: <step>" for the per-LiDAR steps and "joint" for stage 2.
RigResult run_rig_calibration(const std::vector<FrameStore>& stores, const std::vector<std::string>& names,
                              const PipelineConfig& config, const PipelineProgress& progress = {},
                              const RigBeside& beside = {});

/// The overlap measure of JointConfig between the maps of two LiDARs (stitched, world frame).
double map_overlap(const std::vector<Vec3f>& a_world, const std::vector<Vec3f>& b_world, double voxel_m);

/// T_a_b and its covariance from both extrinsics and the 12x12 covariance of their INS-frame
/// perturbations [dt_a, w_a, dt_b, w_b] (the parameterisation of refine.hpp).
LidarPair lidar_pair(const Iso3& T_ins_a, const Iso3& T_ins_b, const Eigen::Matrix<double, 12, 12>& covariance);

}  // namespace insalign
