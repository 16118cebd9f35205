// A stitched map for a given extrinsic: the frames placed in the world through the INS poses,
// each point at its own time. What the report draws and `insalign stitch` writes.
#pragma once

#include <cstddef>
#include <vector>

#include "core/frame_store.hpp"
#include "core/geometry.hpp"

namespace insalign {

/// n frames spread over the drive's motion measure whose sweeps the poses cover.
std::vector<std::size_t> spread_frames(const FrameStore& store, std::size_t n, double time_offset_s = 0.0);

/// The frames (from the store, base thinning) placed with per-point deskew and downsampled to
/// voxel_m (0: every point). Frames the poses do not cover are left out.
std::vector<Vec3f> stitch_map(const FrameStore& store, const std::vector<std::size_t>& frames, const Iso3& T_ins_lidar,
                              double time_offset_s, double voxel_m = 0.1);

/// stitch_map with the points `mask` leaves out apart (not downsampled). The mask judges each frame
/// as it places it itself: a moving-point mask built with stage 1's extrinsic still finds its
/// points in a map placed with the final one (whose tz may be decimetres higher).
struct SplitMap {
  std::vector<Vec3f> kept_world, dropped_world;
};
SplitMap stitch_map_split(const FrameStore& store, const std::vector<std::size_t>& frames, const Iso3& T_ins_lidar,
                          double time_offset_s, double voxel_m, const PointMask& mask);

}  // namespace insalign
