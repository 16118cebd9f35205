// Writing recordings (insalign simulate --format ros1|mcap|db3), the mirror of bag_reader.hpp:
// declare topics, append serialized messages in time order, close. Each writer writes its own
// container with its index (ROS 1: connection, chunk info and index records; MCAP: summary with
// chunk and message indexes; rosbag2: the sqlite3 tables and metadata.yaml) so that the readers
// take the random-access path on its output, as on a real recorder's.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "recording/bag_reader.hpp"

namespace insalign::io::bag {

enum class BagFormat {
  kRos1,   ///< .bag, ROS 1 bag v2.0
  kMcap,   ///< .mcap, ros1 or cdr messages
  kDb3,    ///< rosbag2 folder: one .db3 plus metadata.yaml
};

enum class Compression { kNone, kLz4, kZstd, kBz2 };

struct WriterOptions {
  Compression compression = Compression::kNone;  ///< ROS 1: none/bz2/lz4; MCAP: none/zstd/lz4; db3: none
  std::size_t chunk_bytes = 768 * 1024;          ///< a chunk is closed once it holds this much (rosbag's default)
};

class BagWriter {
 public:
  virtual ~BagWriter() = default;
  /// Declares a topic; returns its id for write(). `topic.encoding` must suit the container
  /// (ROS 1 bags: kRos1; db3: kCdr; MCAP: either).
  virtual std::uint32_t add_topic(const Topic& topic) = 0;
  /// Appends one serialized message. log_time_ns must not decrease.
  virtual void write(std::uint32_t topic, std::int64_t log_time_ns, const std::vector<std::uint8_t>& bytes) = 0;
  /// Writes the index and moves the file (or folder) into place; nothing is visible before.
  virtual void close() = 0;
};

/// path: the .bag / .mcap file, or the rosbag2 folder for kDb3. Throws InputError naming path.
std::unique_ptr<BagWriter> make_bag_writer(BagFormat format, const std::filesystem::path& path,
                                           const WriterOptions& options = {});

}  // namespace insalign::io::bag
