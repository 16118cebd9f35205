// ROS 1 bag v2.0 reader. Opening reads the bag header, then the index at index_pos (connection and
// chunk info records) and, behind each chunk, its index data records: chunk data is never read or
// decompressed to list messages. read() takes one message record out of its chunk: straight from
// the file for an uncompressed chunk, else from the decompressed chunk, kept in a small cache.
#include "recording/ros1_bag.hpp"

#include <bzlib.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstdio>
#include <cstring>
#include <limits>
#include <list>
#include <mutex>
#include <optional>
#include <span>
#include <stdexcept>
#include <tuple>
#include <unordered_map>

#include "core/errors.hpp"
#include "recording/byte_buffer.hpp"
#include "recording/lz4_frame.hpp"

namespace insalign::io::bag {
namespace {

using Bytes = ByteBuffer;  // file pieces and decompressed chunks: not zeroed before they are written
using Message = std::vector<std::uint8_t>;  // what read() returns
using ByteSpan = std::span<const std::uint8_t>;

constexpr std::size_t kMaxRecordHeaderBytes = 64 * 1024;  // real headers hold a few short fields
constexpr std::size_t kReadAheadBytes = 4096;             // one page: a run of small records per pread
constexpr std::size_t kIndexEntryBytes = 12;              // time (sec, nsec) + offset, all uint32

std::string at_byte(std::uint64_t byte) { return "byte " + std::to_string(byte); }

std::string op_name(std::uint8_t op) {
  static const char* const kNames[] = {"", "", "message data", "bag header", "index data",
                                       "chunk", "chunk info", "connection"};
  const std::string hex = "op=" + std::to_string(op);
  return op < 8 && kNames[op][0] != '\0' ? hex + " (" + kNames[op] + ")" : hex + " (unknown)";
}

std::uint32_t le32(const std::uint8_t* p) {
  return std::uint32_t{p[0]} | std::uint32_t{p[1]} << 8 | std::uint32_t{p[2]} << 16 | std::uint32_t{p[3]} << 24;
}
std::uint64_t le64(const std::uint8_t* p) { return le32(p) | std::uint64_t{le32(p + 4)} << 32; }
// ROS time: uint32 seconds then uint32 nanoseconds.
constexpr std::int64_t kNsPerSecond = 1000000000;
std::int64_t ros_time_ns(const std::uint8_t* p) {
  return static_cast<std::int64_t>(le32(p)) * kNsPerSecond + static_cast<std::int64_t>(le32(p + 4));
}

// Where a problem is, for the error: the file, "byte N", and what the byte means.
struct Where {
  const std::string* file = nullptr;
  std::uint64_t byte = 0;
  std::string context;  // e.g. "in the lz4 chunk here, at offset 77 of its uncompressed data: "
  [[noreturn]] void fail(const std::string& problem) const { throw InputError(*file, at_byte(byte), context + problem); }
};

// Thrown when a read needs bytes past the end of the file: the bag is cut off there.
class CutOff : public InputError {
 public:
  using InputError::InputError;
};

// An error's problem alone, without its "file:byte N: " prefix (for a warning that says where).
std::string problem_of(const InputError& e) {
  const std::string prefix = e.file() + ":" + e.location() + ": ";
  const std::string what = e.what();
  return what.rfind(prefix, 0) == 0 ? what.substr(prefix.size()) : what;
}

// The bag file, read with pread only so that threads never share a file position.
class BagFile {
 public:
  explicit BagFile(const std::filesystem::path& path) : name_(path.string()) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) {
      throw InputError(name_, "", std::filesystem::exists(path, ec) ? "not a regular file" : "file not found");
    }
    fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    struct stat st {};
    if (fd_ < 0 || ::fstat(fd_, &st) != 0) {
      const int err = errno;
      if (fd_ >= 0) ::close(fd_);
      throw InputError(name_, "", std::string("cannot open: ") + std::strerror(err));
    }
    size_ = static_cast<std::uint64_t>(st.st_size);
  }
  ~BagFile() { ::close(fd_); }
  BagFile(const BagFile&) = delete;
  BagFile& operator=(const BagFile&) = delete;

  const std::string& name() const { return name_; }
  std::uint64_t size() const { return size_; }

  void read(std::uint64_t off, std::uint8_t* dst, std::size_t n) const {
    if (off > size_ || n > size_ - off) {
      throw CutOff(name_, at_byte(off),
                   std::to_string(n) + " bytes needed, but the file ends at byte " + std::to_string(size_) + " (cut off?)");
    }
    while (n > 0) {
      const ssize_t got = ::pread(fd_, dst, n, static_cast<off_t>(off));
      if (got < 0 && errno == EINTR) continue;
      if (got <= 0) throw InputError(name_, at_byte(off), got < 0 ? std::strerror(errno) : "the file shrank while read");
      dst += got, off += static_cast<std::uint64_t>(got), n -= static_cast<std::size_t>(got);
    }
  }

 private:
  std::string name_;
  int fd_ = -1;
  std::uint64_t size_ = 0;
};

// Bytes that records are parsed from: the file (through a read-ahead window) or a chunk's data.
class Source {
 public:
  virtual ~Source() = default;
  /// Bytes [off, off + n), valid until the next call; past end(), fails as past_end(off, ...).
  virtual ByteSpan get(std::uint64_t off, std::size_t n, const char* what) = 0;
  virtual std::uint64_t end() const = 0;
  virtual Where at(std::uint64_t off) const = 0;
  /// `what`, at `off`, needs the bytes up to `needed`, past end(): CutOff at the end of the file.
  [[noreturn]] virtual void past_end(std::uint64_t off, std::uint64_t needed, const char* what) const = 0;
};

