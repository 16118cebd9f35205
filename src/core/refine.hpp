// Stage 2, refinement: deskew every sweep through the INS poses at each point's own time, stitch
// frames from the whole drive into one map and move the extrinsic (and the LiDAR-to-INS time
// offset) until that map is as crisp as possible.
#pragma once

#include <cstddef>
#include <array>
#include <functional>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "core/frame_store.hpp"
#include "core/geometry.hpp"
#include "core/map_registration.hpp"
#include "core/occupancy.hpp"
#include "core/stage.hpp"

namespace insalign {

enum class RefineMethod {
  /// The paper (after Levinson & Thrun): number of occupied voxels of the stitched map,
  /// minimised by a coordinate-wise grid search with shrinking steps.
  kOccupancyGrid,
  /// Plane thickness of the stitched map (point-to-plane on fine local planes, re-fitted every
  /// iteration, i.e. the smallest-eigenvalue cost of BALM) minimised by Gauss-Newton over the
  /// extrinsic and the time offset (through the pose velocity). Smooth, so it converges to a
  /// far finer optimum than a quantised voxel count.
  kContinuous,
};

inline constexpr std::array<std::pair<RefineMethod, std::string_view>, 2> kRefineMethodNames{
    {{RefineMethod::kContinuous, "continuous"}, {RefineMethod::kOccupancyGrid, "occupancy-grid"}}};
constexpr auto enum_names(RefineMethod) { return std::span(kRefineMethodNames); }

/// A rig's joint stage 2 (rig.hpp): which LiDARs share one map, by the overlap of their stitched
/// maps (shared occupied voxels over the smaller map's).
struct JointConfig {
  bool enabled = true;              ///< false: every LiDAR of a rig refined alone
  double overlap_voxel_m = 0.5;     ///< voxel edge of the overlap count, metres
  double min_overlap = 0.05;        ///< shared fraction that ties two LiDARs; below, they do not overlap
  std::size_t overlap_frames = 40;  ///< frames per LiDAR stitched to measure the overlap
  /// Stage 2 keeps one anchor's tz (the LiDAR whose stage 1 found the most planes) and moves the
  /// other members' tz: their heights relative to it are seen on the shared ground, and a side
  /// LiDAR held at its own fiducial tz (a few mm off the roof's ground) tilts to meet it instead.
  bool relative_tz = true;
  /// The stated stddev of a member's tz relative to the anchor is at least this, m. The formal one
  /// (points taken as independent) said 0.2-0.4 mm where the error was 2-3.5 mm (a side VLP-16 in
  /// bench/rig_accuracy, reduced runs); 12 members' relative errors over 4 drives had an RMS of
  /// 1.5 mm, and the segments' spread does not see such a bias.
  double relative_tz_min_sigma_m = 0.0015;
  /// Stage 3 afterwards: the median of the members' own corrections moves every member alike
  /// (keeping the heights stage 2 found between them); false: each LiDAR's own stage 3.
  bool shared_stage3 = true;
  /// Points per sweep at most that a member other than the anchor gives stage 2 (the anchor keeps
  /// RefineConfig::filter's). The anchor, the LiDAR with the most stage-1 planes, holds most of
  /// the shared map's planes; another member's points pin its own seven parameters to them, and
  /// stage 2's cost grows with the group's points. A dense second LiDAR at 5000 instead of 10000
  /// (bench/rig_accuracy, the OS1-64 in front) keeps its errors within the same bounds.
  std::size_t member_max_points = 5000;
  MapCheckConfig map_check;  ///< each LiDAR's stage 1 checked against the best one's map
  /// A group with a LiDAR stage 1 could not determine alone: at most this many unchecked joint
  /// passes (until one moves nothing) before the checked one.
  int weak_passes = 3;
};

template <class V>
void visit_config(V& v, JointConfig& c) {
  v("enabled", c.enabled, "rig: refine the overlapping LiDARs in one map (false: each alone)");
  v("overlap_voxel_m", c.overlap_voxel_m, "rig: voxel edge of the overlap count, m");
  v("min_overlap", c.min_overlap, "rig: shared occupied voxels / the smaller map's that tie two LiDARs");
  v("overlap_frames", c.overlap_frames, "rig: frames per LiDAR stitched to measure the overlap");
  v("relative_tz", c.relative_tz, "rig: stage 2 moves every member's tz but the anchor's (heights from the shared ground)");
  v("relative_tz_min_sigma_m", c.relative_tz_min_sigma_m, "rig: floor of a member's stated tz stddev relative to the anchor, m");
  v("shared_stage3", c.shared_stage3, "rig: the median of the members' stage-3 tz corrections moves every member alike (false: each its own)");
  v("member_max_points", c.member_max_points, "rig: points per sweep at most in stage 2 for a member other than the anchor (0: refine.filter's)");
  v("weak_passes", c.weak_passes, "rig: unchecked joint passes at most, before the checked one, when a LiDAR was not determined alone");
  v.section("map_check", c.map_check);
}

struct RefineConfig {
  RefineMethod method = RefineMethod::kContinuous;
  /// Frames spread evenly over the drive's motion measure (frames.hpp), at most one per
  /// min_motion_m of it: standstill adds nothing.
  std::size_t max_frames = 120;
  double min_motion_m = 0.3;
  /// ...and more than max_frames where they would lie farther apart than this (m of motion): the
  /// frames' near fields must overlap. 120 frames over a 4.5 km highway drive (37 m apart) left a
  /// front bumper LiDAR's pitch 0.069 deg off at a stated 0.017; 19 m apart it was 0.001.
  double max_spacing_m = 20.0;
  /// Per-frame thinning: one raw point (with its own time) per voxel in the LiDAR frame, then at
  /// most max_points (min_range_m 0: the vehicle's body radius).
  SweepFilter filter{.min_range_m = 0.0, .max_range_m = 80.0, .voxel_m = 0.15, .max_points = 10000};

