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
};

/// At stage 2's result (T_ins_lidar, time_offset_s, on its frames): the x, y sensitivity to tz
/// and the stddev it adds for a tz uncertainty of tz_sigma_m (1 sigma).
TzCoupling tz_coupling(const FrameStore& store, const std::vector<std::size_t>& frames, const Iso3& T_ins_lidar,
                       double time_offset_s, bool time_offset_free, const RefineConfig& config, double tz_sigma_m);

}  // namespace insalign
