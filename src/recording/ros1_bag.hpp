// ROS 1 bag v2.0 (wiki.ros.org/Bags/Format/2.0), read and written without ROS: chunks
// uncompressed, bz2 or lz4 (roslz4's LZ4 frames). The reader takes the index at the end of the
// file (connection, chunk info and per-chunk index data records) and decompresses one chunk per
// message read; a bag without an index (a recording that was not closed) is scanned instead.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string_view>

#include "recording/bag_reader.hpp"
#include "recording/bag_writer.hpp"

namespace insalign::io::bag {

/// Opens a ROS 1 bag v2.0. Throws InputError(path, "byte N", what) when it is not one or its
/// header or index is corrupt. A bag without a usable index (not closed, or cut off) is scanned
/// with a warning; if its file ends inside a chunk, that is an InputError naming the cut chunk's
/// byte and the file's end unless options.read_cut_off (then the whole chunks before it are read).
std::unique_ptr<BagReader> open_ros1_bag(const std::filesystem::path& path, const OpenOptions& options = {});

/// A writer of ROS 1 bag v2.0 files (compression none, bz2 or lz4; zstd is refused with an
/// InputError naming path). The file appears at `path` only on close().
std::unique_ptr<BagWriter> make_ros1_bag_writer(const std::filesystem::path& path, const WriterOptions& options);

/// Whether a file starting with `first_bytes` is a ROS 1 bag v2.0 ("#ROSBAG V2.0\n").
bool is_ros1_bag(std::string_view first_bytes);

/// The format's constants, shared by the reader and the writer.
namespace ros1 {
inline constexpr std::string_view kMagic = "#ROSBAG V2.0\n";
inline constexpr std::uint32_t kBagHeaderBytes = 4096;  ///< header + data of the bag header record
inline constexpr std::uint8_t kOpMessageData = 0x02;
inline constexpr std::uint8_t kOpBagHeader = 0x03;
inline constexpr std::uint8_t kOpIndexData = 0x04;
inline constexpr std::uint8_t kOpChunk = 0x05;
inline constexpr std::uint8_t kOpChunkInfo = 0x06;
inline constexpr std::uint8_t kOpConnection = 0x07;
}  // namespace ros1

}  // namespace insalign::io::bag
