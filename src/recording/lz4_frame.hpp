// The LZ4 frame format (LZ4F, magic 0x184D2204), as used by ROS 1 bag lz4 chunks and MCAP "lz4"
// chunks: one shared pair of helpers over Debian's liblz4.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "recording/byte_buffer.hpp"

namespace insalign::io::bag {

/// Decompresses one or more concatenated LZ4 frames that must yield exactly `expected_size`
/// bytes. Errors throw InputError(file, "byte <byte_offset>", what), byte_offset being the record
/// that holds the frame. A claimed size that LZ4 cannot reach from `size` bytes (its ratio is
/// below 255:1) is refused before anything is allocated, so a corrupt size cannot exhaust memory.
ByteBuffer lz4_frame_decompress(const std::uint8_t* data, std::size_t size, std::size_t expected_size,
                                const std::string& file, std::uint64_t byte_offset);

/// The first `wanted` bytes of the content of the LZ4 frame(s) in `data` (all of it when shorter),
/// each block decoded only as far as needed: the small messages at the start of a chunk are read
/// without decompressing the cloud behind them. `data` may stop early: only the bytes the prefix
/// needs must be there (at most wanted * 256/255 + block headers). Checksums are not verified
/// (they cover whole blocks or the whole content). Errors as lz4_frame_decompress.
ByteBuffer lz4_frame_decompress_prefix(const std::uint8_t* data, std::size_t size, std::size_t wanted,
                                       const std::string& file, std::uint64_t byte_offset);

/// One LZ4 frame holding `size` bytes (content size stored in the frame header).
std::vector<std::uint8_t> lz4_frame_compress(const std::uint8_t* data, std::size_t size);

}  // namespace insalign::io::bag