  // Degrees of freedom.
  bool estimate_time_offset = true; ///< also estimate the LiDAR-to-INS time offset
  double time_offset_range_s = 0.05;  ///< offset searched within start +- this, seconds
  bool estimate_tz = false;         ///< INS-vertical translation: unobservable from planar driving,
                                    ///< stage 3 fixes it from fiducials; kept at its start value
  /// Stage 2 may move the horizontal lever arm by max speed x its time-offset change plus this
  /// (stage 1's accuracy bound); beyond, refine_checked runs it again with the offset fixed.
  double max_unexplained_shift_m = 0.03;

  // kOccupancyGrid: the paper's search.
  double occupancy_voxel_m = 0.1;   ///< voxel edge of the occupancy count, metres (with downsampled
                                    ///< frames a finer grid holds about one point per voxel and
                                    ///< counts points instead of surfaces)
  double grid_rot_range_deg = 0.5;  ///< first-round half range per rotation axis, degrees
  double grid_trans_range_m = 0.05; ///< first-round half range per translation axis, metres
  int grid_steps = 3;               ///< samples per side in a round (2*steps+1 per coordinate)
  int grid_rounds = 4;              ///< the range shrinks by grid_shrink after every round
  double grid_shrink = 0.4;         ///< range factor between rounds
  int grid_sweeps_per_round = 1;    ///< coordinate passes over all DOF within a round

