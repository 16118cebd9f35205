// A moving-point mask scored against the simulator's mover flags (tests only).
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/frame_store.hpp"
#include "sim/simulate.hpp"

namespace insalign::testing {

struct MoverScore {
  std::size_t tp = 0, fp = 0, fn = 0, all = 0;  ///< movers masked, static masked, movers kept, points
  double precision() const { return tp / std::max(1.0, static_cast<double>(tp + fp)); }
  double recall() const { return tp / std::max(1.0, static_cast<double>(tp + fn)); }
};

/// Every 10th frame of LiDAR `lidar` rendered at its own resolution, its points' keep flags from
/// the mask against the simulator's flags of points on movers.
inline MoverScore mover_score(const sim::World& world, std::size_t lidar, const PointMask& mask) {
  MoverScore s;
  for (std::size_t k = 0; k < world.lidars[lidar].frame_times_s.size(); k += 10) {
    std::vector<std::uint8_t> truth;
    const Sweep sweep = sim::render_lidar_sweep(world, lidar, k, &truth);
    const std::vector<char> keep = mask.keep(k, sweep);
    for (std::size_t i = 0; i < sweep.size(); ++i) {
      s.tp += truth[i] && !keep[i];
      s.fp += !truth[i] && !keep[i];
      s.fn += truth[i] && keep[i];
      ++s.all;
    }
  }
  return s;
}

}  // namespace insalign::testing
