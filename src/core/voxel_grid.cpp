#include "core/voxel_grid.hpp"

#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <bit>
#include <utility>
#include <unordered_map>

namespace insalign {
namespace {

constexpr std::uint64_t kMix = 0x9E3779B97F4A7C15ull;
constexpr std::size_t kParallelPoints = 400000;    // below this one pass on one thread is faster

// The same result as the one-thread pass for big clouds (a stitched map): points split into
// buckets by the hash of their voxel, each bucket keeps its first point per voxel in its own
// cache-sized table (buckets in parallel), and the kept indices are put back in input order.
std::vector<std::uint32_t> downsample_in_buckets(std::span<const Vec3f> points, double inv) {
  constexpr int kBucketBits = 8;
  constexpr std::size_t kBuckets = std::size_t{1} << kBucketBits;
  std::vector<std::uint64_t> keys(points.size());
  tbb::parallel_for(std::size_t{0}, points.size(), std::size_t{8192}, [&](std::size_t c) {
    for (std::size_t i = c; i < std::min(points.size(), c + 8192); ++i) keys[i] = voxel_key(points[i], inv);
  });
  std::vector<std::size_t> begin(kBuckets + 1, 0);
  for (std::uint64_t key : keys) ++begin[((key * kMix) >> (64 - kBucketBits)) + 1];
  for (std::size_t b = 0; b < kBuckets; ++b) begin[b + 1] += begin[b];
  std::vector<std::uint32_t> bucketed(points.size());  // point indices, increasing within a bucket
  std::vector<std::size_t> fill(begin.begin(), begin.end() - 1);
  for (std::size_t i = 0; i < keys.size(); ++i) bucketed[fill[(keys[i] * kMix) >> (64 - kBucketBits)]++] = static_cast<std::uint32_t>(i);
  std::vector<std::vector<std::uint32_t>> kept(kBuckets);
  tbb::parallel_for(std::size_t{0}, kBuckets, [&](std::size_t b) {
    VoxelKeySet seen(begin[b + 1] - begin[b]);
    for (std::size_t k = begin[b]; k < begin[b + 1]; ++k)
      if (seen.insert(keys[bucketed[k]])) kept[b].push_back(bucketed[k]);
  });
  std::vector<std::uint32_t> out;
  for (const auto& v : kept) out.insert(out.end(), v.begin(), v.end());
  std::sort(out.begin(), out.end());
  return out;
}

// Groups by a least-significant-digit radix sort of the points' box indices (box_index(i), below
// 2^bits): stable, so the same groups in the same order as sorting (key, index) pairs; a few
// linear passes over the bits the box needs cost less than comparing pairs. Cell: the narrowest
// word the box fits (8 bytes a point with 32-bit cells, as the pairs took).
template <class Cell, class BoxIndex>
void radix_groups(std::size_t n, int bits, const BoxIndex& box_index, VoxelGroups& out) {
  struct Keyed {
    Cell cell;
    std::uint32_t index;
  };
  std::vector<Keyed> keyed(n), swap(n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 16384), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) keyed[i] = {static_cast<Cell>(box_index(i)), static_cast<std::uint32_t>(i)};
  });
  constexpr int kDigitBits = 11;
  constexpr std::size_t kDigits = std::size_t{1} << kDigitBits;
  std::vector<std::size_t> start(kDigits);
  for (int shift = 0; shift < bits; shift += kDigitBits) {
    std::fill(start.begin(), start.end(), 0);
    for (const Keyed& k : keyed) ++start[(k.cell >> shift) & (kDigits - 1)];
    std::size_t sum = 0;
    for (std::size_t& s : start) sum += std::exchange(s, sum);
    for (const Keyed& k : keyed) swap[start[(k.cell >> shift) & (kDigits - 1)]++] = k;
    keyed.swap(swap);
  }
  out.begin.clear();
  for (std::size_t i = 0; i < n; ++i) {
    if (i == 0 || keyed[i].cell != keyed[i - 1].cell) out.begin.push_back(i);
    out.order[i] = keyed[i].index;
  }
  out.begin.push_back(n);
}

}  // namespace

