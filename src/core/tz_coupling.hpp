// Without fiducials or a height prior tz stays where stage 1 (or the initial guess) left it, and
// a wrong tz shifts each sweep sideways wherever the car rolls or pitches (0.3 m at a 1.5 deg
// roll is 8 mm): stage 2 absorbs that shift in x and y, so their formal stddev (tz held fixed)
// does not cover the bias (seen: x 7.8 mm off, stddev 1.1 mm, tz 0.79 m off). This measures how
// far stage 2's x and y move per metre of tz (the other DOFs re-fitted, on stage 2's own
// least-squares system) and carries tz's uncertainty into their stddev.
#pragma once

#include <cstddef>
#include <vector>

#include "core/frame_store.hpp"
#include "core/geometry.hpp"
#include "core/refine.hpp"

namespace insalign {

struct TzCoupling {
  bool ok = false;                       ///< false: too few points on planes (nothing added)
  Eigen::Vector2d dxy_dtz = Eigen::Vector2d::Zero();  ///< stage 2's x, y change per metre of tz (m/m)
  double tz_sigma_m = 0.0;               ///< the tz uncertainty carried
  Eigen::Vector2d stddev_added_m = Eigen::Vector2d::Zero();  ///< |dxy_dtz| * tz_sigma_m
  /// The same for roll, pitch, yaw (rad/m, rad): with perfect poses the segments agree to
  /// 0.0001 deg and a 0.39 m tz error still moved pitch 0.0016 deg.
  Eigen::Vector3d drpy_dtz = Eigen::Vector3d::Zero();
  Eigen::Vector3d rpy_stddev_added_rad = Eigen::Vector3d::Zero();
};

/// The INS's absolute height error over the drive (1 sigma) for stage 3's fiducial tz: the
/// assumed RTK-level value (assumed_m, z.ins_vertical_sigma_m, which partly averages out over a
/// drive) combined in quadrature with how far the INS's stated vertical stddev grows above its best
/// value on this drive (RMS over the samples not left out). Growth is an INS drifting away from
/// its fix, which is slow and does not average out over the fiducial frames (seen: tz 55 mm off
/// with a stated +- 11 mm on a drive whose INS stated up to 52 mm). assumed_m when nothing is stated.
double ins_height_sigma_m(const FrameStore& store, double assumed_m);

/// At stage 2's result (T_ins_lidar, time_offset_s, on its frames): the x, y, roll, pitch, yaw
/// sensitivity to tz and the stddev it adds for a tz uncertainty of tz_sigma_m (1 sigma).
TzCoupling tz_coupling(const FrameStore& store, const std::vector<std::size_t>& frames, const Iso3& T_ins_lidar,
                       double time_offset_s, bool time_offset_free, const RefineConfig& config, double tz_sigma_m);

}  // namespace insalign