class FileSource final : public Source {
 public:
  FileSource(const BagFile& file, std::uint64_t end) : file_(file), end_(std::min(end, file.size())) {}
  ByteSpan get(std::uint64_t off, std::size_t n, const char* what) override {
    if (off > end_ || n > end_ - off) past_end(off, off + n, what);
    if (n == 0) return {};
    if (off >= buf_pos_ && off - buf_pos_ <= buf_.size() && n <= buf_.size() - (off - buf_pos_)) {
      return ByteSpan(buf_).subspan(off - buf_pos_, n);
    }
    buf_pos_ = off;
    buf_.resize(static_cast<std::size_t>(std::min<std::uint64_t>(std::max(n, kReadAheadBytes), end_ - off)));
    file_.read(off, buf_.data(), buf_.size());
    return ByteSpan(buf_).subspan(0, n);
  }
  std::uint64_t end() const override { return end_; }
  Where at(std::uint64_t off) const override { return {&file_.name(), off, ""}; }
  [[noreturn]] void past_end(std::uint64_t off, std::uint64_t needed, const char* what) const override {
    const bool file_end = end_ == file_.size();
    const std::string problem = std::string(what) + " needs the bytes up to " + std::to_string(needed) + ", but " +
                                (file_end ? "the file ends at byte " : "its chunk ends at byte ") +
                                std::to_string(end_) + " (cut off)";
    if (file_end) throw CutOff(file_.name(), at_byte(off), problem);
    at(off).fail(problem);
  }

 private:
  const BagFile& file_;
  std::uint64_t end_;
  std::uint64_t buf_pos_ = 0;
  Bytes buf_;
};

enum class ChunkCompression { kNone, kBz2, kLz4 };
const char* compression_name(ChunkCompression c) {
  return c == ChunkCompression::kNone ? "none" : c == ChunkCompression::kBz2 ? "bz2" : "lz4";
}

struct Chunk {
  std::uint64_t pos = 0;       ///< the chunk record
  std::uint64_t data_pos = 0;  ///< its stored (maybe compressed) data
  std::uint32_t data_len = 0;
  std::uint32_t size = 0;      ///< uncompressed bytes
  ChunkCompression compression = ChunkCompression::kNone;
};

// A decompressed chunk's data; errors name the chunk's byte (or the file byte when uncompressed).
class ChunkSource final : public Source {
 public:
  ChunkSource(ByteSpan data, const Chunk& chunk, const std::string& file) : data_(data), chunk_(chunk), file_(file) {}
  ByteSpan get(std::uint64_t off, std::size_t n, const char* what) override {
    if (off > data_.size() || n > data_.size() - off) past_end(off, off + n, what);
    return data_.subspan(off, n);
  }
  std::uint64_t end() const override { return data_.size(); }
  [[noreturn]] void past_end(std::uint64_t off, std::uint64_t needed, const char* what) const override {
    at(off).fail(std::string(what) + " needs the bytes up to " + std::to_string(needed) + ", past the end of the chunk's " +
                 std::to_string(data_.size()) + " bytes of data");
  }
  Where at(std::uint64_t off) const override {
    if (chunk_.compression == ChunkCompression::kNone) return {&file_, chunk_.data_pos + off, ""};
    return {&file_, chunk_.pos,
            std::string("in the ") + compression_name(chunk_.compression) + " chunk here, at offset " +
                std::to_string(off) + " of its uncompressed data: "};
  }

 private:
  ByteSpan data_;
  const Chunk& chunk_;
  const std::string& file_;
};

// name=value fields of a record header or of a connection header.
struct Fields {
  std::vector<std::pair<std::string, std::string>> items;
  const std::string* find(std::string_view name) const {
    for (const auto& [k, v] : items) {
      if (k == name) return &v;
    }
    return nullptr;
  }
};

// Returns "" or what is wrong.
std::string parse_fields(ByteSpan bytes, Fields& out) {
  std::size_t i = 0;
  while (i < bytes.size()) {
    if (bytes.size() - i < 4) return "a field length is cut off";
    const std::uint32_t len = le32(bytes.data() + i);
    i += 4;
    if (len > bytes.size() - i) return "a field of " + std::to_string(len) + " bytes runs past the header";
    const auto* begin = reinterpret_cast<const char*>(bytes.data() + i);
    const std::string_view field(begin, len);
    const std::size_t eq = field.find('=');
    if (eq == std::string_view::npos) return "a field has no '='";
    out.items.emplace_back(std::string(field.substr(0, eq)), std::string(field.substr(eq + 1)));
    i += len;
  }
  return "";
}

struct Record {
  Where where;  ///< the record's start
  std::uint8_t op = 0;
  Fields fields;
  std::uint64_t data_pos = 0;
  std::uint32_t data_len = 0;
  std::uint64_t end() const { return data_pos + data_len; }

  const std::string& field(std::string_view name, std::size_t size = 0) const {
    const std::string* v = fields.find(name);
    if (v == nullptr) where.fail(op_name(op) + " record has no '" + std::string(name) + "' field");
    if (size != 0 && v->size() != size) {
      where.fail("field '" + std::string(name) + "' has " + std::to_string(v->size()) + " bytes, not " +
                 std::to_string(size));
    }
    return *v;
  }
  std::uint32_t u32(std::string_view name) const { return le32(data(field(name, 4))); }
  std::uint64_t u64(std::string_view name) const { return le64(data(field(name, 8))); }
  std::int64_t time_ns(std::string_view name) const { return ros_time_ns(data(field(name, 8))); }
  static const std::uint8_t* data(const std::string& s) { return reinterpret_cast<const std::uint8_t*>(s.data()); }
};

// <header_len><header><data_len><data> at `pos`; the data is bounds-checked, not read. A record
// running past the end fails at its own start.
Record read_record(Source& src, std::uint64_t pos) {
  const auto need = [&](std::uint64_t off, std::size_t n, const char* what) {
    if (off > src.end() || n > src.end() - off) src.past_end(pos, off + n, what);
    return src.get(off, n, what);
  };
  Record r;
  r.where = src.at(pos);
  const std::uint32_t header_len = le32(need(pos, 4, "a record header length").data());
  if (header_len > kMaxRecordHeaderBytes) {
    r.where.fail("bad record header: " + std::to_string(header_len) + " bytes long (corrupt length)");
  }
  const std::string problem = parse_fields(need(pos + 4, header_len, "a record header"), r.fields);
  if (!problem.empty()) r.where.fail("bad record header: " + problem);
  const std::string* op = r.fields.find("op");
  if (op == nullptr || op->size() != 1) r.where.fail("bad record header: no one-byte 'op' field");
  r.op = static_cast<std::uint8_t>((*op)[0]);
  r.data_len = le32(need(pos + 4 + header_len, 4, "a record data length").data());
  r.data_pos = pos + 8 + header_len;
  if (r.data_pos > src.end() || r.data_len > src.end() - r.data_pos) {
    src.past_end(pos, r.end(), ("the data of this " + op_name(r.op) + " record").c_str());
  }
  return r;
}

