// One LiDAR frame (a sweep) as every stage sees it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/geometry.hpp"

namespace insalign {

/// A spinning-LiDAR sweep. Points are in the LiDAR frame of the instant each was measured
/// (raw, motion-distorted). The frame time is the END of the sweep, i.e. the latest point time.
struct Sweep {
  std::string name;                ///< frame name (the PCD basename without extension)
  double t_end_s = 0.0;            ///< frame time, LiDAR clock, absolute seconds
  std::vector<Vec3f> p_lidar;      ///< points, metres
  std::vector<float> dt_s;         ///< point time minus t_end_s (<= 0); empty: no per-point time
  std::vector<float> intensity;    ///< empty if the source had none
  std::vector<std::uint16_t> ring; ///< laser index; empty if the source had none

  std::size_t size() const { return p_lidar.size(); }
  bool has_time() const { return !dt_s.empty(); }
};

}  // namespace insalign
