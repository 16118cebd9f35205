#include "io/bag/lz4_frame.hpp"

#include <lz4frame.h>

#include <memory>
#include <stdexcept>

#include "core/errors.hpp"

namespace insalign::io::bag {
namespace {

struct DecompressionContext {
  LZ4F_dctx* ctx = nullptr;
  DecompressionContext() {
    if (LZ4F_isError(LZ4F_createDecompressionContext(&ctx, LZ4F_VERSION))) throw std::bad_alloc();
  }
  ~DecompressionContext() { LZ4F_freeDecompressionContext(ctx); }
  DecompressionContext(const DecompressionContext&) = delete;
  DecompressionContext& operator=(const DecompressionContext&) = delete;
};

}  // namespace

std::vector<std::uint8_t> lz4_frame_decompress(const std::uint8_t* data, std::size_t size, std::size_t expected_size,
                                               const std::string& file, std::uint64_t byte_offset) {
  const std::string where = "byte " + std::to_string(byte_offset);
  // Each input byte of an LZ4 sequence expands to at most 255 output bytes.
  if (expected_size / 256 > size + 64) {
    throw InputError(file, where,
                     "lz4 data of " + std::to_string(size) + " bytes cannot hold the " + std::to_string(expected_size) +
                         " bytes its record claims (corrupt size)");
  }
  std::vector<std::uint8_t> out(expected_size);
  DecompressionContext dctx;
  std::size_t in_pos = 0, out_pos = 0, hint = 1;
  while (in_pos < size) {
    std::size_t out_avail = out.size() - out_pos, in_avail = size - in_pos;
    hint = LZ4F_decompress(dctx.ctx, out.data() + out_pos, &out_avail, data + in_pos, &in_avail, nullptr);
    if (LZ4F_isError(hint)) {
      throw InputError(file, where, std::string("corrupt lz4 data: ") + LZ4F_getErrorName(hint));
    }
    in_pos += in_avail;
    out_pos += out_avail;
    if (in_avail == 0 && out_avail == 0) {
      throw InputError(file, where,
                       "lz4 data decompresses to more than the " + std::to_string(expected_size) + " bytes its record claims");
    }
  }
  if (hint != 0) throw InputError(file, where, "lz4 data ends in the middle of a frame (truncated)");
  if (out_pos != expected_size) {
    throw InputError(file, where,
                     "lz4 data decompresses to " + std::to_string(out_pos) + " bytes, its record claims " +
                         std::to_string(expected_size));
  }
  return out;
}

std::vector<std::uint8_t> lz4_frame_compress(const std::uint8_t* data, std::size_t size) {
  LZ4F_preferences_t prefs{};
  prefs.frameInfo.contentSize = size;
  prefs.frameInfo.blockSizeID = LZ4F_max4MB;
  std::vector<std::uint8_t> out(LZ4F_compressFrameBound(size, &prefs));
  const std::size_t n = LZ4F_compressFrame(out.data(), out.size(), data, size, &prefs);
  if (LZ4F_isError(n)) throw std::runtime_error(std::string("lz4 compression failed: ") + LZ4F_getErrorName(n));
  out.resize(n);
  return out;
}

}  // namespace insalign::io::bag