Record expect_record(Source& src, std::uint64_t pos, std::uint8_t op, const std::string& where_expected) {
  Record r = read_record(src, pos);
  if (r.op != op) r.where.fail("expected " + op_name(op) + " " + where_expected + ", found " + op_name(r.op));
  return r;
}

// ---------------------------------------------------------------------------------------------
// What opening found.

struct ChunkInfo {
  std::uint64_t chunk_pos = 0;
  std::int64_t start_ns = 0, end_ns = 0;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> counts;  ///< (connection, messages)
  Where where;
};

struct Contents {
  std::vector<Topic> topics;
  std::unordered_map<std::uint32_t, std::uint32_t> topic_of_connection;
  std::vector<Chunk> chunks;  ///< in file order; MessageRef::locator indexes it
  std::vector<std::vector<MessageRef>> messages;  ///< per topic
  std::vector<std::string> warnings;
  std::int64_t start_ns = 0, end_ns = 0;
  bool indexed = true;
};

// A connection record: the record header names the connection and topic, its data is the
// connection header (type, md5sum, message_definition; latching and callerid are not needed).
void add_connection(Contents& c, const Record& r, Source& src) {
  const std::uint32_t id = r.u32("conn");
  Fields header;
  const std::string problem = parse_fields(src.get(r.data_pos, r.data_len, "a connection header"), header);
  if (!problem.empty()) r.where.fail("bad connection header: " + problem);
  const std::string* topic_name = r.fields.find("topic");
  if (topic_name == nullptr) topic_name = header.find("topic");
  const std::string* type = header.find("type");
  if (topic_name == nullptr || type == nullptr) r.where.fail("connection " + std::to_string(id) + " has no topic or type");
  std::uint32_t t = 0;
  while (t < c.topics.size() && !(c.topics[t].name == *topic_name && c.topics[t].type == *type)) ++t;
  if (const auto known = c.topic_of_connection.find(id); known != c.topic_of_connection.end()) {
    if (known->second == t) return;  // a scan meets each connection in its chunk and in the index
    r.where.fail("connection " + std::to_string(id) + " is declared twice, for different topics");
  }
  if (t == c.topics.size()) {
    for (const Topic& other : c.topics) {
      if (other.name == *topic_name) {
        c.warnings.push_back("topic " + *topic_name + " has connections of two types (" + other.type + ", " + *type +
                             "): listed twice");
      }
    }
    Topic topic;
    topic.name = *topic_name;
    topic.type = *type;
    topic.encoding = MessageEncoding::kRos1;
    // An empty definition counts as none stored, so that decoders fall back to built-in ones.
    if (const std::string* def = header.find("message_definition"); def != nullptr && !def->empty()) {
      topic.definition = *def;
      topic.definition_encoding = "ros1msg";
    }
    if (const std::string* md5 = header.find("md5sum")) topic.md5sum = *md5;
    c.topics.push_back(std::move(topic));
    c.messages.emplace_back();
  }
  c.topic_of_connection.emplace(id, t);
}

std::uint32_t topic_of(const Contents& c, std::uint32_t connection, const Where& where) {
  const auto it = c.topic_of_connection.find(connection);
  if (it == c.topic_of_connection.end()) {
    where.fail("refers to connection " + std::to_string(connection) + ", which the bag does not declare");
  }
  return it->second;
}

Chunk chunk_from_record(const Record& r) {
  Chunk chunk;
  chunk.pos = r.where.byte;
  chunk.data_pos = r.data_pos;
  chunk.data_len = r.data_len;
  const std::string& compression = r.field("compression");
  if (compression == "none") {
    chunk.compression = ChunkCompression::kNone;
  } else if (compression == "bz2") {
    chunk.compression = ChunkCompression::kBz2;
  } else if (compression == "lz4") {
    chunk.compression = ChunkCompression::kLz4;
  } else {
    r.where.fail("unknown chunk compression \"compression=" + compression + "\" (ROS 1 bags use none, bz2 or lz4)");
  }
  chunk.size = r.fields.find("size") != nullptr ? r.u32("size") : r.data_len;
  if (chunk.compression == ChunkCompression::kNone && chunk.size != chunk.data_len) {
    r.where.fail("uncompressed chunk of " + std::to_string(chunk.data_len) + " bytes claims " +
                 std::to_string(chunk.size));
  }
  return chunk;
}

// ---------------------------------------------------------------------------------------------
// Decompression.

// All `expected` bytes, or (wanted < expected) only the first `wanted`: bzip2 decodes block by
// block (900 kB of data each), so the INS messages and the header of the cloud at the start of a
// recorder's chunk cost its first block, not the 5 MB cloud behind them.
Bytes bz2_decompress(const Bytes& in, std::size_t expected, const std::string& file, std::uint64_t at,
                     std::size_t wanted = SIZE_MAX) {
  bz_stream s{};
  if (BZ2_bzDecompressInit(&s, 0, 0) != BZ_OK) throw std::bad_alloc();
  struct End {
    bz_stream* s;
    ~End() { BZ2_bzDecompressEnd(s); }
  } end{&s};
  const auto fail = [&](const std::string& what) { throw InputError(file, at_byte(at), what); };
  // Grown as output appears, so that a corrupt size claim cannot allocate gigabytes up front.
  const bool prefix = wanted < expected;
  Bytes out(prefix ? wanted : std::min(expected + 1, in.size() * 8 + 65536));
  s.next_in = const_cast<char*>(reinterpret_cast<const char*>(in.data()));
  s.avail_in = static_cast<unsigned>(in.size());
  std::size_t produced = 0;
  for (;;) {
    s.next_out = reinterpret_cast<char*>(out.data() + produced);
    s.avail_out = static_cast<unsigned>(std::min<std::size_t>(out.size() - produced, UINT_MAX));
    const unsigned before = s.avail_out;
    const int ret = BZ2_bzDecompress(&s);
    produced += before - s.avail_out;
    if (ret == BZ_STREAM_END) break;
    if (ret == BZ_MEM_ERROR) throw std::bad_alloc();
    if (ret != BZ_OK) fail(ret == BZ_DATA_ERROR_MAGIC ? "the bz2 chunk's data is not bz2 data" : "corrupt bz2 chunk data");
    if (s.avail_out > 0 && s.avail_in == 0) fail("bz2 chunk data ends before its stream does (truncated)");
    if (produced == out.size()) {
      if (prefix) return out;
      if (out.size() > expected) break;
      out.resize(std::min(expected + 1, out.size() * 2));
    }
  }
  if (produced != expected) {
    fail("bz2 chunk data decompresses to " + std::string(produced > expected ? "more than " : "") +
         std::to_string(std::min(produced, expected)) + " bytes, its header claims " + std::to_string(expected));
  }
  out.resize(produced);
  return out;
}

