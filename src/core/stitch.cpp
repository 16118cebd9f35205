#include "core/stitch.hpp"

#include <tbb/parallel_for.h>

#include "core/deskew.hpp"
#include "core/voxel_grid.hpp"

namespace insalign {

std::vector<std::size_t> spread_frames(const FrameStore& store, std::size_t n, double time_offset_s) {
  const DriveFrames drive = drive_frames(store, time_offset_s);
  std::vector<std::size_t> out;
  for (std::size_t k : spread_over_motion(drive, n)) out.push_back(drive.index[k]);
  return out;
}

std::vector<Vec3f> stitch_map(const FrameStore& store, const std::vector<std::size_t>& frames, const Iso3& T_ins_lidar,
                              double time_offset_s, double voxel_m) {
  // Placed a batch at a time (in parallel) and downsampled as they come, first point per voxel
  // in frame order: the same map as placing everything and downsampling once, without holding
  // every placed point (the report stitches three maps of ~3M points each).
  constexpr std::size_t kBatch = 16;
  PlaceOptions options;
  options.time_offset_s = time_offset_s;
  const double inv = voxel_m > 0.0 ? 1.0 / voxel_m : 0.0;
  VoxelKeySet seen;
  std::vector<Vec3f> p_world;
  std::vector<std::vector<Vec3f>> placed(std::min(kBatch, frames.size()));
  for (std::size_t first = 0; first < frames.size(); first += kBatch) {
    const std::size_t n = std::min(kBatch, frames.size() - first);
    tbb::parallel_for(std::size_t{0}, n, [&](std::size_t k) {
      const Sweep& sweep = store.reduced(frames[first + k]);
      placed[k].clear();
      if (sweep_covered(store.poses(), sweep, time_offset_s))
        placed[k] = sweep_to_world(sweep, store.poses(), T_ins_lidar, options);
    });
    for (std::size_t k = 0; k < n; ++k)
      for (const Vec3f& p : placed[k])
        if (voxel_m <= 0.0 || seen.insert(voxel_key(p, inv))) p_world.push_back(p);
  }
  return p_world;
}

}  // namespace insalign
