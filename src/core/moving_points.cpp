#include "core/moving_points.hpp"

#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <limits>

#include "core/deskew.hpp"

namespace insalign {
namespace {

constexpr std::size_t kBatchFrames = 16;  // frames whose evidence is held at once before merging

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
  // A sweep's first point may be later than one period before its end (covered is checked on its
  // points' times): the start origin no earlier than the poses begin.
  const double t_start = std::max(t_end - period_s, poses.t_begin());
  out.origin_start = (poses.T_world_ins(t_start) * T_ins_lidar).translation().cast<float>();
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
  // In parallel: a cell's ground is the value at a rank, whatever the order of its equal keys.
  tbb::parallel_sort(key_z.begin(), key_z.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
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

// One frame's neighbourhood as dense grids: its evidence voxels as two bitsets (hit, free) and
// the ground heights of its cells. Every point and ray sample lies in the box of the frame's
// points and origins, so the tens of millions of samples a mask casts index arrays of a few
// tens of kilobytes instead of probing hash tables of a megabyte (cache misses were most of the
// time). Cells outside the box, which rounding alone could produce, go to hash sets: the same
// evidence either way.
class FrameCells {
 public:
  FrameCells(const PlacedSweep& f, const VoxelKeyMap<float>& ground_z_m, const MovingPointsConfig& c)
      : c_(c), inv_voxel_(1.0 / c.voxel_m), inv_cell_(1.0 / c.ground_cell_m), ground_z_m_(ground_z_m) {
    Vec3f lo = f.origin_start.cwiseMin(f.origin_end), hi = f.origin_start.cwiseMax(f.origin_end);
    for (const Vec3f& p : f.p_world)
      if (p.allFinite()) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    x0_ = floor_int(lo.x() * inv_voxel_) - 1, y0_ = floor_int(lo.y() * inv_voxel_) - 1;
    w_ = floor_int(hi.x() * inv_voxel_) + 2 - x0_, d_ = floor_int(hi.y() * inv_voxel_) + 2 - y0_;
    h_ = static_cast<std::int64_t>(std::ceil((c.max_height_m - c.ground_clearance_m) * inv_voxel_));
    const std::size_t bits = static_cast<std::size_t>(std::max<std::int64_t>(w_ * d_ * h_, 1));
    hit_.assign((bits + 63) / 64, 0), free_.assign((bits + 63) / 64, 0);
    gx0_ = floor_int(lo.x() * inv_cell_) - 1, gy0_ = floor_int(lo.y() * inv_cell_) - 1;
    gw_ = floor_int(hi.x() * inv_cell_) + 2 - gx0_, gd_ = floor_int(hi.y() * inv_cell_) + 2 - gy0_;
    ground_.resize(static_cast<std::size_t>(gw_ * gd_));
    for (std::int64_t gy = 0; gy < gd_; ++gy)
      for (std::int64_t gx = 0; gx < gw_; ++gx) {
        const float* z = ground_z_m.find(voxel_key(VoxelCell{gx0_ + gx, gy0_ + gy, 0}));
        ground_[static_cast<std::size_t>(gy * gw_ + gx)] = z ? *z : std::numeric_limits<float>::quiet_NaN();
      }
  }

  /// The evidence voxel of p and its bit in the box (-1 outside it); false when p is not judged
  /// (no ground under it, too low or too high).
  bool cell(const Vec3f& p, VoxelCell& v, std::int64_t& bit) const {
    const float z = ground_at(p);
    const double h = p.z() - z - c_.ground_clearance_m;  // NaN without ground
    if (!(h >= 0.0 && h < c_.max_height_m - c_.ground_clearance_m)) return false;
    v = {floor_int(p.x() * inv_voxel_), floor_int(p.y() * inv_voxel_), floor_int(h * inv_voxel_)};
    const std::int64_t ix = v.x - x0_, iy = v.y - y0_;
    bit = ix >= 0 && ix < w_ && iy >= 0 && iy < d_ && v.z < h_ ? (v.z * d_ + iy) * w_ + ix : -1;
    return true;
  }
  /// Every hit is marked before the first free voxel.
  void mark_hit(const VoxelCell& v, std::int64_t bit) {
    if (bit >= 0) {
      hit_[bit >> 6] |= std::uint64_t{1} << (bit & 63);
    } else if (hit_outside_.insert(voxel_key(v))) {
      add(evidence_.hit, voxel_key(v));
    }
  }
  /// The samples of a ray from o, one per voxel length (`step` of the ray), up to free_m from o:
  /// their evidence voxels are free where judged. The same as cell() then mark_free() per sample.
  /// The samples inside the box run in a loop without calls (a call there spilled the loop's
  /// floats to the stack, whose reloads waited on the bitset's stores) and without a branch on
  /// whether a sample is judged (samples near the ground go either way at random, and that
  /// branch was often mispredicted); a sample outside it, which rounding alone produces, stops
  /// that loop for the hash sets.
  void mark_free_ray(const Vec3f& o, const Vec3f& ray, float step, double free_m) {
    const float length = ray.norm();
    for (float s = step; s * length < free_m; s += step) {
      s = mark_free_in_box(o, ray, s, step, length, free_m);
      if (s * length < free_m) mark_free_outside(Vec3f(o.x() + s * ray.x(), o.y() + s * ray.y(), o.z() + s * ray.z()));
    }
  }
  /// A voxel both hit and crossed is hit: evidence() leaves the box's hit voxels out of its free ones.
  void mark_free(const VoxelCell& v, std::int64_t bit) {
    if (bit >= 0) {
      free_[bit >> 6] |= std::uint64_t{1} << (bit & 63);
    } else if (!hit_outside_.contains(voxel_key(v)) && free_outside_.insert(voxel_key(v))) {
      add(evidence_.free, voxel_key(v));
    }
  }
  /// The voxels marked, each once, by shard (the box's read off its bitsets: setting a bit costs
  /// less than asking whether it was set and keeping a list).
  FrameEvidence evidence() && {
    for (std::size_t w = 0; w < hit_.size(); ++w) {
      add_bits(hit_[w], w, evidence_.hit);
      add_bits(free_[w] & ~hit_[w], w, evidence_.free);
    }
    return std::move(evidence_);
  }

 private:
  /// mark_free_ray's samples from s on while they lie in the box: the first one outside, or the
  /// end of the ray.
  float mark_free_in_box(const Vec3f& o, const Vec3f& ray, float s, float step, float length, double free_m) {
    const double inv_cell = inv_cell_, inv_voxel = inv_voxel_, clearance = c_.ground_clearance_m;
    const double top = c_.max_height_m - c_.ground_clearance_m;
    const std::int64_t gx0 = gx0_, gy0 = gy0_, gw = gw_, gd = gd_, x0 = x0_, y0 = y0_, w = w_, d = d_, h = h_;
    const float* ground = ground_.data();
    std::uint64_t* free = free_.data();
    for (; s * length < free_m; s += step) {
      const float px = o.x() + s * ray.x(), py = o.y() + s * ray.y(), pz = o.z() + s * ray.z();
      const std::int64_t gx = floor_int(px * inv_cell) - gx0, gy = floor_int(py * inv_cell) - gy0;
      const std::int64_t ix = floor_int(px * inv_voxel) - x0, iy = floor_int(py * inv_voxel) - y0;
      if (static_cast<std::uint64_t>(gx) >= static_cast<std::uint64_t>(gw) ||
          static_cast<std::uint64_t>(gy) >= static_cast<std::uint64_t>(gd) ||
          static_cast<std::uint64_t>(ix) >= static_cast<std::uint64_t>(w) ||
          static_cast<std::uint64_t>(iy) >= static_cast<std::uint64_t>(d))
        return s;
      const double z = pz - ground[gy * gw + gx] - clearance;  // NaN: no ground
      const bool judged = (z >= 0.0) & (z < top);
      const std::int64_t iz = floor_int((judged ? z : 0.0) * inv_voxel);
      if (iz >= h) return s;
      const std::int64_t bit = (iz * d + iy) * w + ix;
      free[bit >> 6] |= std::uint64_t{judged} << (bit & 63);
    }
    return s;
  }
  void mark_free_outside(const Vec3f& p) {
    VoxelCell v;
    std::int64_t bit = -1;
    if (cell(p, v, bit)) mark_free(v, bit);
  }
  float ground_at(const Vec3f& p) const {
    const std::int64_t gx = floor_int(p.x() * inv_cell_), gy = floor_int(p.y() * inv_cell_);
    if (gx >= gx0_ && gx < gx0_ + gw_ && gy >= gy0_ && gy < gy0_ + gd_)
      return ground_[static_cast<std::size_t>((gy - gy0_) * gw_ + (gx - gx0_))];
    const float* z = ground_z_m_.find(voxel_key(VoxelCell{gx, gy, 0}));
    return z ? *z : std::numeric_limits<float>::quiet_NaN();
  }
  static void add(std::array<std::vector<std::uint64_t>, kShards>& out, std::uint64_t key) {
    out[shard_of(key)].push_back(key);
  }
  void add_bits(std::uint64_t bits, std::size_t word, std::array<std::vector<std::uint64_t>, kShards>& out) const {
    for (; bits != 0; bits &= bits - 1) {
      const auto i = static_cast<std::int64_t>(64 * word) + std::countr_zero(bits);
      add(out, voxel_key(VoxelCell{x0_ + i % w_, y0_ + i / w_ % d_, i / (w_ * d_)}));
    }
  }
  const MovingPointsConfig& c_;
  double inv_voxel_, inv_cell_;
  const VoxelKeyMap<float>& ground_z_m_;
  std::int64_t x0_ = 0, y0_ = 0, w_ = 0, d_ = 0, h_ = 0;  // evidence voxels of the box
  std::int64_t gx0_ = 0, gy0_ = 0, gw_ = 0, gd_ = 0;      // ground cells of the box
  std::vector<std::uint64_t> hit_, free_;
  std::vector<float> ground_;
  VoxelKeySet hit_outside_, free_outside_;
  FrameEvidence evidence_;  // the voxels outside the box so far
};

// The voxels a frame's points land in and (rays) the voxels its rays cross short of their points.
FrameEvidence frame_evidence(const PlacedSweep& f, const VoxelKeyMap<float>& ground_z_m, const MovingPointsConfig& c,
                             bool rays = true) {
  FrameCells cells(f, ground_z_m, c);
  VoxelCell v;
  std::int64_t bit = -1;
  for (const Vec3f& p : f.p_world)
    if (p.allFinite() && cells.cell(p, v, bit)) cells.mark_hit(v, bit);
  for (std::size_t i = 0; i < f.p_world.size() && rays; ++i) {
    const Vec3f& p = f.p_world[i];
    if (!p.allFinite()) continue;
    const Vec3f o = f.origin_start + f.fraction[i] * (f.origin_end - f.origin_start);
    const Vec3f ray = p - o;
    const double free_m = ray.norm() - c.end_margin_m;
    const float step = static_cast<float>(c.voxel_m / std::max(ray.norm(), 1e-3f));  // one sample per voxel length
    cells.mark_free_ray(o, ray, step, free_m);
  }
  return std::move(cells).evidence();
}

struct Counts {
  std::uint16_t hit = 0, free = 0;  // sample frames
};
using ShardedCounts = std::array<VoxelKeyMap<Counts>, kShards>;

void count_evidence(const std::vector<PlacedSweep>& frames, const VoxelKeyMap<float>& ground_z_m,
                    const MovingPointsConfig& c, bool rays, ShardedCounts& counts) {
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
      batch[k] = frame_evidence(frames[first + k], ground_z_m, c, rays);
    });
    tbb::parallel_for(std::size_t{0}, kShards, [&](std::size_t part) {
      for (const FrameEvidence& e : batch) add(e.hit[part], counts[part], true), add(e.free[part], counts[part], false);
    });
  }
}

