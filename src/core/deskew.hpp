// Placing sweeps in the world with the INS trajectory, point by point (motion compensation).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

#include "core/pose_stream.hpp"
#include "core/sweep.hpp"

namespace insalign {

/// Options for placing a sweep. The INS time of a point is t_lidar + time_offset_s.
struct PlaceOptions {
  double time_offset_s = 0.0;  ///< added to LiDAR time to get INS time (CONVENTIONS.md)
  bool per_point_time = true;  ///< false: every point at the frame time (no deskew)
  double knot_spacing_s = 0.002;  ///< poses are interpolated at knots this far apart, then blended
};

/// World coordinates of every point: T_world_ins(t_i + offset) * T_ins_lidar * p_lidar_i.
/// Throws OutOfRangeError if the poses do not cover the sweep.
std::vector<Vec3f> sweep_to_world(const Sweep& sweep, const PoseStream& poses, const Iso3& T_ins_lidar,
                                  const PlaceOptions& options = {});

/// Every point expressed in the LiDAR frame at the frame time t_end_s (motion removed):
/// p' = (T_world_ins(t_end + offset) * T_ins_lidar)^-1 * T_world_ins(t_i + offset) * T_ins_lidar * p_i.
std::vector<Vec3f> deskew_sweep(const Sweep& sweep, const PoseStream& poses, const Iso3& T_ins_lidar,
                                const PlaceOptions& options = {});

/// T_world_ins at the sweep's frame time (through the time offset).
Iso3 frame_pose(const Sweep& sweep, const PoseStream& poses, double time_offset_s);

/// The INS pose, velocity and angular velocity (world frame) at evenly spaced times from a sweep's
/// first point time to its last, at most max_step_s apart (two at least), for the Jacobians of
/// stage 2 and the trajectory correction: the points' positions come from sweep_to_world, these
/// only need to be close.
struct SweepMotion {
  double dt0_s = 0.0;    ///< point time (relative to the frame time, dt_s) of entry 0
  double step_s = 0.01;  ///< between entries
  std::vector<Mat3> R_world_ins;
  std::vector<Vec3> t_world_ins, v_world, w_world;
  /// The entry nearest the point time dt_s.
  std::size_t nearest(double dt_s) const {
    const double f = std::round((dt_s - dt0_s) / step_s);
    return static_cast<std::size_t>(std::clamp(f, 0.0, static_cast<double>(R_world_ins.size() - 1)));
  }
};
/// Velocities by central differences over 10 ms, inside the poses' span.
SweepMotion sweep_motion(const Sweep& sweep, const PoseStream& poses, double time_offset_s, double max_step_s = 0.01);

}  // namespace insalign
