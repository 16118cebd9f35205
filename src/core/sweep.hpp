// One LiDAR frame (a sweep) as every stage sees it.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <utility>
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

/// The earliest and latest point time relative to the frame time (dt_s), or {0, 0} without times.
/// Every placement of a sweep asks: kept in eight running extremes, the two passes of
/// std::min_element and std::max_element (one chain through memory each) were a third of
/// placing the points. Point times are finite (the readers drop the others).
inline std::pair<float, float> dt_range(const Sweep& sweep) {
  const std::vector<float>& dt = sweep.dt_s;
  if (dt.empty()) return {0.0f, 0.0f};
  constexpr std::size_t kLanes = 8;
  float lo[kLanes], hi[kLanes];
  std::fill(lo, lo + kLanes, dt[0]);
  std::fill(hi, hi + kLanes, dt[0]);
  std::size_t i = 0;
  for (; i + kLanes <= dt.size(); i += kLanes)
    for (std::size_t k = 0; k < kLanes; ++k) lo[k] = std::min(lo[k], dt[i + k]), hi[k] = std::max(hi[k], dt[i + k]);
  for (; i < dt.size(); ++i) lo[0] = std::min(lo[0], dt[i]), hi[0] = std::max(hi[0], dt[i]);
  return {*std::min_element(lo, lo + kLanes), *std::max_element(hi, hi + kLanes)};
}

}  // namespace insalign