bool moving_space(const Counts& n, const MovingPointsConfig& c) {
  return n.free >= c.min_free_frames && n.hit <= c.max_hit_fraction * (n.hit + n.free);
}

}  // namespace

MovingPoints::MovingPoints(PoseStream poses, const Iso3& T_ins_lidar, double time_offset_s,
                           const MovingPointsConfig& config, VoxelKeyMap<float> ground_z_m,
                           const std::vector<std::uint64_t>& moving_voxels)
    : poses_(std::move(poses)),
      T_ins_lidar_(T_ins_lidar),
      time_offset_s_(time_offset_s),
      config_(config),
      ground_z_m_(std::move(ground_z_m)),
      moving_voxels_(moving_voxels.size()) {
  for (std::uint64_t key : moving_voxels) moving_voxels_.insert(key);
  build_box(moving_voxels);
}

void MovingPoints::build_box(const std::vector<std::uint64_t>& moving_voxels) {
  if (moving_voxels.empty()) return;
  VoxelCell lo = voxel_cell_of(moving_voxels.front()), hi = lo;
  for (std::uint64_t key : moving_voxels) {
    const VoxelCell c = voxel_cell_of(key);
    lo = {std::min(lo.x, c.x), std::min(lo.y, c.y), std::min(lo.z, c.z)};
    hi = {std::max(hi.x, c.x), std::max(hi.y, c.y), std::max(hi.z, c.z)};
  }
  constexpr double kMaxBits = double(std::int64_t{1} << 27);  // 16 MB
  Box b;
  b.lo = lo, b.w = hi.x - lo.x + 1, b.d = hi.y - lo.y + 1, b.h = hi.z - lo.z + 1;
  if (double(b.w) * double(b.d) * double(b.h) > kMaxBits) return;
  b.bits.assign(static_cast<std::size_t>((b.w * b.d * b.h + 63) / 64), 0);
  for (std::uint64_t key : moving_voxels) {
    const VoxelCell c = voxel_cell_of(key);
    const std::int64_t bit = ((c.z - lo.z) * b.d + (c.y - lo.y)) * b.w + (c.x - lo.x);
    b.bits[static_cast<std::size_t>(bit >> 6)] |= std::uint64_t{1} << (bit & 63);
  }
  // Every ground cell a point of a box column can fall in, with one to spare for rounding.
  const double cells_per_voxel = config_.voxel_m / config_.ground_cell_m;
  b.gx0 = floor_int(double(lo.x) * cells_per_voxel) - 1, b.gy0 = floor_int(double(lo.y) * cells_per_voxel) - 1;
  b.gw = floor_int(double(hi.x + 1) * cells_per_voxel) + 2 - b.gx0;
  b.gd = floor_int(double(hi.y + 1) * cells_per_voxel) + 2 - b.gy0;
  b.ground_z_m.resize(static_cast<std::size_t>(b.gw * b.gd));
  for (std::int64_t gy = 0; gy < b.gd; ++gy)
    for (std::int64_t gx = 0; gx < b.gw; ++gx) {
      const float* z = ground_z_m_.find(voxel_key(VoxelCell{b.gx0 + gx, b.gy0 + gy, 0}));
      b.ground_z_m[static_cast<std::size_t>(gy * b.gw + gx)] = z ? *z : std::numeric_limits<float>::quiet_NaN();
    }
  box_ = std::move(b);
}

