// The figures a calibration engineer checks first about a drive: how long, how far, how fast,
// how much turning, how level. Pose-only, no I/O.
#pragma once

#include <cstddef>
#include <vector>

#include "core/geometry.hpp"
#include "core/pose_stream.hpp"

namespace insalign {

struct DriveSummary {
  std::size_t frames = 0;                ///< LiDAR frames used (filled by io::summarize_drive)
  std::size_t poses = 0;
  double duration_s = 0.0;               ///< last pose time - first pose time
  double frame_time_begin_s = 0.0;       ///< first / last frame time (LiDAR clock)
  double frame_time_end_s = 0.0;
  double max_pose_gap_s = 0.0;           ///< largest step between consecutive poses
  double distance_m = 0.0;               ///< path length of the INS position
  double heading_change_deg = 0.0;       ///< total absolute yaw change (sum of |d yaw|, unwrapped)
  double heading_range_deg = 0.0;        ///< max - min of the unwrapped yaw (how far it swings)
  double speed_min_mps = 0.0;            ///< over windows of speed_window_s (see summarize_poses)
  double speed_max_mps = 0.0;
  double speed_mean_mps = 0.0;           ///< distance_m / duration_s
  double roll_min_deg = 0.0, roll_max_deg = 0.0;
  double pitch_min_deg = 0.0, pitch_max_deg = 0.0;
  Vec3 bbox_min_m = Vec3::Zero();        ///< INS positions, world frame
  Vec3 bbox_max_m = Vec3::Zero();
  double mean_points_per_frame = 0.0;    ///< over the sampled frames (filled by io::summarize_drive)
  std::size_t frames_sampled = 0;
};

/// Pose-derived figures. Speeds are measured over windows of at least speed_window_s so that
/// position noise between closely spaced poses does not show up as speed spikes.
DriveSummary summarize_poses(const std::vector<StampedPose>& poses, double speed_window_s = 0.5);

}  // namespace insalign