std::vector<std::uint32_t> voxel_downsample_indices(std::span<const Vec3f> points, double voxel_m) {
  std::vector<std::uint32_t> kept;
  if (voxel_m <= 0.0) {
    kept.resize(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) kept[i] = static_cast<std::uint32_t>(i);
    return kept;
  }
  const double inv = 1.0 / voxel_m;
  // Isolated: a thread waiting inside may not pick up another sweep's thinning, whose per-thread
  // scratch (thin_sweep's, the set below) this call's caller is still using.
  if (points.size() >= kParallelPoints)
    return tbb::this_task_arena::isolate([&] { return downsample_in_buckets(points, inv); });
  thread_local VoxelKeySet seen;  // every sweep of a run passes here, several times
  seen.clear(points.size());
  constexpr std::size_t kAhead = 16;  // keys hashed this far ahead, their slots prefetched
  std::uint64_t keys[kAhead];
  const std::size_t n = points.size();
  for (std::size_t i = 0; i < std::min(n, kAhead); ++i) seen.prefetch(keys[i] = voxel_key(points[i], inv));
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint64_t key = keys[i % kAhead];
    if (i + kAhead < n) seen.prefetch(keys[i % kAhead] = voxel_key(points[i + kAhead], inv));
    if (seen.insert(key)) kept.push_back(static_cast<std::uint32_t>(i));
  }
  return kept;
}

VoxelGroups group_by_voxel(std::span<const Vec3f> points, double voxel_m) {
  VoxelGroups out;
  const std::size_t n = points.size();
  out.begin.push_back(0);
  if (n == 0) return out;
  const double inv = 1.0 / voxel_m;
  // The cells are computed twice (bounds, then place) rather than stored: 24 bytes a point of a
  // million-point window cost more in page faults than the arithmetic. Both passes in parallel.
  struct Bounds {
    VoxelCell lo, hi;
  };
  const VoxelCell first = voxel_cell(points[0], inv);
  constexpr std::size_t kGrain = 16384;
  const Bounds bounds = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, kGrain), Bounds{first, first},
      [&](const tbb::blocked_range<std::size_t>& r, Bounds b) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
          const VoxelCell c = voxel_cell(points[i], inv);
          b.lo = {std::min(b.lo.x, c.x), std::min(b.lo.y, c.y), std::min(b.lo.z, c.z)};
          b.hi = {std::max(b.hi.x, c.x), std::max(b.hi.y, c.y), std::max(b.hi.z, c.z)};
        }
        return b;
      },
      [](Bounds a, const Bounds& b) {
        return Bounds{{std::min(a.lo.x, b.lo.x), std::min(a.lo.y, b.lo.y), std::min(a.lo.z, b.lo.z)},
                      {std::max(a.hi.x, b.hi.x), std::max(a.hi.y, b.hi.y), std::max(a.hi.z, b.hi.z)}};
      });
  const VoxelCell lo = bounds.lo, hi = bounds.hi;
  const std::int64_t w = hi.x - lo.x + 1, d = hi.y - lo.y + 1, h = hi.z - lo.z + 1;
  const double box = static_cast<double>(w) * static_cast<double>(d) * static_cast<double>(h);
  out.order.resize(n);
  if (box <= std::max(4.0 * static_cast<double>(n), 65536.0)) {
    // A counting sort over the points' box of cells (a map or a window spans a few hundred
    // metres): x-major, so its order is the key order, and stable, so each group is in index order.
    std::vector<std::uint32_t> dense(n);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kGrain), [&](const tbb::blocked_range<std::size_t>& r) {
      for (std::size_t i = r.begin(); i != r.end(); ++i) {
        const VoxelCell c = voxel_cell(points[i], inv);
        dense[i] = static_cast<std::uint32_t>(((c.x - lo.x) * d + (c.y - lo.y)) * h + (c.z - lo.z));
      }
    });
    std::vector<std::uint32_t> start(static_cast<std::size_t>(box) + 1, 0);
    for (std::uint32_t k : dense) ++start[k + 1];
    for (std::size_t k = 1; k < start.size(); ++k) start[k] += start[k - 1];
    out.begin.clear();
    for (std::size_t k = 0; k + 1 < start.size(); ++k)
      if (start[k + 1] != start[k]) out.begin.push_back(start[k]);
    out.begin.push_back(n);
    for (std::size_t i = 0; i < n; ++i) out.order[start[dense[i]]++] = static_cast<std::uint32_t>(i);
    return out;
  }
  // A box too big to count over (a stitched map at centimetre voxels): radix_groups.
  const int bits = std::bit_width(static_cast<std::uint64_t>(w) * static_cast<std::uint64_t>(d) * static_cast<std::uint64_t>(h) - 1);
  const auto box_index = [&](std::size_t i) {
    const VoxelCell c = voxel_cell(points[i], inv);
    return static_cast<std::uint64_t>(((c.x - lo.x) * d + (c.y - lo.y)) * h + (c.z - lo.z));
  };
  if (bits <= 32) radix_groups<std::uint32_t>(n, bits, box_index, out);
  else radix_groups<std::uint64_t>(n, bits, box_index, out);
  return out;
}

