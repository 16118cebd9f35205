// Stage 1, rough calibration: point-to-plane least squares on adaptive-voxel planes over groups
// of frames, coarse to fine (Yan et al. 2022, section III-B), from an extrinsic off by up to
// about 20 deg and 0.5 m to about 0.1 deg and 2 cm.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "core/frame_store.hpp"
#include "core/frames.hpp"
#include "core/geometry.hpp"
#include "core/observability.hpp"
#include "core/stage.hpp"

namespace insalign {

/// One coarse-to-fine round: which frames are registered together and how planes are found.
struct RoughRound {
  int window_groups = 1;             ///< consecutive frame groups registered together; 0 = all
  int frame_stride = 1;              ///< use every n-th frame of each group (1 = all)
  double root_voxel_m = 2.0;         ///< adaptive voxelization root edge, metres
  double planarity_sigma_m = 0.10;   ///< plane thickness accepted, metres (loose while far off)
  double robust_scale_m = 0.20;      ///< Cauchy loss scale on a point cluster's RMS distance, metres
  int iterations = 4;                ///< Gauss-Newton (Levenberg-Marquardt) steps on fixed associations
};

/// The default schedule: windows of a few consecutive frames (little relative motion, so a wrong
/// extrinsic misplaces them little) with large loose voxels first, then longer windows and finally
/// the whole drive with tight voxels (turns make rotation and x, y well determined).
std::vector<RoughRound> default_rough_schedule();

struct RoughConfig {
  std::size_t groups = 24;           ///< groups of consecutive moving frames spread over the drive
  std::size_t frames_per_group = 6;  ///< consecutive moving frames per group
  /// Per-frame thinning in the LiDAR frame (min_range_m 0: the vehicle's body radius).
  SweepFilter filter{.min_range_m = 0.0, .max_range_m = 80.0, .voxel_m = 0.4, .max_points = 0};
  int max_depth = 3;                 ///< octree depth below the root voxel (min voxel = root / 8)
  double max_eigen_ratio = 0.1;      ///< plane test: smallest / middle eigenvalue below this
  std::size_t min_points_per_plane = 8;  ///< fewer points in a voxel: dropped
  std::size_t min_frames_per_plane = 2;  ///< a plane seen by one frame says nothing about the extrinsic
  std::vector<RoughRound> rounds = default_rough_schedule();
  /// tz is the INS vertical: planar driving cannot determine it. false: kept at the initial
  /// value unless the final information determines it (then it is estimated in a last round);
  /// true: always kept at the initial value.
  bool always_fix_tz = false;
  bool deskew = true;                ///< use per-point times (if the sweeps have them)
  ObservabilityConfig observability{};
  /// A start already near the answer (core/global_init: start_is_near) skips the schedule's first
  /// rounds of one-group windows: they bring a far start into the basin, and a near start is in
  /// it. The rounds of several groups stay: their ten-second windows keep stage 1 (which the INS
  /// checks use) robust to an INS jump that whole-drive rounds would spread. false: all rounds.
  bool near_start_skips_single_group_rounds = true;
  /// When stage 2 follows, stage 1 leaves out its last round (the finest voxels): stage 2 starts
  /// from the round before, well inside its basin (0.5 deg, 5 cm). On the table1 drive that round
  /// moved stage 1 by 0.2 mm and 0.0005 deg and the final result not at all (bench/RESULTS.md).
  /// Stage 1 alone (--no-refine) runs it. false: every round.
  bool stage2_skips_last_round = true;
};

/// The schedule from its first round whose windows hold several groups (all of it when none do).
std::vector<RoughRound> multi_group_rounds(const std::vector<RoughRound>& rounds);

/// The rounds stage 1 runs in the pipeline: a near start (core/global_init: start_is_near) skips
/// the one-group rounds, and stage 2 following skips the last round (the config's flags say
/// whether); never fewer than one round.
std::vector<RoughRound> pipeline_rounds(const RoughConfig& config, bool near_start, bool stage2_follows);

template <class V>
void visit_config(V& v, RoughRound& c) {
  v("window_groups", c.window_groups, "consecutive frame groups registered together (0: all)");
  v("frame_stride", c.frame_stride, "every n-th frame of each group (1: all)");
  v("root_voxel_m", c.root_voxel_m, "adaptive voxelization root edge, m");
  v("planarity_sigma_m", c.planarity_sigma_m, "plane thickness accepted, m");
  v("robust_scale_m", c.robust_scale_m, "Cauchy loss scale on a cluster's RMS distance, m");
  v("iterations", c.iterations, "Levenberg-Marquardt steps on fixed associations");
}

template <class V>
void visit_config(V& v, RoughConfig& c) {
  v("groups", c.groups, "groups of consecutive moving frames spread over the drive");
  v("frames_per_group", c.frames_per_group, "consecutive moving frames per group");
  v.section("filter", c.filter);
  v("max_depth", c.max_depth, "adaptive-voxel octree depth below the root voxel");
  v("max_eigen_ratio", c.max_eigen_ratio, "plane test: smallest / middle eigenvalue below this");
  v("min_points_per_plane", c.min_points_per_plane, "voxels with fewer points are dropped");
  v("min_frames_per_plane", c.min_frames_per_plane, "planes seen by fewer frames are dropped");
  v.list("rounds", c.rounds, "the coarse-to-fine schedule, one entry per round");
  v("always_fix_tz", c.always_fix_tz, "true: keep tz at its initial value even when the drive determines it");
  v("deskew", c.deskew, "use per-point times when the sweeps have them");
  v("near_start_skips_single_group_rounds", c.near_start_skips_single_group_rounds,
    "a start from the data's hand-eye solve (lever arm observed), or an init kept within init.near_data_* of it, skips the first rounds of one-group windows");
  v("stage2_skips_last_round", c.stage2_skips_last_round,
    "when stage 2 follows, stage 1 leaves out its last (finest) round: stage 2 starts from the round before");
  v.section("observability", c.observability);
}

struct RoundLog {
  int round = 0;
  Iso3 T_ins_lidar = Iso3::Identity();  ///< estimate after the round
  double cost = 0.0;                 ///< robust cost after the round, m^2
  std::size_t planes = 0, residuals = 0;
  int windows = 0;                   ///< frame windows registered in the round
  double build_s = 0.0;              ///< wall time: deskew, voxelize, associate
  double solve_s = 0.0;              ///< wall time: optimisation
};

struct RoughResult {
  /// kUndetermined when a DOF other than tz is not determined (message: which and why).
  StageOutcome outcome;
  Iso3 T_ins_lidar = Iso3::Identity();  ///< estimate
  bool tz_estimated = false;         ///< false: tz kept at the initial value (planar driving)
  DofVerdict observability;          ///< from the final round's information over all frames used
  Mat6 information = Mat6::Zero();   ///< final J^T J (planes marginalised), m^-2 / rad^-2 units
  double residual_sigma_m = 0.0;     ///< RMS point-to-plane distance of the final round
  double cost_before = 0.0;          ///< robust cost of the first round at the initial extrinsic, m^2
  double cost_after = 0.0;           ///< robust cost of the last round at the estimate, m^2
  std::size_t frames_used = 0, planes = 0, residuals = 0;
  int rounds = 0;
  std::vector<RoundLog> convergence;
  double load_time_s = 0.0;          ///< of which loading and reducing the frames
};

/// Groups of consecutive moving frames spread over the drive (no sweep is loaded).
using FrameGroups = std::vector<std::vector<std::size_t>>;
FrameGroups rough_frame_groups(const FrameStore& store, const RoughConfig& config = {}, double time_offset_s = 0.0);

/// Runs stage 1 on the given groups (rough_frame_groups, or a time slice of them). Reads the
/// frames from the store (thinned by config.filter). Does not throw for degenerate data: the
/// outcome says which DOFs are undetermined and why. Throws what the frame loader throws.
/// time_offset_s: the LiDAR-to-INS time offset the sweeps are placed with (t_ins = t_lidar +
/// offset; global initialisation's, stage 1 does not estimate it).
RoughResult calibrate_rough(const FrameStore& store, const FrameGroups& groups, const Iso3& T_ins_lidar_init,
                            double time_offset_s, const RoughConfig& config = {},
                            const std::function<void(double fraction)>& progress = {});

/// The points one frame saw of one plane (the association is fixed; the plane itself is refitted
/// to all its observations at every extrinsic).
struct PlaneObservation {
  std::size_t plane = 0;              ///< plane id; observations of one plane must be adjacent
  Iso3 T_world_ins = Iso3::Identity();  ///< frame pose
  std::vector<Vec3f> p_lidar;         ///< the frame's points (deskewed), LiDAR frame
};

/// The stage's least-squares system at an extrinsic: robust cost sum N * s^2 * log(1 + e / (N s^2))
/// over (frame, plane) clusters with e their summed squared point-to-plane distances, the planes
/// refitted; gradient = half the cost gradient and hessian = Gauss-Newton J^T J (weighted), both
/// with the plane parameters eliminated, in the INS-frame perturbation of observability.hpp.
/// Exposed so tests can check the analytic derivatives against numeric differentiation.
struct PointPlaneSystem {
  double cost = 0.0;
  Vec6 gradient = Vec6::Zero();
  Mat6 hessian = Mat6::Zero();
  double sigma_m = 0.0;               ///< weighted RMS point-to-plane distance
};
PointPlaneSystem point_plane_system(const std::vector<PlaneObservation>& observations, const Iso3& T_ins_lidar,
                                    double robust_scale_m);


}  // namespace insalign