bool MovingPoints::moving(const Vec3f& p_world) const {
  if (!p_world.allFinite()) return false;
  if (box_.bits.empty()) return moving_in_maps(p_world);
  const Box& b = box_;
  const double inv_voxel = 1.0 / config_.voxel_m;
  const std::int64_t ix = floor_int(p_world.x() * inv_voxel) - b.lo.x, iy = floor_int(p_world.y() * inv_voxel) - b.lo.y;
  if (ix < 0 || ix >= b.w || iy < 0 || iy >= b.d) return false;  // no moving voxel in this column
  const double inv_cell = 1.0 / config_.ground_cell_m;
  const std::int64_t gx = floor_int(p_world.x() * inv_cell) - b.gx0, gy = floor_int(p_world.y() * inv_cell) - b.gy0;
  if (gx < 0 || gx >= b.gw || gy < 0 || gy >= b.gd) return moving_in_maps(p_world);
  const double h = p_world.z() - b.ground_z_m[static_cast<std::size_t>(gy * b.gw + gx)] - config_.ground_clearance_m;
  if (!(h >= 0.0 && h < config_.max_height_m - config_.ground_clearance_m)) return false;  // NaN: no ground
  const std::int64_t iz = floor_int(h * inv_voxel) - b.lo.z;
  if (iz < 0 || iz >= b.h) return false;
  const std::int64_t bit = (iz * b.d + iy) * b.w + ix;
  return (b.bits[static_cast<std::size_t>(bit >> 6)] >> (bit & 63)) & 1;
}

