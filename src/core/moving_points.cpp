#include "core/moving_points.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>

#include "core/deskew.hpp"

namespace insalign {
namespace {

constexpr std::size_t kBatchFrames = 16;  // frames whose evidence is held at once before merging
constexpr std::uint64_t kNoKey = ~std::uint64_t{0};  // no evidence key has every bit set

std::uint64_t ground_key(const Vec3f& p, double inv_cell_m) {
  return voxel_key(VoxelCell{floor_int(p.x() * inv_cell_m), floor_int(p.y() * inv_cell_m), 0});
}

// Evidence voxel of a point at height h above (ground + clearance); h in [0, top).
std::uint64_t evidence_key(const Vec3f& p, double h_m, double inv_voxel_m) {
  return voxel_key(VoxelCell{floor_int(p.x() * inv_voxel_m), floor_int(p.y() * inv_voxel_m), floor_int(h_m * inv_voxel_m)});
}

// Height above ground + clearance, or NaN when the point is not judged (no ground, too low or high).
struct HeightAbove {
  const VoxelKeyMap<float>& ground_z_m;
  const MovingPointsConfig& c;
  double inv_cell_m = 1.0 / c.ground_cell_m;
  mutable std::uint64_t last_key = std::numeric_limits<std::uint64_t>::max();
  mutable float last_z = 0.0f;
  mutable bool last_found = false;
  double operator()(const Vec3f& p) const {
    const std::uint64_t key = ground_key(p, inv_cell_m);
    if (key != last_key) {  // rays step through a cell several times in a row
      const float* z = ground_z_m.find(key);
      last_key = key;
      last_found = z != nullptr;
      if (last_found) last_z = *z;
    }
    if (!last_found) return std::numeric_limits<double>::quiet_NaN();
    const double h = p.z() - last_z - c.ground_clearance_m;
    return h >= 0.0 && h < c.max_height_m - c.ground_clearance_m ? h : std::numeric_limits<double>::quiet_NaN();
  }
};

struct PlacedSweep {
  std::vector<Vec3f> p_world;
  Vec3f origin_start = Vec3f::Zero(), origin_end = Vec3f::Zero();  // LiDAR origin at sweep start, end
  std::vector<float> fraction;  // of the sweep, per point (0 start, 1 end)
};

PlacedSweep place(const Sweep& sweep, const PoseStream& poses, const Iso3& T_ins_lidar, double time_offset_s,
                  double period_s) {
  PlacedSweep out;
  if (sweep.size() == 0 || !sweep_covered(poses, sweep, time_offset_s)) return out;
  out.p_world = sweep_to_world(sweep, poses, T_ins_lidar, PlaceOptions{.time_offset_s = time_offset_s});
  const double t_end = sweep.t_end_s + time_offset_s;
  out.origin_end = (poses.T_world_ins(t_end) * T_ins_lidar).translation().cast<float>();
  out.origin_start = (poses.T_world_ins(t_end - period_s) * T_ins_lidar).translation().cast<float>();
  out.fraction.resize(sweep.size(), 1.0f);
  if (sweep.has_time())
    for (std::size_t i = 0; i < sweep.size(); ++i)
      out.fraction[i] = static_cast<float>(std::clamp(1.0 + sweep.dt_s[i] / period_s, 0.0, 1.0));
  return out;
}

// Ground height per cell: a low percentile of the heights of the sample's points in it.
VoxelKeyMap<float> ground_heights(const std::vector<PlacedSweep>& frames, const MovingPointsConfig& c) {
  std::vector<std::pair<std::uint64_t, float>> key_z;  // sorted by cell: each cell's heights side by side
  const double inv = 1.0 / c.ground_cell_m;
  for (const PlacedSweep& f : frames)
    for (const Vec3f& p : f.p_world)
      if (p.allFinite()) key_z.emplace_back(ground_key(p, inv), p.z());
  std::sort(key_z.begin(), key_z.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  VoxelKeyMap<float> ground;
  for (auto first = key_z.begin(); first != key_z.end();) {
    const auto last = std::find_if(first, key_z.end(), [&](const auto& e) { return e.first != first->first; });
    const auto k = static_cast<std::ptrdiff_t>(c.ground_percentile * static_cast<double>(last - first - 1));
    std::nth_element(first, first + k, last, [](const auto& a, const auto& b) { return a.second < b.second; });
    ground[first->first] = (first + k)->second;
    first = last;
  }
  return ground;
}

// Evidence is merged in parallel: keys fall into kShards parts by hash, each part counted on
// its own (the serial merge of millions of keys held the second core idle).
constexpr int kShardBits = 4;
constexpr std::size_t kShards = std::size_t{1} << kShardBits;
std::size_t shard_of(std::uint64_t key) { return (key * 0x9E3779B97F4A7C15ull) >> (64 - kShardBits); }

struct FrameEvidence {
  std::array<std::vector<std::uint64_t>, kShards> hit, free;  // unique, disjoint, by shard
};

// The voxels a frame's points land in and the voxels its rays cross short of their points.
FrameEvidence frame_evidence(const PlacedSweep& f, const HeightAbove& height, const MovingPointsConfig& c) {
  FrameEvidence e;
  const double inv = 1.0 / c.voxel_m;
  VoxelKeySet hit(f.p_world.size());
  for (const Vec3f& p : f.p_world) {
    if (!p.allFinite()) continue;
    const double h = height(p);
    if (!std::isfinite(h)) continue;
    const std::uint64_t key = evidence_key(p, h, inv);
    if (hit.insert(key)) e.hit[shard_of(key)].push_back(key);
  }
  // Rays near the LiDAR all cross the same few voxels: a set, not a sort of every sample.
  VoxelKeySet free(8 * f.p_world.size());
  for (std::size_t i = 0; i < f.p_world.size(); ++i) {
    const Vec3f& p = f.p_world[i];
    if (!p.allFinite()) continue;
    const Vec3f o = f.origin_start + f.fraction[i] * (f.origin_end - f.origin_start);
    const Vec3f ray = p - o;
    const double free_m = ray.norm() - c.end_margin_m;
    const float step = static_cast<float>(c.voxel_m / std::max(ray.norm(), 1e-3f));  // one sample per voxel length
    std::uint64_t last = kNoKey;  // a ray's samples often stay in one voxel for two steps
    for (float s = step; s * ray.norm() < free_m; s += step) {
      const Vec3f q = o + s * ray;
      const double hq = height(q);
      if (!std::isfinite(hq)) continue;
      const std::uint64_t key = evidence_key(q, hq, inv);
      if (key == last) continue;
      last = key;
      if (!hit.contains(key) && free.insert(key)) e.free[shard_of(key)].push_back(key);
    }
  }
  return e;
}

struct Counts {
  std::uint16_t hit = 0, free = 0;  // sample frames
};
using ShardedCounts = std::array<VoxelKeyMap<Counts>, kShards>;

ShardedCounts count_evidence(const std::vector<PlacedSweep>& frames, const HeightAbove& height_proto,
                             const MovingPointsConfig& c) {
  ShardedCounts counts;
  constexpr std::uint16_t kMax = std::numeric_limits<std::uint16_t>::max();
  const auto add = [&](const std::vector<std::uint64_t>& keys, VoxelKeyMap<Counts>& map, bool hit) {
    for (std::uint64_t key : keys) {
      std::uint16_t& n = hit ? map[key].hit : map[key].free;
      if (n < kMax) ++n;
    }
  };
  for (std::size_t first = 0; first < frames.size(); first += kBatchFrames) {
    const std::size_t n = std::min(kBatchFrames, frames.size() - first);
    std::vector<FrameEvidence> batch(n);
    tbb::parallel_for(std::size_t{0}, n, [&](std::size_t k) {
      const HeightAbove height{height_proto.ground_z_m, c};  // its own lookup cache
      batch[k] = frame_evidence(frames[first + k], height, c);
    });
    tbb::parallel_for(std::size_t{0}, kShards, [&](std::size_t part) {
      for (const FrameEvidence& e : batch) add(e.hit[part], counts[part], true), add(e.free[part], counts[part], false);
    });
  }
  return counts;
}

bool moving_space(const Counts& n, const MovingPointsConfig& c) {
  return n.free >= c.min_free_frames && n.hit <= c.max_hit_fraction * (n.hit + n.free);
}

}  // namespace

MovingPoints::MovingPoints(PoseStream poses, const Iso3& T_ins_lidar, double time_offset_s,
                           const MovingPointsConfig& config, VoxelKeyMap<float> ground_z_m,
                           VoxelKeySet moving_voxels)
    : poses_(std::move(poses)),
      T_ins_lidar_(T_ins_lidar),
      time_offset_s_(time_offset_s),
      config_(config),
      ground_z_m_(std::move(ground_z_m)),
      moving_voxels_(std::move(moving_voxels)) {}

bool MovingPoints::moving(const Vec3f& p_world) const {
  if (!p_world.allFinite()) return false;
  const HeightAbove height{ground_z_m_, config_};
  const double h = height(p_world);
  if (!std::isfinite(h)) return false;
  return moving_voxels_.contains(evidence_key(p_world, h, 1.0 / config_.voxel_m));
}

std::vector<char> MovingPoints::keep_world(std::size_t, const std::vector<Vec3f>& p_world) const {
  std::vector<char> keep(p_world.size(), 1);
  for (std::size_t i = 0; i < p_world.size(); ++i) keep[i] = !moving(p_world[i]);
  return keep;
}

std::vector<char> MovingPoints::keep(std::size_t index, const Sweep& sweep) const {
  if (sweep.size() == 0 || !sweep_covered(poses_, sweep, time_offset_s_)) return std::vector<char>(sweep.size(), 1);
  return keep_world(index, sweep_to_world(sweep, poses_, T_ins_lidar_, PlaceOptions{.time_offset_s = time_offset_s_}));
}

std::shared_ptr<const MovingPoints> find_moving_points(const FrameStore& store, const Iso3& T_ins_lidar,
                                                       double time_offset_s, const MovingPointsConfig& config,
                                                       MovingPointsResult& result) {
  const auto start = std::chrono::steady_clock::now();
  result = {};
  if (!config.enabled) return nullptr;
  const std::vector<std::size_t> picks = check_sample(store, config.max_frames, time_offset_s);
  if (picks.size() < 2 * config.min_free_frames) return nullptr;
  SweepFilter filter = config.filter;
  filter.min_range_m = std::max(filter.min_range_m, store.base_filter().min_range_m);
  const FrameStore unmasked = store.with_mask(nullptr);
  const std::vector<Sweep> sweeps = unmasked.thinned(picks, filter);
  std::vector<PlacedSweep> placed(sweeps.size());
  tbb::parallel_for(std::size_t{0}, sweeps.size(), [&](std::size_t k) {
    placed[k] = place(sweeps[k], store.poses(), T_ins_lidar, time_offset_s, store.sweep_period_s());
  });
  VoxelKeyMap<float> ground = ground_heights(placed, config);
  VoxelKeySet moving_voxels;
  for (const VoxelKeyMap<Counts>& part : count_evidence(placed, HeightAbove{ground, config}, config)) {
    part.for_each([&](std::uint64_t key, const Counts& n) {
      if (n.free < config.min_free_frames) return;
      ++result.voxels_judged;
      if (!moving_space(n, config)) return;
      moving_voxels.insert(key);
      result.voxels_moving += n.hit > 0;
    });
  }
  auto mask = std::make_shared<const MovingPoints>(store.poses(), T_ins_lidar, time_offset_s, config,
                                                   std::move(ground), std::move(moving_voxels));
  std::vector<std::pair<std::size_t, std::size_t>> tally(placed.size());  // checked, moving per frame
  tbb::parallel_for(std::size_t{0}, placed.size(), [&](std::size_t k) {
    for (const Vec3f& p : placed[k].p_world) tally[k].first += p.allFinite(), tally[k].second += mask->moving(p);
  });
  for (const auto& [checked, moving] : tally) result.points_checked += checked, result.points_moving += moving;
  result.applied = true;
  result.mask = mask;
  result.frames_used = placed.size();
  result.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return mask;
}

}  // namespace insalign
