// Regular voxel grids shared by the stages: the integer cell of a point, one 64-bit key per cell,
// and downsampling to one point per cell.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>
#include <tuple>
#include <vector>

#include "core/geometry.hpp"

namespace insalign {

/// Integer coordinates of a cube of the grid: cell = floor(p / voxel_m).
struct VoxelCell {
  std::int64_t x = 0, y = 0, z = 0;
  bool operator==(const VoxelCell&) const = default;
  bool operator<(const VoxelCell& o) const { return std::tie(x, y, z) < std::tie(o.x, o.y, o.z); }
};

/// floor(x) as an integer, for finite x well inside the int64 range: std::floor is a library call
/// on the baseline x86-64 target, and the grids below compute three per point.
inline std::int64_t floor_int(double x) {
  const auto i = static_cast<std::int64_t>(x);
  return i - (x < static_cast<double>(i));
}

inline VoxelCell voxel_cell(const Vec3& p_m, double inv_voxel_m) {
  return {floor_int(p_m.x() * inv_voxel_m), floor_int(p_m.y() * inv_voxel_m), floor_int(p_m.z() * inv_voxel_m)};
}
inline VoxelCell voxel_cell(const Vec3f& p_m, double inv_voxel_m) { return voxel_cell(Vec3(p_m.cast<double>()), inv_voxel_m); }

/// 21 bits per axis: +-1M cells, far beyond any drive at centimetre-to-metre voxels. Sorting by
/// key sorts by (x, y, z).
inline std::uint64_t voxel_key(const VoxelCell& c) {
  constexpr std::int64_t kOffset = std::int64_t{1} << 20;
  constexpr std::uint64_t kMask = (std::uint64_t{1} << 21) - 1;
  return ((static_cast<std::uint64_t>(c.x + kOffset) & kMask) << 42) |
         ((static_cast<std::uint64_t>(c.y + kOffset) & kMask) << 21) | (static_cast<std::uint64_t>(c.z + kOffset) & kMask);
}
/// The cell of a key (the inverse of voxel_key for cells within its range).
inline VoxelCell voxel_cell_of(std::uint64_t key) {
  constexpr std::int64_t kOffset = std::int64_t{1} << 20;
  constexpr std::uint64_t kMask = (std::uint64_t{1} << 21) - 1;
  return {static_cast<std::int64_t>((key >> 42) & kMask) - kOffset, static_cast<std::int64_t>((key >> 21) & kMask) - kOffset,
          static_cast<std::int64_t>(key & kMask) - kOffset};
}
inline std::uint64_t voxel_key(const Vec3f& p_m, double inv_voxel_m) { return voxel_key(voxel_cell(p_m, inv_voxel_m)); }
inline std::uint64_t voxel_key(const Vec3& p_m, double inv_voxel_m) { return voxel_key(voxel_cell(p_m, inv_voxel_m)); }

namespace detail {
inline constexpr std::uint64_t kNoVoxelKey = ~std::uint64_t{0};  // no voxel key has all 64 bits set
/// The slot of `key` in an open-addressing table (a power of two long, under half full): where
/// it is, or the empty slot where it goes.
/// Where probing for `key` starts in a table of `size` slots (a power of two).
inline std::size_t voxel_home(std::size_t size, std::uint64_t key) {
  // Folded so that every bit of the key reaches the slot: keys differing only in x (bits 42-62)
  // must not share one (they did, when the slot was taken from the product's bits 20-40).
  std::uint64_t h = key * 0x9E3779B97F4A7C15ull;
  h ^= h >> 32;
  return h & (size - 1);
}
inline std::size_t voxel_slot(const std::vector<std::uint64_t>& table, std::uint64_t key) {
  const std::size_t mask = table.size() - 1;
  std::size_t slot = voxel_home(table.size(), key);
  while (table[slot] != kNoVoxelKey && table[slot] != key) slot = (slot + 1) & mask;
  return slot;
}
inline std::size_t voxel_table_size(std::size_t expected) {
  std::size_t capacity = 16;
  while (capacity < 2 * expected) capacity <<= 1;
  return capacity;
}
}  // namespace detail

/// A set of voxel keys by open addressing: several times faster than std::unordered_set on the
/// per-point paths (downsampling, ray casting). Grows by doubling at half load.
class VoxelKeySet {
 public:
  explicit VoxelKeySet(std::size_t expected = 0) : table_(detail::voxel_table_size(expected), detail::kNoVoxelKey) {}
  /// true when the key was not in the set yet.
  bool insert(std::uint64_t key) {
    std::size_t slot = detail::voxel_slot(table_, key);
    if (table_[slot] == key) return false;
    if (2 * (size_ + 1) > table_.size()) {
      grow();
      slot = detail::voxel_slot(table_, key);
    }
    table_[slot] = key;
    ++size_;
    return true;
  }
  /// Empties the set for about `expected` keys, keeping its memory when it is large enough (a
  /// reused set costs no fresh pages: the kernel zeroing them cost as much as the inserts).
  void clear(std::size_t expected) {
    const std::size_t size = detail::voxel_table_size(expected);
    if (table_.size() < size || table_.size() > 4 * size) table_.assign(size, detail::kNoVoxelKey);
    else std::fill(table_.begin(), table_.end(), detail::kNoVoxelKey);
    size_ = 0;
  }
  bool contains(std::uint64_t key) const { return table_[detail::voxel_slot(table_, key)] == key; }
  /// Starts loading the slot of `key` into the cache (an insert a few keys later finds it there).
  void prefetch(std::uint64_t key) const { __builtin_prefetch(&table_[detail::voxel_home(table_.size(), key)]); }
  std::size_t size() const { return size_; }