bool MovingPoints::moving_in_maps(const Vec3f& p_world) const {
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

namespace {

// The sample frames of the evidence, placed with this extrinsic.
std::vector<PlacedSweep> placed_sample(const FrameStore& store, const Iso3& T_ins_lidar, double time_offset_s,
                                       const MovingPointsConfig& config) {
  const std::vector<std::size_t> picks = check_sample(store, config.max_frames, time_offset_s);
  if (picks.size() < 2 * config.min_free_frames) return {};
  SweepFilter filter = config.filter;
  filter.min_range_m = std::max(filter.min_range_m, store.base_filter().min_range_m);
  const FrameStore unmasked = store.with_mask(nullptr);
  const std::vector<Sweep> sweeps = unmasked.thinned(picks, filter);
  std::vector<PlacedSweep> placed(sweeps.size());
  tbb::parallel_for(std::size_t{0}, sweeps.size(), [&](std::size_t k) {
    placed[k] = place(sweeps[k], store.poses(), T_ins_lidar, time_offset_s, store.sweep_period_s());
  });
  return placed;
}

// The sample points the mask leaves out, into result.
void tally(const std::vector<PlacedSweep>& placed, const MovingPoints& mask, MovingPointsResult& result) {
  std::vector<std::pair<std::size_t, std::size_t>> counts(placed.size());  // checked, moving per frame
  tbb::parallel_for(std::size_t{0}, placed.size(), [&](std::size_t k) {
    for (const Vec3f& p : placed[k].p_world) counts[k].first += p.allFinite(), counts[k].second += mask.moving(p);
  });
  for (const auto& [checked, moving] : counts) result.points_checked += checked, result.points_moving += moving;
  result.frames_used = placed.size();
}

}  // namespace

std::shared_ptr<const MovingPoints> find_moving_points(const FrameStore& store, const Iso3& T_ins_lidar,
                                                       double time_offset_s, const MovingPointsConfig& config,
                                                       MovingPointsResult& result) {
  std::vector<MovingPointsResult> results;
  find_moving_points({{&store, T_ins_lidar, time_offset_s}}, 0, config, results);
  result = results.front();
  return result.mask;
}

void find_moving_points(const std::vector<MaskedLidar>& lidars, std::size_t rays_from, const MovingPointsConfig& config,
                        std::vector<MovingPointsResult>& results) {
  const auto start = std::chrono::steady_clock::now();
  results.assign(lidars.size(), MovingPointsResult{});
  if (!config.enabled || rays_from >= lidars.size()) return;
  // Each LiDAR's sample over its own ground heights: heights above its own ground agree whatever
  // its stage-1 tz (decimetres off on a sparse LiDAR), and the evidence voxels count heights.
  std::vector<std::vector<PlacedSweep>> placed;
  std::vector<VoxelKeyMap<float>> ground;
  for (const MaskedLidar& l : lidars) {
    placed.push_back(placed_sample(*l.store, l.T_ins_lidar, l.time_offset_s, config));
    ground.push_back(ground_heights(placed.back(), config));
  }
  if (placed[rays_from].empty()) return;
  ShardedCounts counts;
  for (std::size_t l = 0; l < lidars.size(); ++l) count_evidence(placed[l], ground[l], config, l == rays_from, counts);
  std::vector<std::uint64_t> moving_voxels;
  std::size_t judged = 0, moving = 0;
  for (const VoxelKeyMap<Counts>& part : counts) {
    part.for_each([&](std::uint64_t key, const Counts& n) {
      if (n.free < config.min_free_frames) return;
      ++judged;
      if (!moving_space(n, config)) return;
      moving_voxels.push_back(key);
      moving += n.hit > 0;
    });
  }
  for (std::size_t l = 0; l < lidars.size(); ++l) {
    if (placed[l].empty()) continue;
    MovingPointsResult& r = results[l];
    auto mask = std::make_shared<const MovingPoints>(lidars[l].store->poses(), lidars[l].T_ins_lidar,
                                                     lidars[l].time_offset_s, config, std::move(ground[l]), moving_voxels);
    tally(placed[l], *mask, r);
    r.voxels_judged = judged;
    r.voxels_moving = moving;
    r.applied = true;
    r.mask = mask;
    r.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
}

}  // namespace insalign
