// A byte vector whose resize does not zero the new bytes: a decompressed chunk (5 MB for a
// Pandar64 cloud) or a chunk read from the file is overwritten whole right after it is sized, and
// zeroing it first cost as much CPU as the chunk CRC (memset at 4% of a run on an MCAP).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

namespace insalign::io::bag {

/// std::allocator, but `construct()` without arguments default-initializes (no zeroing of bytes).
template <typename T>
struct DefaultInitAllocator : std::allocator<T> {
  using std::allocator<T>::allocator;
  template <typename U>
  struct rebind {
    using other = DefaultInitAllocator<U>;
  };
  template <typename U>
  void construct(U* p) noexcept {
    ::new (static_cast<void*>(p)) U;
  }
  template <typename U, typename... Args>
  void construct(U* p, Args&&... args) {
    std::allocator_traits<std::allocator<T>>::construct(*this, p, std::forward<Args>(args)...);
  }
};

/// Bytes of a chunk or record, sized before they are written.
using ByteBuffer = std::vector<std::uint8_t, DefaultInitAllocator<std::uint8_t>>;

}  // namespace insalign::io::bag