Bytes decompress_chunk(const BagFile& file, const Chunk& chunk) {
  Bytes stored(chunk.data_len);
  file.read(chunk.data_pos, stored.data(), stored.size());
  switch (chunk.compression) {
    case ChunkCompression::kNone:
      return stored;
    case ChunkCompression::kBz2:
      return bz2_decompress(stored, chunk.size, file.name(), chunk.pos);
    case ChunkCompression::kLz4:
      break;
  }
  return lz4_frame_decompress(stored.data(), stored.size(), chunk.size, file.name(), chunk.pos);
}

// The first `wanted` bytes of a chunk's data: an lz4 chunk is decompressed (and read from the file)
// only that far, a bz2 chunk as far as the blocks that hold them, so the small messages before a
// cloud cost no cloud; uncompressed: all.
Bytes decompress_chunk_prefix(const BagFile& file, const Chunk& chunk, std::size_t wanted) {
  if (chunk.compression == ChunkCompression::kNone || wanted >= chunk.size) return decompress_chunk(file, chunk);
  if (chunk.compression == ChunkCompression::kBz2) {
    Bytes stored(chunk.data_len);
    file.read(chunk.data_pos, stored.data(), stored.size());
    return bz2_decompress(stored, chunk.size, file.name(), chunk.pos, wanted);
  }
  // LZ4 expands every input byte to at least 255/256 of an output byte: this much input suffices.
  const std::size_t stored_bytes = std::min<std::size_t>(chunk.data_len, wanted + wanted / 128 + 4096);
  Bytes stored(stored_bytes);
  file.read(chunk.data_pos, stored.data(), stored.size());
  return lz4_frame_decompress_prefix(stored.data(), stored.size(), wanted, file.name(), chunk.pos);
}

// The last few decompressed chunks (or the first part of one): small messages in time order share
// chunks.
class ChunkCache {
 public:
  std::shared_ptr<const Bytes> find(std::uint64_t chunk) {
    const std::lock_guard lock(mutex_);
    for (auto it = entries_.begin(); it != entries_.end(); ++it) {
      if (it->first == chunk) {
        entries_.splice(entries_.begin(), entries_, it);
        return it->second;
      }
    }
    return nullptr;
  }
  void insert(std::uint64_t chunk, std::shared_ptr<const Bytes> data) {
    const std::lock_guard lock(mutex_);
    for (auto it = entries_.begin(); it != entries_.end(); ++it) {
      if (it->first != chunk) continue;
      if (it->second->size() >= data->size()) return;  // another thread decompressed as much meanwhile
      bytes_ -= it->second->size();                     // a longer part of the chunk replaces a shorter
      entries_.erase(it);
      break;
    }
    bytes_ += data->size();
    entries_.emplace_front(chunk, std::move(data));
    while (entries_.size() > 1 && (entries_.size() > kMaxChunks || bytes_ > kMaxBytes)) {
      bytes_ -= entries_.back().second->size();
      entries_.pop_back();
    }
  }

 private:
  static constexpr std::size_t kMaxChunks = 8;
  static constexpr std::size_t kMaxBytes = 64u << 20;  // the newest chunk stays even if larger
  std::mutex mutex_;
  std::list<std::pair<std::uint64_t, std::shared_ptr<const Bytes>>> entries_;
  std::size_t bytes_ = 0;
};

// ---------------------------------------------------------------------------------------------
// Opening through the index.

ChunkInfo chunk_info_from_record(const Record& r, Source& src) {
  if (r.u32("ver") != 1) r.where.fail("chunk info version " + std::to_string(r.u32("ver")) + " (only 1 is known)");
  ChunkInfo info;
  info.where = r.where;
  info.chunk_pos = r.u64("chunk_pos");
  info.start_ns = r.time_ns("start_time");
  info.end_ns = r.time_ns("end_time");
  const std::uint32_t count = r.u32("count");
  if (r.data_len != std::uint64_t{count} * 8) {
    r.where.fail("chunk info lists " + std::to_string(count) + " connections in " + std::to_string(r.data_len) +
                 " bytes (8 each)");
  }
  const ByteSpan data = src.get(r.data_pos, r.data_len, "chunk info data");
  for (std::uint32_t i = 0; i < count; ++i) info.counts.emplace_back(le32(&data[8 * i]), le32(&data[8 * i + 4]));
  return info;
}

