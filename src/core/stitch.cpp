#include "core/stitch.hpp"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "core/deskew.hpp"
#include "core/voxel_grid.hpp"

namespace insalign {

std::vector<std::size_t> spread_frames(const FrameStore& store, std::size_t n, double time_offset_s) {
  const DriveFrames drive = drive_frames(store, time_offset_s);
  std::vector<std::size_t> out;
  for (std::size_t k : spread_over_motion(drive, n)) out.push_back(drive.index[k]);
  return out;
}

namespace {

// One frame placed, its points the mask leaves out (if any) moved to `dropped`.
void place_frame(const FrameStore& store, std::size_t index, const Iso3& T_ins_lidar, double time_offset_s,
                 const PointMask* mask, std::vector<Vec3f>& placed, std::vector<Vec3f>& dropped) {
  placed.clear();
  dropped.clear();
  const Sweep& sweep = store.reduced(index);
  if (!sweep_covered(store.poses(), sweep, time_offset_s)) return;
  placed = sweep_to_world(sweep, store.poses(), T_ins_lidar, PlaceOptions{.time_offset_s = time_offset_s});
  if (!mask) return;
  const std::vector<char> keep = mask->keep(index, sweep);
  std::size_t n = 0;
  for (std::size_t i = 0; i < placed.size(); ++i) {
    if (keep[i]) placed[n++] = placed[i];
    else dropped.push_back(placed[i]);
  }
  placed.resize(n);
}

SplitMap stitch(const FrameStore& store, const std::vector<std::size_t>& frames, const Iso3& T_ins_lidar,
                double time_offset_s, double voxel_m, const PointMask* mask) {
  // Placed a batch at a time (in parallel) and downsampled as they come, first point per voxel
  // in frame order: the same map as placing everything and downsampling once, without holding
  // every placed point (the report stitches three maps of ~3M points each). The voxel set is split
  // by key into parts, each scanned in point order by its own thread: the same first points as
  // one serial pass (which was most of the report's time). Two frames per thread a batch: enough
  // to keep the threads busy, and few megabytes of buffers (fresh pages cost a fault each: 16
  // frames a batch made the report's first map 0.3 s instead of 0.2 on 2 cores).
  const std::size_t batch_frames = 2 * static_cast<std::size_t>(tbb::this_task_arena::max_concurrency());
  constexpr int kPartBits = 4;
  const auto part_of = [](std::uint64_t key) { return (key * 0xD6E8FEB86659FD93ull) >> (64 - kPartBits); };
  const double inv = voxel_m > 0.0 ? 1.0 / voxel_m : 0.0;
  std::vector<VoxelKeySet> seen(std::size_t{1} << kPartBits);
  SplitMap out;
  std::vector<Vec3f>& p_world = out.kept_world;
  std::vector<std::vector<Vec3f>> placed(std::min(batch_frames, frames.size())), dropped(placed.size());
  std::vector<Vec3f> batch;
  std::vector<std::uint64_t> keys;
  std::vector<std::uint32_t> by_part;
  std::vector<std::size_t> part_begin(seen.size() + 1), next;
  std::vector<char> keep;
  for (std::size_t first = 0; first < frames.size(); first += batch_frames) {
    const std::size_t n = std::min(batch_frames, frames.size() - first);
    tbb::parallel_for(std::size_t{0}, n, [&](std::size_t k) {
      place_frame(store, frames[first + k], T_ins_lidar, time_offset_s, mask, placed[k], dropped[k]);
    });
    batch.clear();
    for (std::size_t k = 0; k < n; ++k) {
      batch.insert(batch.end(), placed[k].begin(), placed[k].end());
      out.dropped_world.insert(out.dropped_world.end(), dropped[k].begin(), dropped[k].end());
    }
    if (voxel_m <= 0.0) {
      p_world.insert(p_world.end(), batch.begin(), batch.end());
      continue;
    }
    keys.resize(batch.size());
    tbb::parallel_for(std::size_t{0}, batch.size(), [&](std::size_t i) { keys[i] = voxel_key(batch[i], inv); });
    // The points of each part in point order (a counting sort by part), so that each part's
    // thread reads its own points only, not every key of the batch.
    std::fill(part_begin.begin(), part_begin.end(), 0);
    for (std::uint64_t key : keys) ++part_begin[part_of(key) + 1];
    for (std::size_t p = 1; p < part_begin.size(); ++p) part_begin[p] += part_begin[p - 1];
    by_part.resize(keys.size());
    next = part_begin;
    for (std::size_t i = 0; i < keys.size(); ++i) by_part[next[part_of(keys[i])]++] = static_cast<std::uint32_t>(i);
    keep.assign(batch.size(), 0);
    tbb::parallel_for(std::size_t{0}, seen.size(), [&](std::size_t part) {
      constexpr std::size_t kAhead = 16;  // slots prefetched this far ahead (a map's set misses the cache)
      const std::size_t end = part_begin[part + 1];
      for (std::size_t k = part_begin[part]; k < end; ++k) {
        if (k + kAhead < end) seen[part].prefetch(keys[by_part[k + kAhead]]);
        if (seen[part].insert(keys[by_part[k]])) keep[by_part[k]] = 1;
      }
    });
    for (std::size_t i = 0; i < batch.size(); ++i)
      if (keep[i]) p_world.push_back(batch[i]);
  }
  return out;
}

}  // namespace

std::vector<Vec3f> stitch_map(const FrameStore& store, const std::vector<std::size_t>& frames, const Iso3& T_ins_lidar,
                              double time_offset_s, double voxel_m) {
  return stitch(store, frames, T_ins_lidar, time_offset_s, voxel_m, nullptr).kept_world;
}

SplitMap stitch_map_split(const FrameStore& store, const std::vector<std::size_t>& frames, const Iso3& T_ins_lidar,
                          double time_offset_s, double voxel_m, const PointMask& mask) {
  return stitch(store, frames, T_ins_lidar, time_offset_s, voxel_m, &mask);
}

}  // namespace insalign
