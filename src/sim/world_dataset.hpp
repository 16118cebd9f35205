// A simulated drive as a core Dataset whose sweeps are rendered when a stage loads them, so a
// full-resolution 1000-frame drive never sits in memory (benchmarks, long tests).
#pragma once

#include "core/dataset.hpp"
#include "sim/simulate.hpp"

namespace insalign::sim {

/// Frames render on demand (thread-safe); poses are the per-frame reported poses, as in the
/// written pose file; fiducials and the initial guess as written. `world` is shared, not copied.
/// `lidar`: which LiDAR of a rig (its frames, pose file and initial guess).
Dataset world_dataset(std::shared_ptr<const World> world, std::size_t lidar = 0);

}  // namespace insalign::sim