// The index data records behind one chunk: one per connection of its chunk info, in any order.
void read_index_data(Contents& c, FileSource& src, std::uint64_t pos, const ChunkInfo& info, std::uint32_t chunk_id) {
  const Chunk& chunk = c.chunks[chunk_id];
  std::unordered_map<std::uint32_t, std::uint32_t> expected(info.counts.begin(), info.counts.end());
  for (std::size_t k = 0; k < info.counts.size(); ++k) {
    const Record r = expect_record(src, pos, ros1::kOpIndexData, "behind the chunk at byte " + std::to_string(chunk.pos));
    if (r.u32("ver") != 1) r.where.fail("index data version " + std::to_string(r.u32("ver")) + " (only 1 is known)");
    const std::uint32_t connection = r.u32("conn"), count = r.u32("count");
    const auto it = expected.find(connection);
    if (it == expected.end() || it->second != count) {
      r.where.fail("index data for connection " + std::to_string(connection) + " with " + std::to_string(count) +
                   " messages, which the chunk info at " + at_byte(info.where.byte) + " does not list");
    }
    expected.erase(it);
    if (r.data_len != std::uint64_t{count} * kIndexEntryBytes) {
      r.where.fail("index data of " + std::to_string(r.data_len) + " bytes for " + std::to_string(count) + " messages");
    }
    const std::uint32_t topic = topic_of(c, connection, r.where);
    const ByteSpan data = src.get(r.data_pos, r.data_len, "index data");
    for (std::uint32_t i = 0; i < count; ++i) {
      const std::uint8_t* e = &data[kIndexEntryBytes * i];
      const std::uint32_t offset = le32(e + 8);
      if (offset >= chunk.size) r.where.fail("an index entry points past the end of its chunk");
      c.messages[topic].push_back({topic, ros_time_ns(e), chunk_id, offset});
    }
    pos = r.end();
  }
}

// The connection and chunk info records at index_pos. Throws CutOff if the file ends inside them.
std::vector<ChunkInfo> read_index_section(Contents& c, const BagFile& file, std::uint64_t index_pos,
                                          std::uint64_t connections, std::uint64_t chunks) {
  FileSource src(file, file.size());
  std::vector<ChunkInfo> infos;
  std::uint64_t pos = index_pos, seen_connections = 0;
  for (std::uint64_t i = 0; i < connections + chunks; ++i) {
    const Record r = read_record(src, pos);
    if (r.op == ros1::kOpConnection) {
      add_connection(c, r, src);
      ++seen_connections;
    } else if (r.op == ros1::kOpChunkInfo) {
      infos.push_back(chunk_info_from_record(r, src));
    } else {
      r.where.fail("out of place: " + op_name(r.op) + " in the index (connections and chunk infos only)");
    }
    pos = r.end();
  }
  if (seen_connections != connections || infos.size() != chunks) {
    src.at(index_pos).fail("the bag header promises " + std::to_string(connections) + " connections and " +
                           std::to_string(chunks) + " chunks, the index here holds " +
                           std::to_string(seen_connections) + " and " + std::to_string(infos.size()));
  }
  return infos;
}

void load_indexed(Contents& c, const BagFile& file, std::vector<ChunkInfo> infos) {
  std::sort(infos.begin(), infos.end(), [](const ChunkInfo& a, const ChunkInfo& b) { return a.chunk_pos < b.chunk_pos; });
  FileSource src(file, file.size());
  for (const ChunkInfo& info : infos) {
    if (!c.chunks.empty() && info.chunk_pos < c.chunks.back().data_pos + c.chunks.back().data_len) {
      info.where.fail("chunk info points at byte " + std::to_string(info.chunk_pos) + ", inside the previous chunk");
    }
    const Record r = expect_record(src, info.chunk_pos, ros1::kOpChunk, "where a chunk info points (" +
                                                                           at_byte(info.where.byte) + ")");
    c.chunks.push_back(chunk_from_record(r));
    read_index_data(c, src, r.end(), info, static_cast<std::uint32_t>(c.chunks.size() - 1));
    for (const auto& [connection, count] : info.counts) c.topics[topic_of(c, connection, info.where)].message_count += count;
  }
  for (std::size_t i = 0; i < infos.size(); ++i) {
    c.start_ns = i == 0 ? infos[i].start_ns : std::min(c.start_ns, infos[i].start_ns);
    c.end_ns = i == 0 ? infos[i].end_ns : std::max(c.end_ns, infos[i].end_ns);
  }
}

// ---------------------------------------------------------------------------------------------
// Opening without an index: the chunks in file order, up to the last whole record.

// The records of one chunk's data, [begin, end) of `src`. Returns where the last record read
// ends. With `tolerant` (an unfinished chunk), a broken, cut-off or foreign record ends the chunk
// there instead of failing.
std::uint64_t scan_chunk_records(Contents& c, Source& src, std::uint64_t begin, std::uint64_t end,
                                 std::uint32_t chunk_id, bool tolerant) {
  std::uint64_t pos = begin;
  while (pos < end) {
    try {
      const Record r = read_record(src, pos);
      if (r.op == ros1::kOpConnection) {
        add_connection(c, r, src);
      } else if (r.op == ros1::kOpMessageData) {
        const std::uint32_t topic = topic_of(c, r.u32("conn"), r.where);
        c.messages[topic].push_back({topic, r.time_ns("time"), chunk_id, pos - begin});
      } else {
        r.where.fail("out of place: " + op_name(r.op) + " inside a chunk (connections and messages only)");
      }
      pos = r.end();
    } catch (const InputError&) {
      if (!tolerant) throw;
      break;
    }
  }
  return pos;
}

// One chunk met by the scan; returns where the scan goes on. rosbag writes a chunk's header with
// sizes 0 first and rewrites it when the chunk is closed, so a recording that was killed ends in
// a chunk of "0 bytes" followed by its data: uncompressed, its whole records are still usable.
bool is_unfinished(const Chunk& chunk, const Record& r, const BagFile& file) {
  return chunk.data_len == 0 && chunk.size == 0 && r.end() < file.size();
}

std::uint64_t scan_chunk(Contents& c, const BagFile& file, const Record& r, std::string& note) {
  Chunk chunk = chunk_from_record(r);
  const auto id = static_cast<std::uint32_t>(c.chunks.size());
  if (!is_unfinished(chunk, r, file)) {
    c.chunks.push_back(chunk);
    const Bytes data = decompress_chunk(file, chunk);
    ChunkSource src(data, c.chunks[id], file.name());
    scan_chunk_records(c, src, 0, data.size(), id, false);
    return r.end();
  }
  if (chunk.compression != ChunkCompression::kNone) {
    note = "; the unfinished " + std::string(compression_name(chunk.compression)) + " chunk at " +
           at_byte(chunk.pos) + " was not read";
    return r.end();
  }
  c.chunks.push_back(chunk);
  FileSource src(file, file.size());
  const std::uint64_t limit = std::min<std::uint64_t>(file.size(), r.data_pos + UINT32_MAX);
  const std::uint64_t end = scan_chunk_records(c, src, r.data_pos, limit, id, true);
  c.chunks[id].data_len = c.chunks[id].size = static_cast<std::uint32_t>(end - r.data_pos);
  note = "; the unfinished chunk at " + at_byte(chunk.pos) + " was read up to its last whole record";
  return end;
}

