// Global initialisation, step 2: the LiDAR's yaw about the INS vertical, from the crispness of a
// few levelled frames of a straight stretch (where the unknown lever arm barely matters),
// searched over 360 deg.
#pragma once

#include <cstddef>
#include <utility>
#include <vector>

#include "core/frames.hpp"
#include "core/ground_level.hpp"

namespace insalign {

struct CoarseYawConfig {
  double yaw_step_deg = 5.0;   ///< candidates over 360 deg, then 1 deg around the best
  int frames = 9;              ///< frames of the straight stretch
  double stretch_m = 16.0;     ///< length of that stretch (motion measure)
  double voxel_m = 0.6;        ///< its points are thinned to voxel centroids of this edge
};

template <class V>
void visit_config(V& v, CoarseYawConfig& c) {
  v("yaw_step_deg", c.yaw_step_deg, "yaw candidate step over 360 deg, deg");
  v("frames", c.frames, "frames of the straight stretch scored for yaw");
  v("stretch_m", c.stretch_m, "length of that stretch (motion measure), m");
  v("voxel_m", c.voxel_m, "the stretch's points are thinned to this voxel, m");
}

/// Positions [first, last] (into `frames`) of the stretch of stretch_m that turns least; the
/// whole drive when it is shorter.
std::pair<std::size_t, std::size_t> straightest_stretch(const DriveFrames& frames, double stretch_m);

/// Best yaw (rad, in the levelled INS frame) of the frames' off-ground points, scored by occupied
/// voxels of crispness_voxel_m; tz_insl_m places the LiDAR vertically.
double coarse_yaw(const std::vector<const InitFrame*>& frames, const Levelling& level, double tz_insl_m,
                  double crispness_voxel_m, const CoarseYawConfig& config);

}  // namespace insalign
