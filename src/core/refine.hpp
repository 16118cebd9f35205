// Stage 2, refinement: deskew every sweep through the INS poses at each point's own time, stitch
// frames from the whole drive into one map and move the extrinsic (and the LiDAR-to-INS time
// offset) until that map is as crisp as possible.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "core/dataset.hpp"
#include "core/geometry.hpp"
#include "core/occupancy.hpp"

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

/// Which frames of the drive a map is built from, and how each is reduced.
struct FramePickConfig {
  std::size_t max_frames = 120;     ///< frames spread evenly over the drive's motion (path + turning)
  double min_motion_m = 0.3;        ///< frames closer than this in path length (plus turning, see below)
                                    ///< to the previous pick are skipped: standstill adds nothing
  double turn_weight_m_per_deg = 0.1; ///< 1 deg of heading change counts as this much path length
  double min_range_m = 2.5;         ///< points nearer than this are dropped (the car body)
  double max_range_m = 80.0;        ///< points farther than this are dropped (sparse, noisy)
  double frame_voxel_m = 0.15;      ///< per-frame downsampling in the LiDAR frame (one raw point,
                                    ///< with its own time, kept per voxel)
  std::size_t max_points_per_frame = 10000;  ///< then thinned evenly to at most this many (0: no cap)
};

struct RefineConfig {
  RefineMethod method = RefineMethod::kContinuous;
  FramePickConfig frames;           ///< frames used and their reduction

  // Degrees of freedom.
  bool estimate_time_offset = true; ///< also estimate the LiDAR-to-INS time offset
  double time_offset_range_s = 0.05;  ///< offset searched within start +- this, seconds
  bool estimate_tz = false;         ///< INS-vertical translation: unobservable from planar driving,
                                    ///< stage 3 fixes it from fiducials; kept at its start value

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
  double time_offset_scan_step_s = 0.005;  ///< coarse occupancy scan of the offset before
                                           ///< Gauss-Newton, seconds (0: no scan)
  double time_offset_scan_voxel_m = 0.2;   ///< voxel edge of that scan's occupancy count
};

/// One step of the search: after each grid round, or each Gauss-Newton iteration.
struct RefineRound {
  int round = 0;
  Iso3 T_ins_lidar = Iso3::Identity();
  double time_offset_s = 0.0;
  double cost = 0.0;                ///< the method's measure (see RefineResult::measure)
};

struct RefineResult {
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
  /// Approximate 1-sigma per DOF [x, y, z, roll, pitch, yaw] (m, deg) and time offset (s) from
  /// the Gauss-Newton information, kContinuous only (zero otherwise).
  Vec6 stddev = Vec6::Zero();
  double time_offset_stddev_s = 0.0;
  std::vector<RefineRound> rounds;
  double wall_time_s = 0.0;
};

/// The local-plane parameters of kContinuous as the crispness measure's config.
PlaneThicknessConfig plane_thickness_config(const RefineConfig& config);

/// Refines T_ins_lidar (and the time offset) from a start close to the truth (stage 1 output,
/// within about 0.5 deg and 5 cm). Throws UnobservableError if too few frames move.
/// progress, if set, is called with the fraction done in [0, 1].
RefineResult refine_extrinsic(const Dataset& data, const Iso3& T_ins_lidar_start, double time_offset_start_s,
                              const RefineConfig& config = {},
                              const std::function<void(double)>& progress = {});

/// A stitched, deskewed, downsampled map for a given extrinsic (report, stage 3, `insalign stitch`).
struct StitchConfig {
  FramePickConfig frames;           ///< which frames, and their per-frame reduction
  double voxel_m = 0.1;             ///< the stitched map is downsampled to this, metres
};
std::vector<Vec3f> stitch_map(const Dataset& data, const Iso3& T_ins_lidar, double time_offset_s,
                              const StitchConfig& config = {});

/// Indices of frames spread over the drive's motion, skipping standstill, whose sweeps (shifted by
/// up to +-margin_s) the poses cover. Exposed for tests and for other stages.
std::vector<std::size_t> pick_refine_frames(const Dataset& data, const FramePickConfig& config,
                                            double time_offset_s, double margin_s);

}  // namespace insalign