// What is left of the record at `pos` that the file ends inside: the fields of its header before
// the end (a field cut in half is left out) and, when its data length is there, where it would end.
struct CutRecord {
  Fields fields;
  std::optional<std::uint64_t> end;
  std::optional<std::uint8_t> op() const {
    const std::string* op = fields.find("op");
    if (op == nullptr || op->size() != 1) return std::nullopt;
    return static_cast<std::uint8_t>((*op)[0]);
  }
};

CutRecord cut_record(const BagFile& file, std::uint64_t pos) {
  CutRecord cut;
  if (pos > file.size() || file.size() - pos < 4) return cut;
  std::uint8_t length[4];
  file.read(pos, length, 4);
  const std::uint64_t header_len = le32(length);
  Bytes header(static_cast<std::size_t>(std::min<std::uint64_t>({header_len, kMaxRecordHeaderBytes, file.size() - pos - 4})));
  file.read(pos + 4, header.data(), header.size());
  (void)parse_fields(header, cut.fields);
  if (header.size() == header_len && file.size() - pos - 4 - header_len >= 4) {
    file.read(pos + 4 + header_len, length, 4);
    cut.end = pos + 8 + header_len + le32(length);
  }
  return cut;
}

// A chunk that the file ends inside: its data is partly lost.
struct CutChunk {
  std::uint64_t pos = 0;           ///< where the chunk record starts
  std::string how;                 ///< what the chunk claims, for the error
  std::uint32_t whole_chunks = 0;  ///< the chunks before it
};

// The chunk (or the record of unknown kind: chunks are what rosbag writes most) the file ends in.
CutChunk cut_chunk(const CutRecord& record, std::uint64_t pos, const Contents& c) {
  CutChunk cut;
  cut.pos = pos;
  cut.whole_chunks = static_cast<std::uint32_t>(c.chunks.size());
  if (!record.op()) {
    cut.how = "(its header is cut off: most likely a chunk)";
  } else {
    const std::string* compression = record.fields.find("compression");
    cut.how = "(" + (compression != nullptr ? *compression : std::string("unknown")) + " compression) " +
              (record.end ? "needs the bytes up to " + std::to_string(*record.end) : std::string("is cut before its data length"));
  }
  return cut;
}

// Exit 2 for a cut chunk unless input.read_cut_off: what is lost, what remains, how to go on.
[[noreturn]] void fail_cut_off(const Contents& c, const BagFile& file, const CutChunk& cut) {
  std::size_t messages = 0;
  std::int64_t first_ns = 0, last_ns = 0;
  for (const auto& refs : c.messages) {
    for (const MessageRef& m : refs) {
      if (m.locator >= cut.whole_chunks) continue;
      first_ns = messages == 0 ? m.log_time_ns : std::min(first_ns, m.log_time_ns);
      last_ns = messages == 0 ? m.log_time_ns : std::max(last_ns, m.log_time_ns);
      ++messages;
    }
  }
  std::string rest;
  if (cut.whole_chunks == 0) {
    rest = "no whole chunk comes before it, so --set input.read_cut_off=true would find no message either";
  } else {
    char span[32];
    std::snprintf(span, sizeof span, "%.1f", static_cast<double>(last_ns - first_ns) / kNsPerSecond);
    rest = "--set input.read_cut_off=true reads the " + std::to_string(cut.whole_chunks) + " whole chunk" +
           (cut.whole_chunks == 1 ? "" : "s") + " before it (" + std::to_string(messages) + " messages over " + span +
           " s of recording) and warns";
  }
  throw InputError(file.name(), at_byte(cut.pos),
                   "cut off mid-chunk: the chunk starting at byte " + std::to_string(cut.pos) + " " + cut.how +
                       ", but the file ends at byte " + std::to_string(file.size()) +
                       " (the recording was not closed, or the file was truncated). `rosbag reindex` cannot recover a "
                       "partial chunk; " + rest);
}

void count_scanned(Contents& c) {
  bool first_message = true;
  for (std::size_t t = 0; t < c.topics.size(); ++t) {
    c.topics[t].message_count = c.messages[t].size();
    for (const MessageRef& m : c.messages[t]) {
      c.start_ns = first_message ? m.log_time_ns : std::min(c.start_ns, m.log_time_ns);
      c.end_ns = first_message ? m.log_time_ns : std::max(c.end_ns, m.log_time_ns);
      first_message = false;
    }
  }
}

// The records after `first` in file order. A file ending inside a chunk (one cut in half, or an
// unfinished one) fails unless options.read_cut_off; ending between chunks or inside the index
// data behind a whole chunk loses no message: a warning says what was read.
void load_scanned(Contents& c, const BagFile& file, std::uint64_t first, const std::string& why, const OpenOptions& options) {
  c.indexed = false;
  FileSource src(file, file.size());
  std::uint64_t pos = first;
  std::string stop, note;
  std::optional<CutChunk> cut;
  while (pos < file.size()) {
    Record r;
    try {
      r = read_record(src, pos);
    } catch (const CutOff& e) {
      stop = problem_of(e);
      const CutRecord record = cut_record(file, pos);
      if (!cut && (!record.op() || *record.op() == ros1::kOpChunk)) cut = cut_chunk(record, pos, c);
      break;
    } catch (const InputError& e) {
      stop = problem_of(e);
      break;
    }
    if (r.op == ros1::kOpChunk) {
      if (!cut && is_unfinished(chunk_from_record(r), r, file)) {
        cut = CutChunk{pos, "was never finished (its header still says 0 bytes)", static_cast<std::uint32_t>(c.chunks.size())};
      }
      pos = scan_chunk(c, file, r, note);
      continue;
    }
    if (r.op == ros1::kOpConnection) {
      add_connection(c, r, src);
    } else if (r.op != ros1::kOpIndexData && r.op != ros1::kOpChunkInfo) {
      r.where.fail("out of place: " + op_name(r.op) + " between chunks");
    }
    pos = r.end();
  }
  if (cut && !options.read_cut_off) fail_cut_off(c, file, *cut);
  c.warnings.push_back("not indexed (" + why + "): read " + std::to_string(c.chunks.size()) +
                       " chunks in file order, " +
                       (stop.empty() ? "to the end of the file" : "stopped at " + at_byte(pos) + " (" + stop + ")") + note +
                       (cut ? "; read because input.read_cut_off is true" : ""));
  count_scanned(c);
}

