// Stage 1, rough calibration: point-to-plane least squares on adaptive-voxel planes over groups
// of frames, coarse to fine (Yan et al. 2022, section III-B), from an extrinsic off by up to
// about 20 deg and 0.5 m to about 0.1 deg and 2 cm.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "core/dataset.hpp"
#include "core/frame_selection.hpp"
#include "core/geometry.hpp"
#include "core/observability.hpp"

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
  FrameSelectionConfig frames{};     ///< which frames: 24 groups of 6 consecutive moving frames
  double min_range_m = 2.5;          ///< points nearer than this are the car body, dropped
  double max_range_m = 80.0;         ///< points farther than this are dropped (sparse, noisy)
  double downsample_voxel_m = 0.4;   ///< per-frame voxel downsampling in the LiDAR frame, metres
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
};

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
  double wall_time_s = 0.0;
  double load_time_s = 0.0;          ///< of which loading and reducing the frames
  std::string message;               ///< why the stage stopped early (nothing moves, no planes), else empty
};

/// Runs stage 1. Loads only the frames it uses (in parallel, reducing each right away). Does not
/// throw for degenerate data: the verdict says which DOFs are undetermined and why
/// (unobservable_reason() decides whether that is fatal). Throws what the frame loader throws.
RoughResult calibrate_rough(const Dataset& data, const Iso3& T_ins_lidar_init, const RoughConfig& config = {},
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

/// The perturbation the stage uses: R' = exp(w) R, t' = t + rho, delta = [rho; w].
Iso3 perturb_in_ins_frame(const Iso3& T_ins_lidar, const Vec6& delta);

}  // namespace insalign