  // kContinuous: plane thickness minimised by Gauss-Newton.
  double plane_voxel_m = 1.0;       ///< edge of the voxels fitted with local planes, metres
  double plane_voxel_min_m = 0.5;   ///< non-planar voxels are split once down to this edge
  int plane_min_points = 12;        ///< a local plane needs at least this many points
  double plane_max_planarity = 0.04;  ///< lambda_min / lambda_mid above this: not a plane
  double huber_m = 0.05;            ///< robust loss scale on point-to-plane distances, metres
  int max_iterations = 12;          ///< Gauss-Newton iterations at most
  int refit_iterations = 3;         ///< planes re-found from the map in the first iterations; after
                                    ///< that their point grouping is frozen (smooth cost) and only
                                    ///< their centroids and normals follow the points
  double converged_rot_deg = 1e-4;  ///< stop when an update is below both thresholds
  double converged_trans_m = 1e-5;
  /// The INS's own slow position error, for the stddev it leaves in the estimate: an
  /// RTK-fixed solution wanders by about its stated accuracy (NovAtel RTK: 1 cm horizontal, 1.5 cm
  /// vertical) over tens of seconds. Modelled as exponentially correlated; set your INS's figures.
  /// (Stage 3's z.ins_vertical_sigma_m is the INS's height error where the fiducials are seen.)
  double ins_slow_error_horizontal_m = 0.01;   ///< per horizontal axis, m
  double ins_slow_error_vertical_m = 0.015;    ///< m
  double ins_slow_error_correlation_s = 30.0;  ///< correlation time, s
  double time_offset_scan_step_s = 0.005;  ///< coarse occupancy scan of the offset before
                                           ///< Gauss-Newton, seconds (0: no scan)
  double time_offset_scan_voxel_m = 0.2;   ///< voxel edge of that scan's occupancy count
  JointConfig joint;                ///< rigs: the joint refinement of several LiDARs
  /// DOFs [tx ty tz roll pitch yaw] held at their start values whatever the map says, with no
  /// stddev: set by the pipeline for the DOFs its drive's stage 1 could not determine
  /// (PipelineConfig::hold_undetermined), not a file option.
  std::array<bool, 6> held{};
  /// Only the extrinsic and time offset are read (a repeatability segment): no share of the INS's
  /// correlated error and no occupancy counts, a tenth of a segment's time. Not a file option.
  bool extrinsic_only = false;
};

template <class V>
void visit_config(V& v, RefineConfig& c) {
  v("method", c.method, "crispness measure: continuous (plane thickness, Gauss-Newton) or occupancy-grid (the paper)");
  v("max_frames", c.max_frames, "frames spread over the drive's motion");
  v("min_motion_m", c.min_motion_m, "at most one frame per this much motion measure, m");
  v("max_spacing_m", c.max_spacing_m, "more frames than max_frames where they would lie farther apart than this, m of motion");
  v.section("filter", c.filter);
  v("estimate_time_offset", c.estimate_time_offset, "also estimate the LiDAR-to-INS time offset");
  v("time_offset_range_s", c.time_offset_range_s, "time offset searched within start +- this, s");
  v("estimate_tz", c.estimate_tz, "also move tz (unobservable from planar driving)");
  v("max_unexplained_shift_m", c.max_unexplained_shift_m,
    "x, y may move by max speed x the time-offset change plus this, else stage 2 reruns with the offset fixed, m");
  v("occupancy_voxel_m", c.occupancy_voxel_m, "occupancy_grid: voxel of the occupancy count, m");
  v("grid_rot_range_deg", c.grid_rot_range_deg, "occupancy_grid: first-round half range per rotation axis, deg");
  v("grid_trans_range_m", c.grid_trans_range_m, "occupancy_grid: first-round half range per translation axis, m");
  v("grid_steps", c.grid_steps, "occupancy_grid: samples per side in a round");
  v("grid_rounds", c.grid_rounds, "occupancy_grid: rounds, the range shrinking after each");
  v("grid_shrink", c.grid_shrink, "occupancy_grid: range factor between rounds");
  v("grid_sweeps_per_round", c.grid_sweeps_per_round, "occupancy_grid: coordinate passes over all DOF per round");
  v("plane_voxel_m", c.plane_voxel_m, "continuous: voxel fitted with a local plane, m");
  v("plane_voxel_min_m", c.plane_voxel_min_m, "continuous: non-planar voxels split once down to this, m");
  v("plane_min_points", c.plane_min_points, "continuous: a local plane needs at least this many points");
  v("plane_max_planarity", c.plane_max_planarity, "continuous: lambda_min / lambda_mid above this is not a plane");
  v("huber_m", c.huber_m, "continuous: robust loss scale on point-to-plane distances, m");
  v("max_iterations", c.max_iterations, "continuous: Gauss-Newton iterations");
  v("refit_iterations", c.refit_iterations, "continuous: iterations that re-find the planes before freezing them");
  v("converged_rot_deg", c.converged_rot_deg, "continuous: stop when the rotation update is below this, deg");
  v("converged_trans_m", c.converged_trans_m, "continuous: ...and the translation update below this, m");
  v("ins_slow_error_horizontal_m", c.ins_slow_error_horizontal_m, "INS slow position error per horizontal axis, for the stddev it leaves, m");
  v("ins_slow_error_vertical_m", c.ins_slow_error_vertical_m, "INS slow vertical position error, for the stddev it leaves, m");
  v("ins_slow_error_correlation_s", c.ins_slow_error_correlation_s, "correlation time of the INS slow position error, s");
  v("time_offset_scan_step_s", c.time_offset_scan_step_s, "coarse time-offset scan step before Gauss-Newton (0: none), s");
  v("time_offset_scan_voxel_m", c.time_offset_scan_voxel_m, "voxel of that scan's occupancy count, m");
  v.section("joint", c.joint);
}

/// One step of the search: after each grid round, or each Gauss-Newton iteration.
struct RefineRound {
  int round = 0;
  Iso3 T_ins_lidar = Iso3::Identity();
  double time_offset_s = 0.0;
  double cost = 0.0;                ///< the method's measure (see RefineResult::measure)
};

struct RefineResult {
  /// kUndetermined when too few frames move (message says how many); the estimate is the start.
  /// stddev: from the Gauss-Newton information (kContinuous; tz +inf), points treated as
  /// independent, so optimistic: the pipeline widens it with the repeatability spread.
  StageOutcome outcome;
  Iso3 T_ins_lidar = Iso3::Identity();
  double time_offset_s = 0.0;       ///< t_ins = t_lidar + time_offset_s
  std::string measure;              ///< name and unit of crispness_*, e.g. "occupied voxels (0.05 m)"
  double crispness_before = 0.0;    ///< the method's measure at the start (lower is crisper)
  double crispness_after = 0.0;     ///< ... and at the result
  std::size_t occupied_voxels_before = 0;  ///< the paper's occupancy count, for either method
  std::size_t occupied_voxels_after = 0;
  std::size_t frames_used = 0;
  std::size_t points_used = 0;      ///< after range filtering and downsampling, all frames
  std::size_t planes_used = 0;      ///< kContinuous: local planes in the last iteration
  int evaluations = 0;              ///< cost evaluations (map rebuilds)
  bool time_offset_estimated = false;
  bool converged = false;
  double time_offset_stddev_s = std::numeric_limits<double>::infinity();
  /// The stddev an INS position error of RefineConfig::ins_* sizes and correlation leaves in the
  /// estimate (0 where not estimated): what the INS gets wrong slowly is common to long stretches
  /// of the drive, so the repeatability segments cannot show it.
  Vec6 ins_position_stddev = Vec6::Zero();
  /// What an INS position error e_f (world frame) of the problem's frame f moves this estimate
  /// by, to first order: -ins_shift[f] * e_f, rows x y z roll pitch yaw (rad) and time offset
  /// (s), zero for DOFs not estimated; frame f at LiDAR time ins_shift_t_s[f]. Any error model's
  /// share follows from it (ins_position_stddev is one; random_walk_stddev another).
  std::vector<double> ins_shift_t_s;
  std::vector<Eigen::Matrix<double, 7, 3>> ins_shift;
  std::vector<RefineRound> rounds;
};

/// The stddev (x y z m, roll pitch yaw rad, time offset s) that an INS position random walk
/// leaves in r's estimate: per world axis, a walk whose RMS about its own mean over `span_s` is
/// rms_about_mean_m (a walk's variance about its mean averages q span / 6). Only what differs
/// between frames counts: a shift common to all moves nothing. All zero without ins_shift.
Eigen::Matrix<double, 7, 1> random_walk_stddev(const RefineResult& r, const Vec3& rms_about_mean_m, double span_s);

/// The local-plane parameters of kContinuous as the crispness measure's config.
PlaneThicknessConfig plane_thickness_config(const RefineConfig& config);

/// How far from the drive's ends stage 2's frames keep: its time-offset search shifts sweeps by up
/// to this, s (0 when the offset is not estimated).
inline double refine_margin_s(const RefineConfig& config) {
  return config.estimate_time_offset ? config.time_offset_range_s : 0.0;
}

/// Frames spread over the drive's motion whose sweeps, shifted by up to +-margin_s, the poses
/// cover (no sweep is loaded).
std::vector<std::size_t> refine_frames(const FrameStore& store, const RefineConfig& config, double time_offset_s,
                                       double margin_s);

/// Refines T_ins_lidar (and the time offset) from a start close to the truth (stage 1 output,
/// within about 0.5 deg and 5 cm), on the given frames (refine_frames, or a time slice of them).
/// progress, if set, is called with the fraction done in [0, 1].
RefineResult refine_extrinsic(const FrameStore& store, const std::vector<std::size_t>& frames,
                              const Iso3& T_ins_lidar_start, double time_offset_start_s,
                              const RefineConfig& config = {}, const std::function<void(double)>& progress = {});

/// Stage 2's least-squares system (the continuous method's point-to-plane residuals on the
/// stitched map's local planes, Huber-weighted) at each of `states` (extrinsic, time offset): the
/// planes are found at the first state and only refitted (centroid, normal) at the others, as the
/// Gauss-Newton iterations see them once the grouping is frozen. Parameters [tx ty tz, w_x w_y w_z
/// (R' = exp(w) R), time offset]. Exposed so a test can check the hand-written Jacobian (its
/// time-offset column included) against numerical differentiation.
struct RefineSystem {
  double cost = 0.0;                          ///< sum of w r^2, m^2
  Eigen::Matrix<double, 7, 1> gradient;       ///< sum of w r J (half the cost's gradient at w = 1)
  Eigen::Matrix<double, 7, 7> hessian;        ///< Gauss-Newton, plane offsets eliminated
  std::size_t points = 0;
};
std::vector<RefineSystem> refine_systems(const FrameStore& store, const std::vector<std::size_t>& frames,
                                         const std::vector<std::pair<Iso3, double>>& states, const RefineConfig& config);

/// Stage 2, checked: it may move the horizontal lever arm only as far as its change of the time
/// offset explains (the map shifts by speed x offset along the travel) plus
/// config.max_unexplained_shift_m. Further means the drive cannot separate the offset from the
/// lever arm (a feature-poor drive traded 10 ms for 18 cm): stage 2 runs again with the offset
/// fixed, and `warning` says so (else it is left empty).
RefineResult refine_checked(const FrameStore& store, const std::vector<std::size_t>& frames,
                            const Iso3& T_ins_lidar_start, double time_offset_start_s, double max_speed_mps,
                            const RefineConfig& config, const std::function<void(double)>& progress,
                            std::string& warning);

// ---- Several LiDARs in one map (a rig): the same problem, every frame carrying its LiDAR. ----

/// One LiDAR of a joint refinement: its frames (placed with its store's poses) and its start.
struct RefineLidar {
  std::string name;                     ///< for messages; empty for a single LiDAR
  const FrameStore* store = nullptr;
  std::vector<std::size_t> frames;      ///< refine_frames of its store
  Iso3 T_ins_lidar_start = Iso3::Identity();
  double time_offset_start_s = 0.0;
  bool estimate_time_offset = true;     ///< and config.estimate_time_offset
  /// Also move its tz (besides config.estimate_tz): a rig's LiDAR whose height is tied to another
  /// one's through the shared ground of the joint map (rig.cpp keeps one anchor's tz fixed).
  bool estimate_tz = false;
  /// Points per sweep at most, below config.filter's (0: config.filter's): a rig's member beside
  /// the anchor (JointConfig::member_max_points).
  std::size_t max_points = 0;
};

/// Parameters of LiDAR l in the joint state: [7 l, 7 l + 7) = tx ty tz roll pitch yaw (the
/// INS-frame perturbation of observability.hpp) and its time offset.
inline constexpr int kRefineParams = 7;

struct JointRefineResult {
  StageOutcome outcome;                 ///< of the whole problem (kUndetermined names the LiDAR)
  /// Per LiDAR, as refine_extrinsic returns it (crispness: the joint map's; stddev: marginal of
  /// the joint covariance).
  std::vector<RefineResult> lidars;
  /// 7N x 7N, m / rad / s: Gauss-Newton information of the last iteration (every parameter,
  /// fixed ones included, planes eliminated) and the covariance of the estimated ones
  /// (sigma^2 H^-1; rows and columns of fixed parameters zero). Empty if not run.
  Eigen::MatrixXd information, covariance;
  double residual_sigma_m = 0.0;        ///< weighted RMS point-to-plane distance, last iteration
  std::vector<double> residuals;        ///< per LiDAR: its points on planes (last iteration)
  std::vector<double> rms_before_m, rms_after_m;  ///< per LiDAR: its points' plane distance RMS
  std::size_t planes_used = 0;
  std::size_t shared_planes = 0;        ///< planes holding points of more than one LiDAR
  int evaluations = 0;
};

/// Stage 2 over several LiDARs at once: all their frames in one stitched map, each through its
/// own extrinsic and time offset, minimising the joint map's plane thickness. One LiDAR gives
/// exactly refine_extrinsic's result.
JointRefineResult refine_joint(const std::vector<RefineLidar>& lidars, const RefineConfig& config = {},
                               const std::function<void(double)>& progress = {});

/// refine_checked for several LiDARs: a LiDAR whose lever arm moves further than its offset
/// change explains gets its offset fixed and the joint problem runs again (one warning each).
JointRefineResult refine_joint_checked(const std::vector<RefineLidar>& lidars, double max_speed_mps,
                                       const RefineConfig& config, const std::function<void(double)>& progress,
                                       std::vector<std::string>& warnings);

/// refine_systems for several LiDARs: states[k][l] is LiDAR l's (extrinsic, offset) at state k;
/// gradient and hessian over the 7N parameters.
struct JointRefineSystem {
  double cost = 0.0;
  Eigen::VectorXd gradient;
  Eigen::MatrixXd hessian;
  std::size_t points = 0;
};
std::vector<JointRefineSystem> refine_joint_systems(const std::vector<RefineLidar>& lidars,
                                                    const std::vector<std::vector<std::pair<Iso3, double>>>& states,
                                                    const RefineConfig& config);

}  // namespace insalign