Contents load(const BagFile& file, const OpenOptions& options) {
  FileSource src(file, file.size());
  if (file.size() < ros1::kMagic.size() ||
      std::memcmp(src.get(0, ros1::kMagic.size(), "the magic").data(), ros1::kMagic.data(), ros1::kMagic.size()) != 0) {
    throw InputError(file.name(), "byte 0", "not a ROS 1 bag v2.0: it does not start with \"#ROSBAG V2.0\"");
  }
  const Record header = expect_record(src, ros1::kMagic.size(), ros1::kOpBagHeader, "at the start of the bag");
  const std::uint64_t index_pos = header.u64("index_pos");
  const std::uint32_t connections = header.u32("conn_count"), chunks = header.u32("chunk_count");
  Contents c;
  if (index_pos == 0) {
    load_scanned(c, file, header.end(), "index_pos is 0: the recording was not closed", options);
  } else if (index_pos > file.size() || (index_pos == file.size() && connections + chunks > 0)) {
    load_scanned(c, file, header.end(),
                 "its index at " + at_byte(index_pos) + " lies past the end of the file at " + at_byte(file.size()) +
                     ": the file is cut off",
                 options);
  } else if (index_pos < header.end()) {
    header.where.fail("index_pos " + std::to_string(index_pos) + " points into the bag header");
  } else {
    std::vector<ChunkInfo> infos;
    try {
      infos = read_index_section(c, file, index_pos, connections, chunks);
    } catch (const CutOff&) {
      c = Contents{};
      load_scanned(c, file, header.end(), "its index at " + at_byte(index_pos) + " is cut off", options);
      return c;
    }
    load_indexed(c, file, std::move(infos));
  }
  return c;
}

class Ros1BagReader final : public BagReader {
 public:
  Ros1BagReader(const std::filesystem::path& path, const OpenOptions& options)
      : path_(path), file_(path), c_(load(file_, options)) {
    for (auto& refs : c_.messages) {
      std::sort(refs.begin(), refs.end(), [](const MessageRef& a, const MessageRef& b) {
        return std::tie(a.log_time_ns, a.locator, a.locator2) < std::tie(b.log_time_ns, b.locator, b.locator2);
      });
    }
  }

  const std::vector<Topic>& topics() const override { return c_.topics; }
  std::vector<MessageRef> messages(std::uint32_t topic) const override {
    if (topic >= c_.messages.size()) throw std::out_of_range("no topic " + std::to_string(topic) + " in " + file_.name());
    return c_.messages[topic];
  }
  std::vector<std::uint8_t> read(const MessageRef& ref) const override;
  std::vector<std::uint8_t> read_prefix(const MessageRef& ref, std::size_t max_bytes) const override;
  SharedMessage read_shared(const MessageRef& ref) const override;
  std::string describe() const override;
  const std::vector<std::string>& warnings() const override { return c_.warnings; }
  std::int64_t start_time_ns() const override { return c_.start_ns; }
  std::int64_t end_time_ns() const override { return c_.end_ns; }
  const std::filesystem::path& path() const override { return path_; }

 private:
  std::shared_ptr<const Bytes> chunk_data(std::uint64_t locator, std::uint64_t until) const;
  SharedMessage message_in_chunk(const MessageRef& ref, std::uint64_t probe) const;
  static std::optional<std::uint64_t> record_end(const Bytes& data, std::uint64_t pos);
  const Chunk& chunk_of(const MessageRef& ref) const;

  Record message_record(Source& src, std::uint64_t pos, const MessageRef& ref) const {
    const Record r = expect_record(src, pos, ros1::kOpMessageData, "where the index points");
    if (topic_of(c_, r.u32("conn"), r.where) != ref.topic) r.where.fail("the index points at a message of another topic");
    return r;
  }

  std::filesystem::path path_;
  BagFile file_;
  Contents c_;
  mutable ChunkCache cache_;
};

const Chunk& Ros1BagReader::chunk_of(const MessageRef& ref) const {
  if (ref.topic >= c_.topics.size() || ref.locator >= c_.chunks.size()) {
    throw std::out_of_range("a MessageRef that is not from " + file_.name());
  }
  return c_.chunks[ref.locator];
}

// A compressed chunk's data reaching at least `until` bytes: from the cache, else decompressed as
// far as that (growing geometrically, all of it once most is needed), and cached.
std::shared_ptr<const Bytes> Ros1BagReader::chunk_data(std::uint64_t locator, std::uint64_t until) const {
  constexpr std::uint64_t kMinPart = 64 * 1024;
  const Chunk& chunk = c_.chunks[locator];
  std::shared_ptr<const Bytes> data = cache_.find(locator);
  if (data != nullptr && (data->size() >= until || data->size() >= chunk.size)) return data;
  std::uint64_t want = std::max({until, kMinPart, data != nullptr ? 2 * data->size() : 0});
  if (2 * want >= chunk.size) want = chunk.size;
  // Two threads missing the same chunk at once both decompress it: rare, and still correct.
  data = std::make_shared<const Bytes>(decompress_chunk_prefix(file_, chunk, static_cast<std::size_t>(want)));
  cache_.insert(locator, data);
  return data;
}

