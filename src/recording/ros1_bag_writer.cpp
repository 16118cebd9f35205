// ROS 1 bag v2.0 writer, laid out as rosbag lays it out: the bag header record padded to 4096
// bytes, chunks closed at options.chunk_bytes (each connection record in the chunk of its first
// message), the index data records behind each chunk, and at close the connection and chunk info
// records at index_pos, with the bag header rewritten to point at them. The file is written under
// a temporary name and renamed on close().
#include <bzlib.h>
#include <lz4frame.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <map>
#include <stdexcept>

#include "core/errors.hpp"
#include "recording/ros1_bag.hpp"

namespace insalign::io::bag {
namespace {

using Bytes = std::vector<std::uint8_t>;

void put_u32(Bytes& b, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) b.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}
void put_u64(Bytes& b, std::uint64_t v) {
  put_u32(b, static_cast<std::uint32_t>(v));
  put_u32(b, static_cast<std::uint32_t>(v >> 32));
}
// ROS time: uint32 seconds, uint32 nanoseconds.
void put_time(Bytes& b, std::int64_t ns) {
  put_u32(b, static_cast<std::uint32_t>(ns / 1'000'000'000));
  put_u32(b, static_cast<std::uint32_t>(ns % 1'000'000'000));
}

// <len>name=value
void put_field(Bytes& b, std::string_view name, const Bytes& value) {
  put_u32(b, static_cast<std::uint32_t>(name.size() + 1 + value.size()));
  b.insert(b.end(), name.begin(), name.end());
  b.push_back('=');
  b.insert(b.end(), value.begin(), value.end());
}
void put_field(Bytes& b, std::string_view name, std::string_view value) { put_field(b, name, Bytes(value.begin(), value.end())); }
void put_u32_field(Bytes& b, std::string_view name, std::uint32_t v) {
  Bytes value;
  put_u32(value, v);
  put_field(b, name, value);
}
void put_u64_field(Bytes& b, std::string_view name, std::uint64_t v) {
  Bytes value;
  put_u64(value, v);
  put_field(b, name, value);
}
void put_time_field(Bytes& b, std::string_view name, std::int64_t ns) {
  Bytes value;
  put_time(value, ns);
  put_field(b, name, value);
}
void put_op(Bytes& b, std::uint8_t op) { put_field(b, "op", Bytes{op}); }

// <header_len><header><data_len>, the data to follow.
void put_record_head(Bytes& out, const Bytes& header, std::size_t data_size) {
  put_u32(out, static_cast<std::uint32_t>(header.size()));
  out.insert(out.end(), header.begin(), header.end());
  put_u32(out, static_cast<std::uint32_t>(data_size));
}
void put_record(Bytes& out, const Bytes& header, const Bytes& data) {
  put_record_head(out, header, data.size());
  out.insert(out.end(), data.begin(), data.end());
}

Bytes bag_header_record(std::uint64_t index_pos, std::uint32_t connections, std::uint32_t chunks) {
  Bytes header;
  put_u64_field(header, "index_pos", index_pos);
  put_u32_field(header, "conn_count", connections);
  put_u32_field(header, "chunk_count", chunks);
  put_op(header, ros1::kOpBagHeader);
  Bytes out;
  put_record(out, header, Bytes(ros1::kBagHeaderBytes - header.size(), ' '));
  return out;
}

Bytes bz2_compress(const Bytes& in) {
  auto size = static_cast<unsigned>(in.size() + in.size() / 100 + 600);  // libbz2's documented bound
  Bytes out(size);
  const int ret = BZ2_bzBuffToBuffCompress(reinterpret_cast<char*>(out.data()), &size,
                                           const_cast<char*>(reinterpret_cast<const char*>(in.data())),
                                           static_cast<unsigned>(in.size()), 9, 0, 30);
  if (ret == BZ_MEM_ERROR) throw std::bad_alloc();
  if (ret != BZ_OK) throw std::runtime_error("bz2 compression failed (libbz2 error " + std::to_string(ret) + ")");
  out.resize(size);
  return out;
}

// roslz4 (rosbag's lz4) reads only LZ4 frames with independent blocks, a content checksum and no
// content size, so this is not lz4_frame_compress (which stores the content size).
Bytes lz4_compress_for_roslz4(const Bytes& in) {
  LZ4F_preferences_t prefs{};
  prefs.frameInfo.blockSizeID = LZ4F_max1MB;  // rosbag's choice
  prefs.frameInfo.blockMode = LZ4F_blockIndependent;
  prefs.frameInfo.contentChecksumFlag = LZ4F_contentChecksumEnabled;
  Bytes out(LZ4F_compressFrameBound(in.size(), &prefs));
  const std::size_t n = LZ4F_compressFrame(out.data(), out.size(), in.data(), in.size(), &prefs);
  if (LZ4F_isError(n)) throw std::runtime_error(std::string("lz4 compression failed: ") + LZ4F_getErrorName(n));
  out.resize(n);
  return out;
}

struct IndexEntry {
  std::int64_t t_ns = 0;
  std::uint32_t offset = 0;  ///< of the message record in the chunk's uncompressed data
};

struct ChunkInfo {
  std::uint64_t pos = 0;
  std::int64_t start_ns = 0, end_ns = 0;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> counts;  ///< (connection, messages)
};

class Ros1BagWriter final : public BagWriter {
 public:
  Ros1BagWriter(const std::filesystem::path& path, const WriterOptions& options);
  ~Ros1BagWriter() override;
  Ros1BagWriter(const Ros1BagWriter&) = delete;
  Ros1BagWriter& operator=(const Ros1BagWriter&) = delete;

  std::uint32_t add_topic(const Topic& topic) override;
  void write(std::uint32_t topic, std::int64_t log_time_ns, const std::vector<std::uint8_t>& bytes) override;
  void close() override;

 private:
  [[noreturn]] void fail(const std::string& what) const { throw InputError(path_.string(), "", what); }
  void put(const std::uint8_t* data, std::size_t size);
  void put(const Bytes& bytes) { put(bytes.data(), bytes.size()); }
  Bytes connection_record(std::uint32_t id) const;
  void flush_chunk();

  std::filesystem::path path_, tmp_;
  WriterOptions options_;
  std::FILE* file_ = nullptr;
  std::uint64_t pos_ = 0;  ///< bytes written so far
  std::vector<Topic> topics_;  ///< connection id = index
  std::vector<bool> declared_;  ///< its connection record is in a chunk already
  Bytes chunk_;  ///< the open chunk's uncompressed data
  std::map<std::uint32_t, std::vector<IndexEntry>> chunk_index_;  ///< the open chunk's, per connection
  std::int64_t chunk_start_ns_ = 0, chunk_end_ns_ = 0, last_ns_ = 0;
  std::vector<ChunkInfo> chunk_infos_;
  bool closed_ = false;
};

Ros1BagWriter::Ros1BagWriter(const std::filesystem::path& path, const WriterOptions& options)
    : path_(path), tmp_(path.string() + ".tmp." + std::to_string(::getpid())), options_(options) {
  if (options.compression == Compression::kZstd) fail("ROS 1 bags compress chunks with none, bz2 or lz4, not zstd");
  file_ = std::fopen(tmp_.c_str(), "wb");
  if (file_ == nullptr) fail(std::string("cannot write: ") + std::strerror(errno));
  put(reinterpret_cast<const std::uint8_t*>(ros1::kMagic.data()), ros1::kMagic.size());
  put(bag_header_record(0, 0, 0));  // index_pos 0 (unindexed) until close() rewrites it
}

Ros1BagWriter::~Ros1BagWriter() {
  if (file_ != nullptr) std::fclose(file_);
  std::error_code ec;
  if (!closed_) std::filesystem::remove(tmp_, ec);
}

void Ros1BagWriter::put(const std::uint8_t* data, std::size_t size) {
  if (std::fwrite(data, 1, size, file_) != size) fail(std::string("write failed: ") + std::strerror(errno));
  pos_ += size;
}

std::uint32_t Ros1BagWriter::add_topic(const Topic& topic) {
  if (closed_) throw std::logic_error("add_topic after close");
  if (topic.encoding != MessageEncoding::kRos1) {
    fail("topic " + topic.name + ": a ROS 1 bag holds ROS 1 serialized messages, not CDR");
  }
  if (topic.name.empty() || topic.type.empty()) fail("a topic needs a name and a type");
  topics_.push_back(topic);
  declared_.push_back(false);
  return static_cast<std::uint32_t>(topics_.size() - 1);
}

// The connection record: op, conn and topic in the record header; the connection header (what a
// subscriber's handshake held) as its data.
Bytes Ros1BagWriter::connection_record(std::uint32_t id) const {
  const Topic& topic = topics_[id];
  Bytes header, data, out;
  put_u32_field(header, "conn", id);
  put_field(header, "topic", topic.name);
  put_op(header, ros1::kOpConnection);
  put_field(data, "topic", topic.name);
  put_field(data, "type", topic.type);
  put_field(data, "md5sum", topic.md5sum);
  put_field(data, "message_definition", topic.definition);
  put_record(out, header, data);
  return out;
}

void Ros1BagWriter::write(std::uint32_t topic, std::int64_t log_time_ns, const std::vector<std::uint8_t>& bytes) {
  if (closed_) throw std::logic_error("write after close");
  if (topic >= topics_.size()) throw std::invalid_argument("write to undeclared topic " + std::to_string(topic));
  if (log_time_ns < last_ns_ || log_time_ns / 1'000'000'000 > UINT32_MAX) {
    throw std::invalid_argument("ROS 1 bag message times must not decrease and must fit ROS time (got " +
                                std::to_string(log_time_ns) + " ns after " + std::to_string(last_ns_) + ")");
  }
  if (bytes.size() > UINT32_MAX - 64) throw std::invalid_argument("a ROS 1 bag message must be smaller than 4 GB");
  if (!chunk_.empty() && chunk_.size() + bytes.size() + 512 > UINT32_MAX) flush_chunk();  // offsets are uint32
  last_ns_ = log_time_ns;
  if (!declared_[topic]) {
    const Bytes record = connection_record(topic);
    chunk_.insert(chunk_.end(), record.begin(), record.end());
    declared_[topic] = true;
  }
  if (chunk_index_.empty()) chunk_start_ns_ = log_time_ns;
  chunk_end_ns_ = log_time_ns;
  chunk_index_[topic].push_back({log_time_ns, static_cast<std::uint32_t>(chunk_.size())});
  Bytes header;
  put_u32_field(header, "conn", topic);
  put_time_field(header, "time", log_time_ns);
  put_op(header, ros1::kOpMessageData);
  put_record(chunk_, header, bytes);
  if (chunk_.size() >= options_.chunk_bytes) flush_chunk();
}

// The chunk record, then one index data record per connection in it.
void Ros1BagWriter::flush_chunk() {
  if (chunk_index_.empty()) return;
  const bool bz2 = options_.compression == Compression::kBz2, lz4 = options_.compression == Compression::kLz4;
  const Bytes stored = bz2 ? bz2_compress(chunk_) : lz4 ? lz4_compress_for_roslz4(chunk_) : Bytes{};
  const Bytes& data = bz2 || lz4 ? stored : chunk_;
  ChunkInfo info{pos_, chunk_start_ns_, chunk_end_ns_, {}};
  Bytes header, head;
  put_field(header, "compression", bz2 ? "bz2" : lz4 ? "lz4" : "none");
  put_u32_field(header, "size", static_cast<std::uint32_t>(chunk_.size()));
  put_op(header, ros1::kOpChunk);
  put_record_head(head, header, data.size());
  put(head);
  put(data);
  Bytes index;
  for (const auto& [connection, entries] : chunk_index_) {
    Bytes index_header, index_data;
    put_u32_field(index_header, "ver", 1);
    put_u32_field(index_header, "conn", connection);
    put_u32_field(index_header, "count", static_cast<std::uint32_t>(entries.size()));
    put_op(index_header, ros1::kOpIndexData);
    for (const IndexEntry& e : entries) {
      put_time(index_data, e.t_ns);
      put_u32(index_data, e.offset);
    }
    put_record(index, index_header, index_data);
    info.counts.emplace_back(connection, static_cast<std::uint32_t>(entries.size()));
  }
  put(index);
  chunk_infos_.push_back(std::move(info));
  chunk_.clear();
  chunk_index_.clear();
}

void Ros1BagWriter::close() {
  if (closed_) return;
  flush_chunk();
  const std::uint64_t index_pos = pos_;
  for (std::uint32_t id = 0; id < topics_.size(); ++id) put(connection_record(id));
  for (const ChunkInfo& info : chunk_infos_) {
    Bytes header, data, out;
    put_u32_field(header, "ver", 1);
    put_u64_field(header, "chunk_pos", info.pos);
    put_time_field(header, "start_time", info.start_ns);
    put_time_field(header, "end_time", info.end_ns);
    put_u32_field(header, "count", static_cast<std::uint32_t>(info.counts.size()));
    put_op(header, ros1::kOpChunkInfo);
    for (const auto& [connection, count] : info.counts) {
      put_u32(data, connection);
      put_u32(data, count);
    }
    put_record(out, header, data);
    put(out);
  }
  const Bytes bag_header = bag_header_record(index_pos, static_cast<std::uint32_t>(topics_.size()),
                                             static_cast<std::uint32_t>(chunk_infos_.size()));
  if (std::fflush(file_) != 0 || std::fseek(file_, static_cast<long>(ros1::kMagic.size()), SEEK_SET) != 0 ||
      std::fwrite(bag_header.data(), 1, bag_header.size(), file_) != bag_header.size() || std::fflush(file_) != 0 ||
      ::fsync(::fileno(file_)) != 0) {
    fail(std::string("write failed: ") + std::strerror(errno));
  }
  const int closed = std::fclose(file_);
  file_ = nullptr;
  if (closed != 0) fail(std::string("write failed: ") + std::strerror(errno));
  std::error_code ec;
  std::filesystem::rename(tmp_, path_, ec);
  if (ec) fail("cannot move the finished bag into place: " + ec.message());
  closed_ = true;
}

}  // namespace

std::unique_ptr<BagWriter> make_ros1_bag_writer(const std::filesystem::path& path, const WriterOptions& options) {
  return std::make_unique<Ros1BagWriter>(path, options);
}

}  // namespace insalign::io::bag
