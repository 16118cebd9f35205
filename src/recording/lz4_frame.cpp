#include "recording/lz4_frame.hpp"

#include <lz4.h>
#include <lz4frame.h>

#include <algorithm>

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

ByteBuffer lz4_frame_decompress(const std::uint8_t* data, std::size_t size, std::size_t expected_size,
                                const std::string& file, std::uint64_t byte_offset) {
  const std::string where = "byte " + std::to_string(byte_offset);
  // Each input byte of an LZ4 sequence expands to at most 255 output bytes.
  if (expected_size / 256 > size + 64) {
    throw InputError(file, where,
                     "lz4 data of " + std::to_string(size) + " bytes cannot hold the " + std::to_string(expected_size) +
                         " bytes its record claims (corrupt size)");
  }
  ByteBuffer out(expected_size);
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

namespace {

constexpr std::uint32_t kFrameMagic = 0x184D2204;
constexpr std::size_t kWindowBytes = 64 * 1024;  // how far back a linked block may copy from

std::uint32_t le32(const std::uint8_t* p) {
  return std::uint32_t{p[0]} | std::uint32_t{p[1]} << 8 | std::uint32_t{p[2]} << 16 | std::uint32_t{p[3]} << 24;
}

}  // namespace

ByteBuffer lz4_frame_decompress_prefix(const std::uint8_t* data, std::size_t size, std::size_t wanted,
                                       const std::string& file, std::uint64_t byte_offset) {
  const auto fail = [&](const std::string& what) {
    throw InputError(file, "byte " + std::to_string(byte_offset), "corrupt lz4 data: " + what);
  };
  ByteBuffer out(wanted);
  std::size_t in = 0, produced = 0;
  while (produced < wanted && in + 7 <= size) {  // frame by frame
    if (le32(data + in) != kFrameMagic) fail("no LZ4 frame magic where a frame should start");
    const std::uint8_t flg = data[in + 4], bd = data[in + 5];
    if ((flg >> 6) != 1 || (flg & 1) != 0) fail("unknown LZ4 frame version or a dictionary");
    const bool block_checksum = (flg & 0x10) != 0, content_size = (flg & 0x08) != 0, content_checksum = (flg & 0x04) != 0;
    const int size_id = (bd >> 4) & 7;
    if (size_id < 4) fail("unknown LZ4 block size");
    const std::size_t block_max = std::size_t{1} << (8 + 2 * size_id);
    in += 7 + (content_size ? 8 : 0);
    while (produced < wanted) {  // block by block
      if (in + 4 > size) {  // the caller passed only the part of the data it needs
        out.resize(produced);
        return out;
      }
      const std::uint32_t word = le32(data + in);
      in += 4;
      if (word == 0) {  // end mark
        in += content_checksum ? 4 : 0;
        break;
      }
      const bool stored = (word & 0x80000000u) != 0;
      const std::size_t block = word & 0x7FFFFFFFu;
      if (block > block_max) fail("a block larger than the frame's block size");
      const std::size_t available = std::min(block, size - std::min(size, in));
      const std::size_t target = std::min(wanted - produced, block_max);
      int got = 0;
      if (stored) {
        got = static_cast<int>(std::min(available, target));
        std::copy(data + in, data + in + got, out.data() + produced);
      } else {
        const std::size_t dict = std::min(produced, kWindowBytes);  // linked blocks copy from earlier output
        got = LZ4_decompress_safe_partial_usingDict(reinterpret_cast<const char*>(data + in),
                                                    reinterpret_cast<char*>(out.data() + produced), static_cast<int>(available),
                                                    static_cast<int>(target), static_cast<int>(target),
                                                    reinterpret_cast<const char*>(out.data() + produced - dict), static_cast<int>(dict));
        if (got < 0) fail("a block does not decode");
      }
      produced += static_cast<std::size_t>(got);
      in += block + (block_checksum ? 4 : 0);
    }
  }
  out.resize(produced);
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
