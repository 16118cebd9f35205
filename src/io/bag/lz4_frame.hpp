// The LZ4 frame format (LZ4F, magic 0x184D2204), as used by ROS 1 bag lz4 chunks and MCAP "lz4"
// chunks: one shared pair of helpers over Debian's liblz4.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace insalign::io::bag {

/// Decompresses one or more concatenated LZ4 frames that must yield exactly `expected_size`
/// bytes. Errors throw InputError(file, "byte <byte_offset>", what), byte_offset being the record
/// that holds the frame. A claimed size that LZ4 cannot reach from `size` bytes (its ratio is
/// below 255:1) is refused before anything is allocated, so a corrupt size cannot exhaust memory.
std::vector<std::uint8_t> lz4_frame_decompress(const std::uint8_t* data, std::size_t size, std::size_t expected_size,
                                               const std::string& file, std::uint64_t byte_offset);

/// One LZ4 frame holding `size` bytes (content size stored in the frame header).
std::vector<std::uint8_t> lz4_frame_compress(const std::uint8_t* data, std::size_t size);

}  // namespace insalign::io::bag