 private:
  void grow() {
    std::vector<std::uint64_t> old(2 * table_.size(), detail::kNoVoxelKey);
    old.swap(table_);
    for (std::uint64_t key : old)
      if (key != detail::kNoVoxelKey) table_[detail::voxel_slot(table_, key)] = key;
  }
  std::vector<std::uint64_t> table_;
  std::size_t size_ = 0;
};

/// A map from voxel keys to small values, by the same open addressing: for maps asked once per
/// point or ray sample (std::unordered_map's nodes cost a cache miss and an allocation each, and
/// freeing millions of them took longer than building the moving-points mask's evidence).
template <class T>
class VoxelKeyMap {
 public:
  explicit VoxelKeyMap(std::size_t expected = 0)
      : keys_(detail::voxel_table_size(expected), detail::kNoVoxelKey), values_(keys_.size()) {}
  /// The value of `key`, value-initialised when new.
  T& operator[](std::uint64_t key) {
    std::size_t slot = detail::voxel_slot(keys_, key);
    if (keys_[slot] == key) return values_[slot];
    if (2 * (size_ + 1) > keys_.size()) {
      grow();
      slot = detail::voxel_slot(keys_, key);
    }
    keys_[slot] = key;
    ++size_;
    return values_[slot];
  }
  /// nullptr when absent.
  const T* find(std::uint64_t key) const {
    const std::size_t slot = detail::voxel_slot(keys_, key);
    return keys_[slot] == key ? &values_[slot] : nullptr;
  }
  std::size_t size() const { return size_; }
  /// f(key, value) for every entry, in table order.
  template <class F>
  void for_each(F&& f) const {
    for (std::size_t i = 0; i < keys_.size(); ++i)
      if (keys_[i] != detail::kNoVoxelKey) f(keys_[i], values_[i]);
  }

 private:
  void grow() {
    std::vector<std::uint64_t> old_keys(2 * keys_.size(), detail::kNoVoxelKey);
    std::vector<T> old_values(old_keys.size());
    old_keys.swap(keys_);
    old_values.swap(values_);
    for (std::size_t i = 0; i < old_keys.size(); ++i) {
      if (old_keys[i] == detail::kNoVoxelKey) continue;
      const std::size_t slot = detail::voxel_slot(keys_, old_keys[i]);
      keys_[slot] = old_keys[i];
      values_[slot] = std::move(old_values[i]);
    }
  }
  std::vector<std::uint64_t> keys_;
  std::vector<T> values_;
  std::size_t size_ = 0;
};

/// Indices of one representative point per voxel_m cube: the first one met, so a kept point keeps
/// its own attributes (time); the result is in input order. voxel_m <= 0 keeps all.
std::vector<std::uint32_t> voxel_downsample_indices(std::span<const Vec3f> points, double voxel_m);

/// How many different keys (occupied voxels): exact, buckets by hash counted in parallel; about
/// 3x faster than sorting the keys (stage 2's time-offset scan counts a 1M-point map per step).
std::size_t count_distinct_keys(std::span<const std::uint64_t> keys);

/// The points of voxel_downsample_indices.
std::vector<Vec3f> voxel_downsample(std::span<const Vec3f> points, double voxel_m);

/// Point indices grouped by voxel: the groups in key order (x, then y, then z), each group in index
/// order, exactly as sorting (key, index) pairs would give them. Group k is
/// order[begin[k] .. begin[k + 1]).
struct VoxelGroups {
  std::vector<std::uint32_t> order;
  std::vector<std::size_t> begin;  ///< one more than the groups
  std::size_t size() const { return begin.empty() ? 0 : begin.size() - 1; }
};
VoxelGroups group_by_voxel(std::span<const Vec3f> points, double voxel_m);

/// One point per occupied voxel: the centroid of its points; deterministic order (first met).
std::vector<Vec3> voxel_centroids(const std::vector<Vec3>& points, double voxel_m);

}  // namespace insalign
