// Before any stage: can this drive determine the extrinsic at all? From the poses alone, over the
// frames' time span (poses outside it are never used by the calibration).
//
// Why these measures (small-error analysis of the map built with a wrong extrinsic):
// - A rotation error w of the extrinsic moves a point seen from INS position t_k by
//   (R_k w) x (x - t_k). Two views of one point disagree by (R w) x (t_2 - t_1) on a straight
//   line: proportional to the distance driven between them, and blind to rotation about the
//   direction of travel. Standing still, nothing disagrees: no rotation is determined.
// - A lever-arm error d moves every point of frame k by R_k d: with a constant heading all points
//   move alike, the map stays sharp and the lever arm is invisible. Two views disagree by
//   (R_1 - R_2) d, so the horizontal lever arm needs different headings. Its sensitivity is
//   sqrt(smallest eigenvalue of the covariance of R_k over the frames), in metres of map
//   disagreement per metre of lever-arm error: 0 on a straight, 0.71 for one 90 deg turn with
//   equal time on both legs, about 1 for figure-8s.
// - tz is never determined by planar driving (stage 3 fixes it from fiducials or a height).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "core/dataset.hpp"
#include "core/pose_stream.hpp"

namespace insalign {

struct MotionCheckConfig {
  /// A rotation error of 0.05 deg (half the accuracy the method reaches) shows as a
  /// disagreement of distance * 0.05 deg between the two ends of the drive: 10 m gives 9 mm,
  /// above the few mm that a voxel map of 2-3 cm range noise can resolve.
  double min_distance_m = 10.0;
  /// Total turning (sum of |heading change|): the lever arm and roll need views from several
  /// headings; one lane change is not enough. 90 deg is one proper turn.
  double min_heading_change_deg = 90.0;
  /// Lever-arm sensitivity (see above). 0.35 is reached by a 41 deg turn with equal time on
  /// both legs: a 1 cm lever-arm error then disagrees by 3.5 mm, resolvable like the rotation.
  double min_lever_arm_sensitivity = 0.35;
  /// Speeds are measured over windows of at least this long so pose noise is not a speed.
  double speed_window_s = 0.5;
};

template <class V>
void visit_config(V& v, MotionCheckConfig& c) {
  v("min_distance_m", c.min_distance_m, "the drive must cover at least this path length, m");
  v("min_heading_change_deg", c.min_heading_change_deg, "total |heading change| needed (90 = one proper turn), deg");
  v("min_lever_arm_sensitivity", c.min_lever_arm_sensitivity, "lever-arm sensitivity needed (0.35 = a 41 deg turn with equal legs)");
  v("speed_window_s", c.speed_window_s, "speeds are measured over windows at least this long, s");
}

struct MotionCheck {
  bool ok = false;
  double distance_m = 0.0;           ///< path length of the INS origin over the frames' span
  double heading_change_deg = 0.0;   ///< total |heading change| (unwrapped)
  double heading_spread_deg = 0.0;   ///< max - min of the unwrapped heading
  double lever_arm_sensitivity = 0.0;///< see the file comment; 0 = lever arm invisible
  double max_speed_mps = 0.0;
  double duration_s = 0.0;           ///< first to last frame time covered by poses
  std::size_t frames = 0;
  /// What the drive determines and what it does not, and why, in plain words; on failure, what
  /// to record instead.
  std::string explanation;
  bool rotation_determined = false;  ///< roll, pitch, yaw
  bool lever_arm_xy_determined = false;
};

/// Never throws on degenerate data (ok = false with the reason); the caller decides to stop.
MotionCheck check_motion(const PoseStream& poses, const std::vector<FrameInfo>& frames,
                         const MotionCheckConfig& config = {});

}  // namespace insalign
