// One interface over the three recording containers (ROS 1 bag v2.0, MCAP, rosbag2 sqlite3):
// the topics with their types and stored definitions, an index of every message (no message data
// read), and random access to one message's serialized bytes. Decoding the bytes is
// messages.hpp's job; choosing topics and building a Dataset is bag_dataset.hpp's.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace insalign::io::bag {

/// How a message's bytes are serialized.
enum class MessageEncoding {
  kRos1,  ///< ROS 1 serialization (ROS 1 bags; MCAP channels with message_encoding "ros1")
  kCdr,   ///< CDR with a 4-byte encapsulation header (rosbag2; MCAP "cdr")
};

struct Topic {
  std::string name;            ///< "/points"
  std::string type;            ///< as stored: "sensor_msgs/PointCloud2" or "sensor_msgs/msg/PointCloud2"
  MessageEncoding encoding = MessageEncoding::kRos1;
  std::string definition;      ///< stored message definition text (ros1msg / ros2msg); empty if none
  std::string definition_encoding;  ///< "ros1msg", "ros2msg", "ros2idl" or "" (none stored)
  std::string md5sum;          ///< ROS 1 only
  std::uint64_t message_count = 0;
};

/// Where one message is; `locator` means something only to the reader that made it.
struct MessageRef {
  std::uint32_t topic = 0;        ///< index into BagReader::topics()
  std::int64_t log_time_ns = 0;   ///< the recorder's receive time (not header.stamp)
  std::uint64_t locator = 0;
  std::uint64_t locator2 = 0;
};

class BagReader {
 public:
  virtual ~BagReader() = default;

  /// Every topic of the recording (also those with no message).
  virtual const std::vector<Topic>& topics() const = 0;

  /// Every message of `topic`, in log-time order (ties in file order), from the index: no
  /// message data is read or decompressed.
  virtual std::vector<MessageRef> messages(std::uint32_t topic) const = 0;

  /// The serialized bytes of one message. Thread-safe (stages load sweeps in parallel).
  /// Throws InputError(file, "byte N", what) for a corrupt or truncated record.
  virtual std::vector<std::uint8_t> read(const MessageRef& ref) const = 0;

  /// One message's bytes where they already lie: inside a decompressed chunk that `owner` keeps
  /// alive, so that a 5 MB point cloud is decoded straight out of its chunk instead of copied out
  /// first. `bytes` is valid as long as `owner` is held.
  struct SharedMessage {
    std::shared_ptr<const void> owner;
    std::span<const std::uint8_t> bytes;
  };
  /// The whole message like read(), without the copy where the reader can avoid it (this
  /// default copies). Thread-safe like read().
  virtual SharedMessage read_shared(const MessageRef& ref) const {
    auto bytes = std::make_shared<const std::vector<std::uint8_t>>(read(ref));
    return {bytes, std::span<const std::uint8_t>(*bytes)};
  }

  /// The first `max_bytes` bytes of one message (all of it when shorter): enough for header.stamp
  /// and a PointCloud2's layout without its points. This default reads the whole message; readers
  /// override it where a prefix is cheaper (a compressed chunk decompressed only as far as
  /// needed). Thread-safe like read().
  virtual std::vector<std::uint8_t> read_prefix(const MessageRef& ref, std::size_t max_bytes) const {
    std::vector<std::uint8_t> bytes = read(ref);
    if (bytes.size() > max_bytes) bytes.resize(max_bytes);
    return bytes;
  }

  /// One message to read_batch(): all of it (max_bytes 0) or its first max_bytes bytes.
  struct BatchRequest {
    MessageRef ref;
    std::size_t max_bytes = 0;
  };
  using BatchHandler = std::function<void(std::size_t request, std::vector<std::uint8_t> bytes)>;
  /// Reads several messages (given in record order), calling on(k, bytes) for requests[k] (in any
  /// order) from the calling thread. Readers override it where messages sharing a compressed
  /// chunk can be served by one decompression, only as far as the furthest byte any of them
  /// needs (MCAP: INS messages before a cloud in the recorder's chunks cost the chunk's first
  /// block, not the cloud). This default reads each on its own. Thread-safe like read().
  virtual void read_batch(const std::vector<BatchRequest>& requests, const BatchHandler& on) const {
    for (std::size_t k = 0; k < requests.size(); ++k) {
      const BatchRequest& q = requests[k];
      on(k, q.max_bytes == 0 ? read(q.ref) : read_prefix(q.ref, q.max_bytes));
    }
  }

  /// "ROS 1 bag v2.0, lz4 chunks", "MCAP (ros2 profile), zstd chunks, indexed", ...
  virtual std::string describe() const = 0;

  /// What was tolerated while opening (e.g. "no summary section: streamed up to byte N").
  virtual const std::vector<std::string>& warnings() const = 0;

  /// The recorder's time range, nanoseconds (0, 0 when there is no message).
  virtual std::int64_t start_time_ns() const = 0;
  virtual std::int64_t end_time_ns() const = 0;

  /// The file (or folder) this reads; used in error messages.
  virtual const std::filesystem::path& path() const = 0;
};

/// What a caller allows while opening (the input config's say).
struct OpenOptions {
  /// A ROS 1 bag whose file ends inside a chunk: false, an InputError naming the cut chunk's byte;
  /// true, its whole chunks before the cut are read, with a warning. (MCAP always streams a
  /// recording without summary to its last whole record, with a warning.)
  bool read_cut_off = false;
};

/// Opens any of the containers, detected from the content (magic bytes) or, for a folder, its
/// `metadata.yaml` or its `.db3` / `.mcap` files in name order (one bag split in several files).
/// Throws InputError(path, "byte N" or "", what) when it cannot.
std::unique_ptr<BagReader> open_bag(const std::filesystem::path& path, const OpenOptions& options = {});

/// The type without the ROS 2 "/msg/" infix: "sensor_msgs/msg/PointCloud2" -> "sensor_msgs/PointCloud2".
std::string normalized_type(const std::string& type);

}  // namespace insalign::io::bag