// Where the record at `pos` ends, from its two lengths, when `data` holds them.
std::optional<std::uint64_t> Ros1BagReader::record_end(const Bytes& data, std::uint64_t pos) {
  if (pos > data.size() || data.size() - pos < 4) return std::nullopt;
  const std::uint64_t header_len = le32(data.data() + pos);
  if (header_len > kMaxRecordHeaderBytes || data.size() - pos - 4 < header_len + 4) return std::nullopt;
  return pos + 8 + header_len + le32(data.data() + pos + 4 + header_len);
}

std::vector<std::uint8_t> Ros1BagReader::read(const MessageRef& ref) const {
  const Chunk& chunk = chunk_of(ref);
  if (chunk.compression == ChunkCompression::kNone) {
    // Straight from the file: a 3 MB point cloud costs one read of its bytes.
    FileSource src(file_, chunk.data_pos + chunk.data_len);
    const Record r = message_record(src, chunk.data_pos + ref.locator2, ref);
    Message out(r.data_len);
    if (r.data_len > kReadAheadBytes) {
      file_.read(r.data_pos, out.data(), out.size());
    } else {
      const ByteSpan data = src.get(r.data_pos, r.data_len, "message data");
      std::copy(data.begin(), data.end(), out.begin());
    }
    return out;
  }
  const SharedMessage m = message_in_chunk(ref, ref.locator2 + kReadAheadBytes);
  return Message(m.bytes.begin(), m.bytes.end());
}

BagReader::SharedMessage Ros1BagReader::read_shared(const MessageRef& ref) const {
  const Chunk& chunk = chunk_of(ref);
  if (chunk.compression == ChunkCompression::kNone) return BagReader::read_shared(ref);  // one read, no chunk
  // This is the read of a cloud, which fills its chunk: a bz2 chunk not at hand is decompressed
  // whole at once (a first look at the record's header would decode its first block twice).
  const bool whole = chunk.compression == ChunkCompression::kBz2;
  return message_in_chunk(ref, whole ? chunk.size : ref.locator2 + kReadAheadBytes);
}

// A message of a compressed chunk: the chunk as far as `probe` (enough for the record's header),
// then as far as the record's end: reading the INS messages before a cloud does not decompress
// the cloud.
BagReader::SharedMessage Ros1BagReader::message_in_chunk(const MessageRef& ref, std::uint64_t probe) const {
  const Chunk& chunk = chunk_of(ref);
  std::shared_ptr<const Bytes> data = chunk_data(ref.locator, probe);
  data = chunk_data(ref.locator, record_end(*data, ref.locator2).value_or(chunk.size));
  ChunkSource src(*data, chunk, file_.name());
  const Record r = message_record(src, ref.locator2, ref);
  return {data, src.get(r.data_pos, r.data_len, "message data")};
}

std::vector<std::uint8_t> Ros1BagReader::read_prefix(const MessageRef& ref, std::size_t max_bytes) const {
  const Chunk& chunk = chunk_of(ref);
  if (chunk.compression == ChunkCompression::kNone) {
    FileSource src(file_, chunk.data_pos + chunk.data_len);
    const Record r = message_record(src, chunk.data_pos + ref.locator2, ref);
    Message out(std::min<std::size_t>(r.data_len, max_bytes));
    file_.read(r.data_pos, out.data(), out.size());
    return out;
  }
  std::shared_ptr<const Bytes> data = chunk_data(ref.locator, ref.locator2 + kReadAheadBytes + max_bytes);
  const std::optional<std::uint64_t> end = record_end(*data, ref.locator2);
  if (!end) {  // no header where the index points: the whole read says what is wrong
    Message all = read(ref);
    all.resize(std::min(all.size(), max_bytes));
    return all;
  }
  if (*end > data->size()) {  // the record is longer than what was decompressed: check it on its header
    const std::uint64_t header_len = le32(data->data() + ref.locator2);
    const std::uint64_t data_pos = ref.locator2 + 8 + header_len;
    data = chunk_data(ref.locator, data_pos + max_bytes);
    Fields fields;
    const std::string problem = parse_fields(ByteSpan(*data).subspan(ref.locator2 + 4, header_len), fields);
    const Where where = ChunkSource(*data, chunk, file_.name()).at(ref.locator2);
    const std::string* op = fields.find("op");
    if (!problem.empty() || op == nullptr || *op != std::string(1, static_cast<char>(ros1::kOpMessageData))) {
      where.fail("where the index points there is no message data record" + (problem.empty() ? "" : ": " + problem));
    }
    const std::string* conn = fields.find("conn");
    if (conn == nullptr || conn->size() != 4 || topic_of(c_, le32(reinterpret_cast<const std::uint8_t*>(conn->data())), where) != ref.topic) {
      where.fail("the index points at a message of another topic");
    }
    const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(max_bytes, data->size() - data_pos));
    return Message(data->begin() + static_cast<std::ptrdiff_t>(data_pos), data->begin() + static_cast<std::ptrdiff_t>(data_pos + n));
  }
  ChunkSource src(*data, chunk, file_.name());
  const Record r = message_record(src, ref.locator2, ref);
  const ByteSpan bytes = src.get(r.data_pos, std::min<std::size_t>(r.data_len, max_bytes), "message data");
  return Message(bytes.begin(), bytes.end());
}

std::string Ros1BagReader::describe() const {
  bool used[3] = {false, false, false};
  for (const Chunk& chunk : c_.chunks) used[static_cast<int>(chunk.compression)] = true;
  static const char* const kNames[3] = {"uncompressed", "bz2", "lz4"};
  std::string kinds;
  for (int i = 0; i < 3; ++i) {
    if (used[i]) kinds += (kinds.empty() ? "" : "+") + std::string(kNames[i]);
  }
  return std::string("ROS 1 bag v2.0, ") + (kinds.empty() ? "no" : kinds) + " chunks, " +
         (c_.indexed ? "indexed" : "not indexed (scanned)");
}

}  // namespace

std::unique_ptr<BagReader> open_ros1_bag(const std::filesystem::path& path, const OpenOptions& options) {
  return std::make_unique<Ros1BagReader>(path, options);
}

bool is_ros1_bag(std::string_view first_bytes) { return first_bytes.substr(0, ros1::kMagic.size()) == ros1::kMagic; }

}  // namespace insalign::io::bag