std::size_t count_distinct_keys(std::span<const std::uint64_t> keys) {
  constexpr int kBucketBits = 8;
  constexpr std::size_t kBuckets = std::size_t{1} << kBucketBits;
  const auto mix = [](std::uint64_t key) { return key * kMix; };
  std::vector<std::size_t> begin(kBuckets + 1, 0);
  for (std::uint64_t key : keys) ++begin[(mix(key) >> (64 - kBucketBits)) + 1];
  for (std::size_t b = 0; b < kBuckets; ++b) begin[b + 1] += begin[b];
  std::vector<std::uint64_t> bucketed(keys.size());
  std::vector<std::size_t> fill(begin.begin(), begin.end() - 1);
  for (std::uint64_t key : keys) bucketed[fill[mix(key) >> (64 - kBucketBits)]++] = key;
  std::vector<std::size_t> distinct(kBuckets, 0);
  tbb::parallel_for(std::size_t{0}, kBuckets, [&](std::size_t b) {
    VoxelKeySet seen(begin[b + 1] - begin[b]);
    for (std::size_t i = begin[b]; i < begin[b + 1]; ++i) seen.insert(bucketed[i]);
    distinct[b] = seen.size();
  });
  std::size_t total = 0;
  for (std::size_t d : distinct) total += d;
  return total;
}

std::vector<Vec3f> voxel_downsample(std::span<const Vec3f> points, double voxel_m) {
  std::vector<Vec3f> out;
  for (std::uint32_t i : voxel_downsample_indices(points, voxel_m)) out.push_back(points[i]);
  return out;
}

std::vector<Vec3> voxel_centroids(const std::vector<Vec3>& points, double voxel_m) {
  const double inv = 1.0 / voxel_m;
  std::unordered_map<std::uint64_t, std::uint32_t> slot;
  slot.reserve(points.size());
  std::vector<Vec3> sum;
  std::vector<int> count;
  for (const Vec3& p : points) {
    auto [it, inserted] = slot.try_emplace(voxel_key(p, inv), static_cast<std::uint32_t>(sum.size()));
    if (inserted) {
      sum.push_back(p);
      count.push_back(1);
    } else {
      sum[it->second] += p;
      ++count[it->second];
    }
  }
  for (std::size_t i = 0; i < sum.size(); ++i) sum[i] /= static_cast<double>(count[i]);
  return sum;
}

}  // namespace insalign
