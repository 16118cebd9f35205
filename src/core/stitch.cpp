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
  std::vector<std::vector<Vec3f>> placed(frames.size());
  PlaceOptions options;
  options.time_offset_s = time_offset_s;
  tbb::parallel_for(std::size_t{0}, frames.size(), [&](std::size_t k) {
    const Sweep& sweep = store.reduced(frames[k]);
    if (sweep_covered(store.poses(), sweep, time_offset_s)) {
      placed[k] = sweep_to_world(sweep, store.poses(), T_ins_lidar, options);
    }
  });
  std::vector<Vec3f> p_world;
  for (const auto& p : placed) p_world.insert(p_world.end(), p.begin(), p.end());
  return voxel_m > 0.0 ? voxel_downsample(p_world, voxel_m) : p_world;
}

}  // namespace insalign
