// MCAP (https://mcap.dev/spec, major version 0), read and written by insalign's own code over
// Debian's libzstd and liblz4. Chunks: uncompressed, "zstd" or "lz4" (LZ4 frames).
//
// Reading an indexed file touches only the footer and the summary section when opening; the
// message index records after each chunk are read the first time messages() is asked, and a
// message's chunk is read, CRC-checked and decompressed by read() (recent chunks are cached).
// read_prefix() decompresses a chunk only as far as the bytes it returns (a cloud's header.stamp
// costs its first zstd block, not 3 MB), so it cannot check the chunk's CRC; read() does.
// A file without a summary (a recording cut off) is streamed from its start up to its last whole
// record, and a warning says where it stops being readable.
//
// Channels map to topics: type = schema name, definition = schema data, definition_encoding =
// schema encoding; message_encoding "ros1" -> kRos1, "cdr" -> kCdr. A channel of any other message
// encoding is listed (with encoding kCdr as a placeholder) but read() refuses its messages.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string_view>

#include "recording/bag_reader.hpp"
#include "recording/bag_writer.hpp"

namespace insalign::io::bag {

/// Opens an MCAP file. Throws InputError(path, "byte N" or "", what) when it cannot.
std::unique_ptr<BagReader> open_mcap(const std::filesystem::path& path);

/// Writes an MCAP file to a temporary name, renamed by close(). Profile "ros1" or "ros2" by the
/// encodings of the topics added before the first message ("" when they mix); chunks uncompressed,
/// zstd or lz4, closed once they hold options.chunk_bytes; a message of chunk_bytes or more gets
/// a chunk of its own, so that small messages never share a chunk with a point cloud.
std::unique_ptr<BagWriter> make_mcap_writer(const std::filesystem::path& path, const WriterOptions& options);

/// True when the bytes start with the MCAP magic 0x89 "MCAP0\r\n".
bool is_mcap(std::string_view first_bytes);

/// Shared by mcap_reader.cpp and mcap_writer.cpp only.
namespace mcap_format {

inline constexpr std::string_view kMagic{"\x89MCAP0\r\n", 8};

enum Opcode : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kStatistics = 0x0B,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};

inline constexpr std::size_t kRecordHeaderBytes = 9;   ///< opcode + uint64 content length
inline constexpr std::size_t kFooterContentBytes = 20;  ///< summary_start, summary_offset_start, summary_crc
inline constexpr std::size_t kMessageHeaderBytes = 22;  ///< channel_id, sequence, log_time, publish_time

/// CRC-32 (IEEE, as zlib) continued over `size` more bytes; start with crc32_update(0, ...).
std::uint32_t crc32_update(std::uint32_t crc, const std::uint8_t* data, std::size_t size);

}  // namespace mcap_format
}  // namespace insalign::io::bag
