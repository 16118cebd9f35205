// MCAP reader: footer + summary on open (or a streamed scan when there is no summary), message
// index records on the first messages() call, one chunk pread + decompression per read() miss.
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zstd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <limits>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <span>
#include <tuple>
#include <unordered_map>
#include <utility>

#include "core/errors.hpp"
#include "recording/byte_buffer.hpp"
#include "recording/crc32.hpp"
#include "recording/lz4_frame.hpp"
#include "recording/mcap.hpp"

namespace insalign::io::bag {

namespace mcap_format {

// Chunk and data-section CRCs cover gigabytes: the carry-less-multiply CRC (crc32.hpp).
std::uint32_t crc32_update(std::uint32_t crc, const std::uint8_t* data, std::size_t size) {
  return crc32_ieee(crc, data, size);
}

}  // namespace mcap_format

bool is_mcap(std::string_view first_bytes) { return first_bytes.substr(0, 8) == mcap_format::kMagic; }

namespace {

namespace fs = std::filesystem;
using namespace mcap_format;
using Bytes = ByteBuffer;                      // file pieces and chunk records: not zeroed
using Message = std::vector<std::uint8_t>;     // what read() returns

std::string at_byte(std::uint64_t offset) { return "byte " + std::to_string(offset); }

// Little-endian fields of one record's content; running past its end names the record's offset.
class Cursor {
 public:
  Cursor(const std::uint8_t* data, std::size_t size, const std::string& file, std::uint64_t record_offset,
         const char* record)
      : data_(data), size_(size), file_(file), record_offset_(record_offset), record_(record) {}

  std::uint8_t u8() { return *take(1); }
  std::uint16_t u16() { return static_cast<std::uint16_t>(le(take(2), 2)); }
  std::uint32_t u32() { return static_cast<std::uint32_t>(le(take(4), 4)); }
  std::uint64_t u64() { return le(take(8), 8); }
  std::string str() {
    const std::uint32_t n = u32();
    const std::uint8_t* p = take(n);
    return {reinterpret_cast<const char*>(p), n};
  }
  const std::uint8_t* take(std::uint64_t n) {
    if (n > size_ - pos_) fail(std::string(record_) + " record is truncated: a field runs past the record's end");
    const std::uint8_t* p = data_ + pos_;
    pos_ += static_cast<std::size_t>(n);
    return p;
  }
  /// A sub-cursor over a uint32 length-prefixed map or array.
  Cursor sub32() {
    const std::uint32_t n = u32();
    return {take(n), n, file_, record_offset_, record_};
  }
  std::size_t remaining() const { return size_ - pos_; }
  [[noreturn]] void fail(const std::string& what) const { throw InputError(file_, at_byte(record_offset_), what); }

 private:
  static std::uint64_t le(const std::uint8_t* p, int n) {
    std::uint64_t v = 0;
    for (int i = n - 1; i >= 0; --i) v = (v << 8) | p[i];
    return v;
  }
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
  const std::string& file_;
  std::uint64_t record_offset_;
  const char* record_;
};

// pread() access: no shared file position, so read() is safe from many threads.
class File {
 public:
  explicit File(const fs::path& path) : name_(path.string()) {
    std::error_code ec;
    if (!fs::is_regular_file(path, ec)) {
      throw InputError(name_, "", fs::exists(path, ec) ? "not a regular file" : "file not found");
    }
    fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    struct stat st {};
    if (fd_ < 0 || ::fstat(fd_, &st) != 0) throw InputError(name_, "", std::string("cannot open: ") + std::strerror(errno));
    size_ = static_cast<std::uint64_t>(st.st_size);
  }
  ~File() {
    if (fd_ >= 0) ::close(fd_);
  }
  File(const File&) = delete;
  File& operator=(const File&) = delete;

  std::uint64_t size() const { return size_; }
  const std::string& name() const { return name_; }

  /// `n` bytes at `offset`, all inside the file, or InputError naming `record_offset`.
  Bytes read(std::uint64_t offset, std::uint64_t n, std::uint64_t record_offset) const {
    if (offset > size_ || n > size_ - offset) {
      throw InputError(name_, at_byte(record_offset), "record runs past the end of the file (" + std::to_string(size_) +
                                                          " bytes)");
    }
    Bytes out(static_cast<std::size_t>(n));
    for (std::size_t done = 0; done < out.size();) {
      const ssize_t got = ::pread(fd_, out.data() + done, out.size() - done, static_cast<off_t>(offset + done));
      if (got < 0 && errno == EINTR) continue;
      if (got <= 0) throw InputError(name_, at_byte(offset + done), std::string("read failed: ") + std::strerror(errno));
      done += static_cast<std::size_t>(got);
    }
    return out;
  }

 private:
  std::string name_;
  int fd_ = -1;
  std::uint64_t size_ = 0;
};

struct SchemaRecord {
  std::string name, encoding, data;
};

struct ChannelRecord {
  std::uint16_t schema_id = 0;
  std::string topic, message_encoding;
  std::map<std::string, std::string> metadata;
};

/// A chunk as its chunk index (or, streamed, its own record) describes it.
struct ChunkLocation {
  std::uint64_t offset = 0, length = 0;  ///< the whole chunk record, opcode and length included
  std::vector<std::pair<std::uint16_t, std::uint64_t>> index_offsets;  ///< channel -> message index record
  std::uint64_t index_length = 0;
  std::string compression;
  std::uint64_t uncompressed_size = 0;
};

struct Statistics {
  std::uint64_t message_count = 0, start_ns = 0, end_ns = 0;
  std::map<std::uint16_t, std::uint64_t> channel_counts;
};

struct ChunkHeader {
  std::uint64_t uncompressed_size = 0;
  std::uint32_t crc = 0;
  std::string compression;
  const std::uint8_t* records = nullptr;
  std::uint64_t records_size = 0;
};

struct MessageHeader {
  std::uint16_t channel = 0;
  std::uint64_t log_time_ns = 0;
};

/// A message found while indexing, with its place in the file for the "ties in file order" rule.
struct Found {
  std::uint16_t channel;
  std::uint64_t log_time_ns;
  std::uint64_t file_pos, inner;  ///< the record (top level) or its chunk, and its offset inside
  std::uint64_t locator, locator2;
};

SchemaRecord parse_schema(Cursor c, std::uint16_t& id) {
  SchemaRecord s;
  id = c.u16();
  s.name = c.str();
  s.encoding = c.str();
  s.data = c.str();
  return s;
}

ChannelRecord parse_channel(Cursor c, std::uint16_t& id) {
  ChannelRecord ch;
  id = c.u16();
  ch.schema_id = c.u16();
  ch.topic = c.str();
  ch.message_encoding = c.str();
  Cursor m = c.sub32();
  while (m.remaining() > 0) {
    std::string key = m.str();
    ch.metadata[std::move(key)] = m.str();
  }
  return ch;
}

ChunkLocation parse_chunk_index(Cursor c) {
  ChunkLocation loc;
  (void)c.u64();  // message_start_time
  (void)c.u64();  // message_end_time
  loc.offset = c.u64();
  loc.length = c.u64();
  Cursor m = c.sub32();
  while (m.remaining() > 0) {
    const std::uint16_t channel = m.u16();
    loc.index_offsets.emplace_back(channel, m.u64());
  }
  loc.index_length = c.u64();
  loc.compression = c.str();
  (void)c.u64();  // compressed_size
  loc.uncompressed_size = c.u64();
  return loc;
}

Statistics parse_statistics(Cursor c) {
  Statistics s;
  s.message_count = c.u64();
  (void)c.u16();  // schema_count
  (void)c.u32();  // channel_count
  (void)c.u32();  // attachment_count
  (void)c.u32();  // metadata_count
  (void)c.u32();  // chunk_count
  s.start_ns = c.u64();
  s.end_ns = c.u64();
  Cursor m = c.sub32();
  while (m.remaining() > 0) {
    const std::uint16_t channel = m.u16();
    s.channel_counts[channel] = m.u64();
  }
  return s;
}

ChunkHeader parse_chunk(Cursor c) {
  ChunkHeader h;
  (void)c.u64();  // message_start_time
  (void)c.u64();  // message_end_time
  h.uncompressed_size = c.u64();
  h.crc = c.u32();
  h.compression = c.str();
  h.records_size = c.u64();
  h.records = c.take(h.records_size);
  return h;
}

MessageHeader parse_message_header(Cursor c) {
  MessageHeader m;
  m.channel = c.u16();
  (void)c.u32();  // sequence
  m.log_time_ns = c.u64();
  return m;
}

bool supported_compression(const std::string& name) { return name.empty() || name == "zstd" || name == "lz4"; }

[[noreturn]] void unsupported_compression(const std::string& file, std::uint64_t offset, const std::string& name) {
  throw InputError(file, at_byte(offset),
                   "chunk compression '" + name + "' is not supported (MCAP chunks: uncompressed, zstd or lz4)");
}

struct ZstdContext {
  ZSTD_DCtx* ctx = ZSTD_createDCtx();
  ~ZstdContext() { ZSTD_freeDCtx(ctx); }
  ZstdContext() = default;
  ZstdContext(const ZstdContext&) = delete;
  ZstdContext& operator=(const ZstdContext&) = delete;
};

// One context per thread, reused from chunk to chunk (creating one per chunk allocates its
// window buffer again each time).
ZSTD_DCtx* thread_zstd_context() {
  thread_local ZstdContext z;
  return z.ctx;
}

// A chunk whose zstd frame states the size its record claims, and not an absurd one, is decoded
// in one call straight into its output: no window buffer and no copy out of it, about a third of
// the streaming decoder's time on a point cloud. Anything else goes the streaming way below.
std::optional<Bytes> zstd_decompress_whole(const ChunkHeader& h, const std::string& file, std::uint64_t offset) {
  constexpr std::uint64_t kMaxOneShotBytes = std::uint64_t(256) << 20;
  const unsigned long long stated = ZSTD_getFrameContentSize(h.records, static_cast<std::size_t>(h.records_size));
  if (stated != h.uncompressed_size || stated > kMaxOneShotBytes) return std::nullopt;
  Bytes out(static_cast<std::size_t>(stated));
  const std::size_t n = ZSTD_decompressDCtx(thread_zstd_context(), out.data(), out.size(), h.records,
                                            static_cast<std::size_t>(h.records_size));
  if (ZSTD_isError(n)) {
    throw InputError(file, at_byte(offset), std::string("corrupt zstd chunk: ") + ZSTD_getErrorName(n));
  }
  if (n != out.size()) {
    throw InputError(file, at_byte(offset), "zstd chunk decompresses to " + std::to_string(n) + " bytes, its record claims " +
                                                std::to_string(h.uncompressed_size));
  }
  return out;
}

// Streaming, with an output that grows as data really comes out: a corrupt uncompressed_size
// cannot make us allocate gigabytes up front.
Bytes zstd_decompress(const ChunkHeader& h, const std::string& file, std::uint64_t offset) {
  if (std::optional<Bytes> whole = zstd_decompress_whole(h, file, offset)) return std::move(*whole);
  const std::uint64_t expected = h.uncompressed_size;
  const std::uint64_t first = std::min<std::uint64_t>(expected, h.records_size * 8 + (1u << 20));
  Bytes out(static_cast<std::size_t>(first) + 1);  // +1: room to notice more data than expected
  ZstdContext z;
  ZSTD_inBuffer in{h.records, static_cast<std::size_t>(h.records_size), 0};
  std::size_t produced = 0, pending = 1;
  while (in.pos < in.size || pending != 0) {
    ZSTD_outBuffer ob{out.data(), out.size(), produced};
    const std::size_t in_before = in.pos;
    pending = ZSTD_decompressStream(z.ctx, &ob, &in);
    if (ZSTD_isError(pending)) {
      throw InputError(file, at_byte(offset), std::string("corrupt zstd chunk: ") + ZSTD_getErrorName(pending));
    }
    const bool progressed = ob.pos != produced || in.pos != in_before;
    produced = ob.pos;
    if (produced > expected) break;
    if (produced == out.size()) {
      out.resize(static_cast<std::size_t>(std::min<std::uint64_t>(expected + 1, std::uint64_t(out.size()) * 2)));
    } else if (!progressed) {
      throw InputError(file, at_byte(offset), "zstd chunk ends in the middle of a frame (truncated)");
    }
  }
  if (produced != expected) {
    throw InputError(file, at_byte(offset),
                     "zstd chunk decompresses to " + std::string(produced > expected ? "more than " : "") +
                         std::to_string(produced) + " bytes, its record claims " + std::to_string(expected));
  }
  out.resize(produced);
  return out;
}

/// The chunk's records, decompressed and (check_crc) CRC-checked. `offset`: the chunk record,
/// for errors.
Bytes decompress_chunk(const ChunkHeader& h, const std::string& file, std::uint64_t offset, bool check_crc = true) {
  Bytes out;
  if (h.compression.empty()) {
    if (h.records_size != h.uncompressed_size) {
      throw InputError(file, at_byte(offset), "uncompressed chunk holds " + std::to_string(h.records_size) +
                                                  " bytes but claims " + std::to_string(h.uncompressed_size));
    }
    out.assign(h.records, h.records + h.records_size);
  } else if (h.compression == "zstd") {
    out = zstd_decompress(h, file, offset);
  } else if (h.compression == "lz4") {
    out = lz4_frame_decompress(h.records, static_cast<std::size_t>(h.records_size),
                               static_cast<std::size_t>(h.uncompressed_size), file, offset);
  } else {
    unsupported_compression(file, offset, h.compression);
  }
  if (h.crc != 0 && check_crc) {
    const std::uint32_t crc = crc32_update(0, out.data(), out.size());
    if (crc != h.crc) {
      throw InputError(file, at_byte(offset),
                       "chunk CRC mismatch (stored " + std::to_string(h.crc) + ", computed " + std::to_string(crc) +
                           "): the chunk is corrupt");
    }
  }
  return out;
}

// Incremental zstd decoding into a bounded output, for the first bytes of a chunk. (lz4 chunks
// go through lz4_frame_decompress_prefix, which stops inside a block: LZ4F's streaming decoder
// decodes whole blocks of up to 4 MB, so the INS messages before a cloud cost the cloud.)
class ZstdPrefixDecoder {
 public:
  ZstdPrefixDecoder(const std::string& file, std::uint64_t offset) : z_(ZSTD_createDCtx()), file_(file), offset_(offset) {
    if (z_ == nullptr) throw std::bad_alloc();
  }
  ~ZstdPrefixDecoder() { ZSTD_freeDCtx(z_); }
  ZstdPrefixDecoder(const ZstdPrefixDecoder&) = delete;
  ZstdPrefixDecoder& operator=(const ZstdPrefixDecoder&) = delete;

  /// Decodes `piece` (the next compressed bytes) into out[produced..]; returns the new count.
  std::size_t feed(const Bytes& piece, Bytes& out, std::size_t produced) {
    for (std::size_t in_pos = 0; in_pos < piece.size() && produced < out.size();) {
      ZSTD_inBuffer in{piece.data(), piece.size(), in_pos};
      ZSTD_outBuffer ob{out.data(), out.size(), produced};
      const std::size_t r = ZSTD_decompressStream(z_, &ob, &in);
      if (ZSTD_isError(r)) throw InputError(file_, at_byte(offset_), std::string("corrupt zstd chunk: ") + ZSTD_getErrorName(r));
      const std::size_t used = in.pos - in_pos, made = ob.pos - produced;
      in_pos += used;
      produced += made;
      if (used == 0 && made == 0) break;  // the frame is over
    }
    return produced;
  }

 private:
  ZSTD_DCtx* z_;
  const std::string& file_;
  std::uint64_t offset_;
};

/// Calls on(opcode, content, content_size, record_offset) for each record of a decompressed chunk.
template <typename OnRecord>
void for_each_record_in_chunk(const Bytes& records, const std::string& file, std::uint64_t chunk_offset, OnRecord on) {
  std::size_t pos = 0;
  while (pos < records.size()) {
    if (records.size() - pos < kRecordHeaderBytes) {
      throw InputError(file, at_byte(chunk_offset), "chunk ends inside a record header (at byte " + std::to_string(pos) +
                                                        " of its records)");
    }
    Cursor head(records.data() + pos, kRecordHeaderBytes, file, chunk_offset, "chunk");
    const std::uint8_t opcode = head.u8();
    const std::uint64_t length = head.u64();
    if (length > records.size() - pos - kRecordHeaderBytes) {
      throw InputError(file, at_byte(chunk_offset), "a record inside the chunk (at byte " + std::to_string(pos) +
                                                        " of its records) runs past the chunk's end");
    }
    on(opcode, records.data() + pos + kRecordHeaderBytes, static_cast<std::size_t>(length), std::uint64_t(pos));
    pos += kRecordHeaderBytes + static_cast<std::size_t>(length);
  }
}

/// Recently decompressed chunks, least recently used evicted first; bounded in count and bytes.
class ChunkCache {
 public:
  std::shared_ptr<const Bytes> find(std::size_t chunk) {
    const std::lock_guard<std::mutex> lock(mutex_);
    for (std::size_t i = 0; i < entries_.size(); ++i) {
      if (entries_[i].first != chunk) continue;
      std::rotate(entries_.begin() + static_cast<std::ptrdiff_t>(i), entries_.begin() + static_cast<std::ptrdiff_t>(i) + 1,
                  entries_.end());
      return entries_.back().second;
    }
    return nullptr;
  }
  void insert(std::size_t chunk, std::shared_ptr<const Bytes> data) {
    const std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& e : entries_) {
      if (e.first == chunk) return;  // another thread was first
    }
    bytes_ += data->size();
    entries_.emplace_back(chunk, std::move(data));
    while (entries_.size() > 1 && (entries_.size() > kMaxChunks || bytes_ > kMaxBytes)) {
      bytes_ -= entries_.front().second->size();
      entries_.erase(entries_.begin());
    }
  }

 private:
  static constexpr std::size_t kMaxChunks = 8;
  static constexpr std::size_t kMaxBytes = std::size_t(192) << 20;
  std::mutex mutex_;
  std::vector<std::pair<std::size_t, std::shared_ptr<const Bytes>>> entries_;
  std::size_t bytes_ = 0;
};

class McapReader final : public BagReader {
 public:
  explicit McapReader(const fs::path& path);

  const std::vector<Topic>& topics() const override { return topics_; }
  std::vector<MessageRef> messages(std::uint32_t topic) const override;
  std::vector<std::uint8_t> read(const MessageRef& ref) const override;
  std::vector<std::uint8_t> read_prefix(const MessageRef& ref, std::size_t max_bytes) const override;
  SharedMessage read_shared(const MessageRef& ref) const override;
  void read_batch(const std::vector<BatchRequest>& requests, const BatchHandler& on) const override;
  std::string describe() const override;
  const std::vector<std::string>& warnings() const override { return warnings_; }
  std::int64_t start_time_ns() const override { return start_ns_; }
  std::int64_t end_time_ns() const override { return end_ns_; }
  const fs::path& path() const override { return path_; }

 private:
  const std::string& name() const { return file_.name(); }
  std::uint64_t read_header();
  struct StreamPlan {
    std::string why;
    std::uint64_t end;  ///< stream up to here
    bool complete;      ///< the file has its footer: a record running past `end` is corruption
  };
  std::optional<StreamPlan> open_indexed();
  void parse_summary(const Bytes& summary, std::uint64_t summary_start);
  void check_chunk_indexes(std::uint64_t data_end) const;
  void stream(std::uint64_t from, std::uint64_t end, bool complete, const std::string& why);
  bool stream_record(std::uint8_t opcode, std::uint64_t offset, std::uint64_t length);
  void stream_chunk(std::uint64_t offset, std::uint64_t length);
  void add_schema(const std::uint8_t* content, std::size_t size, std::uint64_t offset);
  void add_channel(const std::uint8_t* content, std::size_t size, std::uint64_t offset);
  void build_topics();
  void build_index() const;
  void read_message_indexes(std::size_t chunk, std::vector<Found>& found) const;
  void scan_chunk(std::size_t chunk, const Bytes& records, std::vector<Found>& found) const;
  void scan_top_level_messages(std::vector<Found>& found) const;
  std::shared_ptr<const Bytes> add_unindexed_chunk(std::uint64_t offset, std::uint64_t length) const;
  void set_refs(std::vector<Found> found) const;
  std::shared_ptr<const Bytes> chunk_records(std::size_t chunk) const;
  Bytes chunk_prefix(std::size_t chunk, std::uint64_t want) const;
  void check_readable(const MessageRef& ref) const;
  Message read_bytes(const MessageRef& ref, std::uint64_t max_bytes) const;
  Message from_records(const Bytes& records, std::size_t chunk, const MessageRef& ref, std::uint64_t max_bytes) const;
  std::uint64_t needed_end(std::size_t chunk, std::uint64_t inner, std::uint64_t max_bytes) const;
  void serve_chunk(const std::vector<BatchRequest>& requests, const std::vector<std::size_t>& run,
                   const BatchHandler& on) const;
  bool take_crc_check(std::size_t chunk) const;
  Message message_data(const std::uint8_t* record, std::uint64_t available, std::uint64_t offset, std::uint32_t topic,
                     std::uint64_t max_bytes) const;
  std::span<const std::uint8_t> message_view(const std::uint8_t* record, std::uint64_t available, std::uint64_t offset,
                                             std::uint32_t topic, std::uint64_t max_bytes) const;
  Bytes load_chunk(std::size_t chunk) const;
  std::uint32_t topic_of(std::uint16_t channel, std::uint64_t offset) const;

  fs::path path_;
  File file_;
  std::string profile_;
  std::uint64_t data_start_ = 0;  ///< first record after the header
  std::uint64_t data_end_ = 0;    ///< end of the data section (summary start, or where streaming stopped)
  bool indexed_ = false;
  std::map<std::uint16_t, SchemaRecord> schemas_;
  std::map<std::uint16_t, ChannelRecord> channels_;
  mutable std::vector<ChunkLocation> chunks_;  ///< grows while indexing only if some chunk has no chunk index
  std::optional<Statistics> stats_;
  std::vector<Found> streamed_;  ///< messages found while streaming (no summary)
  std::vector<Topic> topics_;
  std::vector<std::string> topic_encoding_;  ///< each topic's MCAP message_encoding
  std::unordered_map<std::uint16_t, std::uint32_t> topic_of_channel_;
  std::vector<std::string> warnings_;
  std::int64_t start_ns_ = 0, end_ns_ = 0;
  mutable std::once_flag index_once_;
  mutable std::vector<std::vector<MessageRef>> refs_;
  mutable std::vector<std::vector<std::uint64_t>> message_starts_;  ///< per chunk, sorted: where a message ends
  mutable ChunkCache cache_;
  mutable std::mutex crc_mutex_;
  mutable std::vector<char> crc_checked_;  ///< per chunk: its CRC was verified once this run
};

McapReader::McapReader(const fs::path& path) : path_(path), file_(path) {
  data_start_ = read_header();
  if (const std::optional<StreamPlan> plan = open_indexed()) {
    schemas_.clear();  // a summary too poor to use may have left some behind
    channels_.clear();
    chunks_.clear();
    stats_.reset();
    stream(data_start_, plan->end, plan->complete, plan->why);
  }
  build_topics();
  if (!indexed_ || !stats_ || stats_->channel_counts.empty()) {
    std::call_once(index_once_, [this] { build_index(); });
    for (std::size_t t = 0; t < topics_.size(); ++t) topics_[t].message_count = refs_[t].size();
    bool any = false;
    for (const auto& refs : refs_) {
      for (const MessageRef& r : refs) {
        start_ns_ = any ? std::min(start_ns_, r.log_time_ns) : r.log_time_ns;
        end_ns_ = any ? std::max(end_ns_, r.log_time_ns) : r.log_time_ns;
        any = true;
      }
    }
  } else if (stats_->message_count > 0) {
    start_ns_ = static_cast<std::int64_t>(stats_->start_ns);
    end_ns_ = static_cast<std::int64_t>(stats_->end_ns);
  }
}

/// Checks the magic and reads the header record; returns where the data section starts.
std::uint64_t McapReader::read_header() {
  const Bytes head = file_.read(0, std::min<std::uint64_t>(file_.size(), kMagic.size() + kRecordHeaderBytes), 0);
  if (!is_mcap({reinterpret_cast<const char*>(head.data()), head.size()})) {
    throw InputError(name(), at_byte(0), "not an MCAP file (bad magic: expected 0x89 \"MCAP0\\r\\n\")");
  }
  if (head.size() < kMagic.size() + kRecordHeaderBytes) {
    throw InputError(name(), at_byte(kMagic.size()), "the file ends before its header record (truncated)");
  }
  Cursor c(head.data() + kMagic.size(), kRecordHeaderBytes, name(), kMagic.size(), "header");
  const std::uint8_t opcode = c.u8();
  const std::uint64_t length = c.u64();
  if (opcode != kHeader) {
    c.fail("expected the header record (opcode 0x01) after the magic, found opcode " + std::to_string(opcode));
  }
  const std::uint64_t content_at = kMagic.size() + kRecordHeaderBytes;
  const Bytes content = file_.read(content_at, length, kMagic.size());
  Cursor h(content.data(), content.size(), name(), kMagic.size(), "header");
  profile_ = h.str();
  (void)h.str();  // library
  return content_at + length;
}

/// Reads footer and summary; when the file has no usable summary, says how to stream it instead.
std::optional<McapReader::StreamPlan> McapReader::open_indexed() {
  const std::uint64_t tail = kRecordHeaderBytes + kFooterContentBytes + kMagic.size();
  const StreamPlan cut{"no footer: the recording was cut off", file_.size(), false};
  if (file_.size() < data_start_ + tail) return cut;
  const std::uint64_t footer_at = file_.size() - tail;
  const Bytes footer = file_.read(footer_at, tail, footer_at);
  Cursor c(footer.data(), footer.size(), name(), footer_at, "footer");
  const std::uint8_t opcode = c.u8();
  const std::uint64_t length = c.u64();
  const std::uint64_t summary_start = c.u64(), summary_offset_start = c.u64();
  const std::uint32_t summary_crc = c.u32();
  if (std::string_view(reinterpret_cast<const char*>(c.take(8)), 8) != kMagic || opcode != kFooter ||
      length != kFooterContentBytes) {
    return cut;
  }
  if (summary_start == 0) return StreamPlan{"the footer says summary_start 0", footer_at, true};
  if (summary_start < data_start_ || summary_start > footer_at ||
      (summary_offset_start != 0 && (summary_offset_start < summary_start || summary_offset_start > footer_at))) {
    c.fail("footer points outside the file (summary_start " + std::to_string(summary_start) + ", summary_offset_start " +
           std::to_string(summary_offset_start) + ")");
  }
  const Bytes summary = file_.read(summary_start, footer_at - summary_start, summary_start);
  if (summary_crc != 0) {
    std::uint32_t crc = crc32_update(0, summary.data(), summary.size());
    crc = crc32_update(crc, footer.data(), 1 + 8 + 16);  // the footer up to summary_crc is covered too
    if (crc != summary_crc) throw InputError(name(), at_byte(summary_start), "summary section CRC mismatch: corrupt");
  }
  parse_summary(summary, summary_start);
  if (channels_.empty() && !chunks_.empty()) return StreamPlan{"the summary holds no channel records", footer_at, true};
  check_chunk_indexes(summary_start);
  data_end_ = summary_start;
  indexed_ = true;
  return std::nullopt;
}

void McapReader::parse_summary(const Bytes& summary, std::uint64_t summary_start) {
  std::size_t pos = 0;
  while (pos < summary.size()) {
    const std::uint64_t at = summary_start + pos;
    Cursor head(summary.data() + pos, summary.size() - pos, name(), at, "summary");
    const std::uint8_t opcode = head.u8();
    const std::uint64_t length = head.u64();
    if (length > head.remaining()) head.fail("summary record runs past the end of the summary section");
    Cursor content(head.take(length), static_cast<std::size_t>(length), name(), at,
                   opcode == kChunkIndex ? "chunk index" : opcode == kStatistics ? "statistics" : "summary");
    if (opcode == kSchema) {
      add_schema(summary.data() + pos + kRecordHeaderBytes, static_cast<std::size_t>(length), at);
    } else if (opcode == kChannel) {
      add_channel(summary.data() + pos + kRecordHeaderBytes, static_cast<std::size_t>(length), at);
    } else if (opcode == kChunkIndex) {
      chunks_.push_back(parse_chunk_index(content));
    } else if (opcode == kStatistics) {
      stats_ = parse_statistics(content);
    }  // attachment / metadata indexes, summary offsets: not needed
    pos += kRecordHeaderBytes + static_cast<std::size_t>(length);
  }
  std::stable_sort(chunks_.begin(), chunks_.end(),
                   [](const ChunkLocation& a, const ChunkLocation& b) { return a.offset < b.offset; });
}

void McapReader::check_chunk_indexes(std::uint64_t data_end) const {
  for (const ChunkLocation& c : chunks_) {
    if (c.offset < data_start_ || c.offset > data_end || c.length > data_end - c.offset ||
        c.length < kRecordHeaderBytes) {
      throw InputError(name(), at_byte(c.offset),
                       "a chunk index puts a chunk of " + std::to_string(c.length) + " bytes here, outside the data section");
    }
    if (!supported_compression(c.compression)) unsupported_compression(name(), c.offset, c.compression);
    for (const auto& [channel, index_at] : c.index_offsets) {
      if (index_at < c.offset + c.length || index_at >= data_end) {
        throw InputError(name(), at_byte(c.offset), "the chunk index points its message index for channel " +
                                                        std::to_string(channel) + " outside the data section");
      }
    }
  }
}

void McapReader::add_schema(const std::uint8_t* content, std::size_t size, std::uint64_t offset) {
  std::uint16_t id = 0;
  SchemaRecord s = parse_schema(Cursor(content, size, name(), offset, "schema"), id);
  if (id != 0) schemas_.emplace(id, std::move(s));  // id 0 is invalid: ignored, as the spec says
}

void McapReader::add_channel(const std::uint8_t* content, std::size_t size, std::uint64_t offset) {
  std::uint16_t id = 0;
  ChannelRecord ch = parse_channel(Cursor(content, size, name(), offset, "channel"), id);
  channels_.emplace(id, std::move(ch));
}

/// Streams records from `from` up to `end`. `complete`: the file has its footer, so a record
/// running past `end` is corruption rather than the cut of an interrupted recording.
void McapReader::stream(std::uint64_t from, std::uint64_t end, bool complete, const std::string& why) {
  std::uint64_t pos = from;
  std::string stop;
  while (pos < end) {
    if (end - pos < kRecordHeaderBytes) {
      stop = "the file ends inside a record header";
      break;
    }
    const Bytes head = file_.read(pos, kRecordHeaderBytes, pos);
    Cursor c(head.data(), head.size(), name(), pos, "record");
    const std::uint8_t opcode = c.u8();
    const std::uint64_t length = c.u64();
    if (opcode == 0) {
      stop = "no valid record there (opcode 0)";
      break;
    }
    if (length > end - pos - kRecordHeaderBytes) {
      if (complete) c.fail("record runs past the end of the data section (" + std::to_string(length) + " bytes)");
      stop = "a record of " + std::to_string(length) + " bytes runs past the end of the file";
      break;
    }
    if (!stream_record(opcode, pos, length)) break;  // data end or footer
    pos += kRecordHeaderBytes + length;
  }
  data_end_ = pos;
  std::string w = "no summary section (" + why + "): streamed the records up to byte " + std::to_string(pos) + " of " +
                  std::to_string(file_.size());
  if (!stop.empty()) w += "; the file stops being readable at byte " + std::to_string(pos) + ": " + stop;
  warnings_.push_back(std::move(w));
}

/// One top-level record while streaming; false once the data section is over.
bool McapReader::stream_record(std::uint8_t opcode, std::uint64_t offset, std::uint64_t length) {
  const std::uint64_t content_at = offset + kRecordHeaderBytes;
  if (opcode == kDataEnd || opcode == kFooter) return false;
  if (opcode == kSchema || opcode == kChannel) {
    const Bytes content = file_.read(content_at, length, offset);
    if (opcode == kSchema) add_schema(content.data(), content.size(), offset);
    if (opcode == kChannel) add_channel(content.data(), content.size(), offset);
  } else if (opcode == kMessage) {
    const Bytes head = file_.read(content_at, std::min<std::uint64_t>(length, kMessageHeaderBytes), offset);
    const MessageHeader m = parse_message_header(Cursor(head.data(), head.size(), name(), offset, "message"));
    streamed_.push_back({m.channel, m.log_time_ns, offset, 0, 0, offset});
  } else if (opcode == kChunk) {
    stream_chunk(offset, length);
  }
  return true;
}

/// Reads a chunk that no chunk index describes, adds it to chunks_; returns its records.
std::shared_ptr<const Bytes> McapReader::add_unindexed_chunk(std::uint64_t offset, std::uint64_t length) const {
  const Bytes content = file_.read(offset + kRecordHeaderBytes, length, offset);
  const ChunkHeader h = parse_chunk(Cursor(content.data(), content.size(), name(), offset, "chunk"));
  if (!supported_compression(h.compression)) unsupported_compression(name(), offset, h.compression);
  auto records = std::make_shared<const Bytes>(decompress_chunk(h, name(), offset));
  ChunkLocation loc;
  loc.offset = offset;
  loc.length = kRecordHeaderBytes + length;
  loc.compression = h.compression;
  loc.uncompressed_size = h.uncompressed_size;
  chunks_.push_back(std::move(loc));
  cache_.insert(chunks_.size() - 1, records);
  return records;
}

void McapReader::stream_chunk(std::uint64_t offset, std::uint64_t length) {
  const std::shared_ptr<const Bytes> records = add_unindexed_chunk(offset, length);
  const std::size_t chunk = chunks_.size() - 1;
  for_each_record_in_chunk(*records, name(), offset,
                           [&](std::uint8_t op, const std::uint8_t* data, std::size_t size, std::uint64_t inner) {
                             if (op == kSchema) add_schema(data, size, offset);
                             if (op == kChannel) add_channel(data, size, offset);
                             if (op != kMessage) return;
                             const MessageHeader m = parse_message_header(Cursor(data, size, name(), offset, "message"));
                             streamed_.push_back({m.channel, m.log_time_ns, offset, inner, chunk + 1, inner});
                           });
}

/// One topic per channel topic; channels repeating a topic with the same type and encoding
/// (several publishers) share it.
void McapReader::build_topics() {
  std::map<std::tuple<std::string, std::string, std::string>, std::uint32_t> by_key;  // name, type, encoding
  for (const auto& [id, ch] : channels_) {
    const auto schema = schemas_.find(ch.schema_id);
    Topic t;
    t.name = ch.topic;
    t.encoding = ch.message_encoding == "ros1" ? MessageEncoding::kRos1 : MessageEncoding::kCdr;
    if (schema != schemas_.end()) {
      t.type = schema->second.name;
      t.definition = schema->second.data;
      t.definition_encoding = schema->second.encoding;
    }
    if (const auto md5 = ch.metadata.find("md5sum"); md5 != ch.metadata.end()) t.md5sum = md5->second;
    const auto [it, is_new] =
        by_key.try_emplace({t.name, t.type, ch.message_encoding}, static_cast<std::uint32_t>(topics_.size()));
    const std::uint32_t index = it->second;
    if (is_new) {
      topics_.push_back(std::move(t));
      topic_encoding_.push_back(ch.message_encoding);
    }
    topic_of_channel_[id] = index;
    if (stats_) {
      const auto n = stats_->channel_counts.find(id);
      if (n != stats_->channel_counts.end()) topics_[index].message_count += n->second;
    }
  }
}

std::uint32_t McapReader::topic_of(std::uint16_t channel, std::uint64_t offset) const {
  const auto it = topic_of_channel_.find(channel);
  if (it == topic_of_channel_.end()) {
    throw InputError(name(), at_byte(offset),
                     "message on channel " + std::to_string(channel) + ", which no channel record declares");
  }
  return it->second;
}

void McapReader::build_index() const {
  std::vector<Found> found = streamed_;
  if (indexed_) {
    for (std::size_t i = 0; i < chunks_.size(); ++i) {
      if (!chunks_[i].index_offsets.empty()) {
        read_message_indexes(i, found);
      } else if (chunks_[i].uncompressed_size > 0) {  // no message index: the chunk itself must be read
        scan_chunk(i, *chunk_records(i), found);
      }
    }
    // Messages outside chunks have no index: look for them when the statistics say some exist.
    if (!stats_ || stats_->message_count > found.size()) scan_top_level_messages(found);
  }
  set_refs(std::move(found));
}

void McapReader::read_message_indexes(std::size_t chunk, std::vector<Found>& found) const {
  const ChunkLocation& c = chunks_[chunk];
  const std::uint64_t block_at = c.offset + c.length;
  std::uint64_t block_end = block_at + std::min(c.index_length, data_end_ - block_at);
  for (const auto& entry : c.index_offsets) block_end = std::max(block_end, entry.second + kRecordHeaderBytes);
  const Bytes block = file_.read(block_at, block_end - block_at, block_at);
  for (const auto& [channel, index_at] : c.index_offsets) {
    const std::size_t pos = static_cast<std::size_t>(index_at - block_at);
    Cursor head(block.data() + pos, block.size() - pos, name(), index_at, "message index");
    if (head.u8() != kMessageIndex) head.fail("the chunk index points here, but this is not a message index record");
    const std::uint64_t length = head.u64();
    Bytes tail;
    const std::uint8_t* content = nullptr;
    if (length <= block.size() - pos - kRecordHeaderBytes) {
      content = block.data() + pos + kRecordHeaderBytes;
    } else {  // outside the declared block: read it on its own
      tail = file_.read(index_at + kRecordHeaderBytes, length, index_at);
      content = tail.data();
    }
    Cursor r(content, static_cast<std::size_t>(length), name(), index_at, "message index");
    if (r.u16() != channel) r.fail("message index for another channel than its chunk index says");
    Cursor entries = r.sub32();
    while (entries.remaining() > 0) {
      const std::uint64_t t = entries.u64(), inner = entries.u64();
      found.push_back({channel, t, c.offset, inner, chunk + 1, inner});
    }
  }
}

void McapReader::scan_chunk(std::size_t chunk, const Bytes& records, std::vector<Found>& found) const {
  const std::uint64_t offset = chunks_[chunk].offset;
  for_each_record_in_chunk(records, name(), offset,
                           [&](std::uint8_t op, const std::uint8_t* data, std::size_t size, std::uint64_t inner) {
                             if (op != kMessage) return;
                             const MessageHeader m = parse_message_header(Cursor(data, size, name(), offset, "message"));
                             found.push_back({m.channel, m.log_time_ns, offset, inner, chunk + 1, inner});
                           });
}

/// Record headers of the data section, for messages outside chunks and chunks without an index
/// (indexed chunks are skipped by their length).
void McapReader::scan_top_level_messages(std::vector<Found>& found) const {
  std::set<std::uint64_t> indexed;
  for (const ChunkLocation& c : chunks_) indexed.insert(c.offset);
  for (std::uint64_t pos = data_start_; pos < data_end_;) {
    const Bytes head = file_.read(pos, std::min<std::uint64_t>(kRecordHeaderBytes, data_end_ - pos), pos);
    Cursor c(head.data(), head.size(), name(), pos, "record");
    const std::uint8_t opcode = c.u8();
    const std::uint64_t length = c.u64();
    if (opcode == kDataEnd) return;
    if (length > data_end_ - pos - kRecordHeaderBytes) c.fail("record runs past the end of the data section");
    if (opcode == kMessage) {
      const Bytes m = file_.read(pos + kRecordHeaderBytes, std::min<std::uint64_t>(length, kMessageHeaderBytes), pos);
      const MessageHeader h = parse_message_header(Cursor(m.data(), m.size(), name(), pos, "message"));
      found.push_back({h.channel, h.log_time_ns, pos, 0, 0, pos});
    } else if (opcode == kChunk && indexed.count(pos) == 0) {
      const std::shared_ptr<const Bytes> records = add_unindexed_chunk(pos, length);
      scan_chunk(chunks_.size() - 1, *records, found);
    }
    pos += kRecordHeaderBytes + length;
  }
}

/// Per topic, in log-time order, ties in file order.
void McapReader::set_refs(std::vector<Found> found) const {
  std::stable_sort(found.begin(), found.end(), [](const Found& a, const Found& b) {
    return std::tie(a.log_time_ns, a.file_pos, a.inner) < std::tie(b.log_time_ns, b.file_pos, b.inner);
  });
  refs_.assign(topics_.size(), {});
  message_starts_.assign(chunks_.size(), {});
  for (const Found& f : found) {
    if (f.locator > 0 && f.locator <= chunks_.size()) message_starts_[f.locator - 1].push_back(f.locator2);
  }
  for (std::vector<std::uint64_t>& starts : message_starts_) std::sort(starts.begin(), starts.end());
  for (const Found& f : found) {
    const std::uint32_t topic = topic_of(f.channel, f.file_pos);
    refs_[topic].push_back({topic, static_cast<std::int64_t>(f.log_time_ns), f.locator, f.locator2});
  }
}

std::vector<MessageRef> McapReader::messages(std::uint32_t topic) const {
  std::call_once(index_once_, [this] { build_index(); });
  return topic < refs_.size() ? refs_[topic] : std::vector<MessageRef>{};
}

Bytes McapReader::load_chunk(std::size_t chunk) const {
  const ChunkLocation& c = chunks_[chunk];
  const Bytes record = file_.read(c.offset, c.length, c.offset);
  Cursor head(record.data(), record.size(), name(), c.offset, "chunk");
  const std::uint8_t opcode = head.u8();
  const std::uint64_t length = head.u64();
  if (opcode != kChunk || length != c.length - kRecordHeaderBytes) {
    head.fail("the chunk index points here, but this is not a chunk record of " + std::to_string(c.length) + " bytes");
  }
  const ChunkHeader h = parse_chunk(Cursor(record.data() + kRecordHeaderBytes, static_cast<std::size_t>(length),
                                           name(), c.offset, "chunk"));
  if (h.compression != c.compression) head.fail("chunk compression '" + h.compression + "' disagrees with its index");
  // The same bytes decompress to the same records: a chunk read again (evicted from the cache)
  // is not checked again. A failed check throws before the chunk is marked checked.
  const bool check = take_crc_check(chunk);
  Bytes records = decompress_chunk(h, name(), c.offset, check);
  if (check) {
    const std::lock_guard<std::mutex> lock(crc_mutex_);
    crc_checked_[chunk] = 1;
  }
  return records;
}

/// Whether the chunk's CRC still needs checking.
bool McapReader::take_crc_check(std::size_t chunk) const {
  const std::lock_guard<std::mutex> lock(crc_mutex_);
  if (crc_checked_.size() < chunks_.size()) crc_checked_.resize(chunks_.size(), 0);
  return crc_checked_[chunk] == 0;
}

/// The first `want` bytes of a chunk's records (fewer if it holds fewer), its compressed data read
/// and decoded only that far (zstd in growing pieces): a cloud's header needs its first block, and
/// the INS messages before a cloud need no cloud.
Bytes McapReader::chunk_prefix(std::size_t chunk, std::uint64_t want) const {
  const ChunkLocation& c = chunks_[chunk];
  const std::uint64_t header = kRecordHeaderBytes + 8 + 8 + 8 + 4 + 4 + c.compression.size() + 8;
  const Bytes head = file_.read(c.offset, std::min(header, c.length), c.offset);
  Cursor h(head.data(), head.size(), name(), c.offset, "chunk");
  const std::uint8_t opcode = h.u8();
  const std::uint64_t length = h.u64();
  (void)h.take(8 + 8 + 8 + 4);  // times, uncompressed_size, crc
  const std::string compression = h.str();
  const std::uint64_t records_size = h.u64();
  if (opcode != kChunk || length != c.length - kRecordHeaderBytes || compression != c.compression ||
      records_size != c.length - header) {
    h.fail("the chunk index points here, but this is not the chunk of " + std::to_string(c.length) + " bytes it describes");
  }
  want = std::min(want, c.uncompressed_size);
  const std::uint64_t records_at = c.offset + header;
  if (compression.empty()) return file_.read(records_at, std::min(want, records_size), c.offset);
  if (compression == "lz4") {
    // LZ4 turns each input byte into at least 255/256 of an output byte: this much input suffices.
    const Bytes stored = file_.read(records_at, std::min<std::uint64_t>(records_size, want + want / 128 + 4096), c.offset);
    return lz4_frame_decompress_prefix(stored.data(), stored.size(), static_cast<std::size_t>(want), name(), c.offset);
  }
  ZstdPrefixDecoder decoder(name(), c.offset);
  Bytes out(static_cast<std::size_t>(want));
  std::size_t produced = 0;
  for (std::uint64_t done = 0, step = 64 * 1024; produced < out.size() && done < records_size; step *= 2) {
    const Bytes piece = file_.read(records_at + done, std::min(step, records_size - done), c.offset);
    done += piece.size();
    produced = decoder.feed(piece, out, produced);
  }
  out.resize(produced);
  return out;
}

std::shared_ptr<const Bytes> McapReader::chunk_records(std::size_t chunk) const {
  if (auto hit = cache_.find(chunk)) return hit;
  auto records = std::make_shared<const Bytes>(load_chunk(chunk));
  cache_.insert(chunk, records);
  return records;
}

void McapReader::check_readable(const MessageRef& ref) const {
  if (ref.topic >= topics_.size()) throw InputError(name(), "", "message reference to a topic this file does not have");
  const std::string& encoding = topic_encoding_[ref.topic];
  if (encoding != "ros1" && encoding != "cdr") {
    throw InputError(name(), "", "topic " + topics_[ref.topic].name + " has message encoding '" + encoding +
                                     "': insalign reads ROS messages only (ros1 or cdr)");
  }
  if (ref.locator > chunks_.size()) throw InputError(name(), "", "message reference to a chunk this file does not have");
}

/// A copy of message_view().
Message McapReader::message_data(const std::uint8_t* record, std::uint64_t available, std::uint64_t offset,
                               std::uint32_t topic, std::uint64_t max_bytes) const {
  const std::span<const std::uint8_t> data = message_view(record, available, offset, topic, max_bytes);
  return {data.begin(), data.end()};
}

/// The first `max_bytes` of the data of the message record at `record`, of which `available`
/// bytes are at hand (at least enough for those). `offset`: the record or its chunk, for errors.
std::span<const std::uint8_t> McapReader::message_view(const std::uint8_t* record, std::uint64_t available,
                                                       std::uint64_t offset, std::uint32_t topic,
                                                       std::uint64_t max_bytes) const {
  Cursor c(record, static_cast<std::size_t>(available), name(), offset, "message");
  const std::uint8_t opcode = c.u8();
  const std::uint64_t length = c.u64();
  if (opcode != kMessage) c.fail("a message index points to a record that is not a message (opcode " + std::to_string(opcode) + ")");
  if (length < kMessageHeaderBytes) c.fail("message record shorter than a message header");
  const MessageHeader h = parse_message_header(c);
  (void)c.take(kMessageHeaderBytes);
  if (topic_of(h.channel, offset) != topic) c.fail("a message index points to a message of another channel");
  const std::uint64_t size = std::min(length - kMessageHeaderBytes, max_bytes);
  return {c.take(size), static_cast<std::size_t>(size)};
}

Message McapReader::read_bytes(const MessageRef& ref, std::uint64_t max_bytes) const {
  check_readable(ref);
  const std::uint64_t offset = ref.locator2;
  if (ref.locator == 0) {  // a message outside chunks: ref.locator2 is its file offset
    const Bytes head = file_.read(offset, kRecordHeaderBytes, offset);
    Cursor c(head.data(), head.size(), name(), offset, "message");
    (void)c.u8();
    const std::uint64_t wanted = std::min(c.u64(), kMessageHeaderBytes + max_bytes);
    const Bytes record = file_.read(offset, kRecordHeaderBytes + std::min(wanted, file_.size()), offset);
    return message_data(record.data(), record.size(), offset, ref.topic, max_bytes);
  }
  const std::size_t chunk = static_cast<std::size_t>(ref.locator - 1);
  const std::uint64_t chunk_at = chunks_[chunk].offset;
  if (ref.locator2 >= chunks_[chunk].uncompressed_size) {
    throw InputError(name(), at_byte(chunk_at), "message index points past the chunk's end");
  }
  std::shared_ptr<const Bytes> records = cache_.find(chunk);
  if (!records && max_bytes < chunks_[chunk].uncompressed_size) {
    // A prefix: decompress only as far as needed (no CRC check: it covers the whole chunk).
    const std::uint64_t want = ref.locator2 + kRecordHeaderBytes + kMessageHeaderBytes + max_bytes;
    records = std::make_shared<const Bytes>(chunk_prefix(chunk, want));
  }
  if (!records) records = chunk_records(chunk);
  return from_records(*records, chunk, ref, max_bytes);
}

/// The message `ref` of chunk `chunk` out of its (possibly partial) decompressed records.
Message McapReader::from_records(const Bytes& records, std::size_t chunk, const MessageRef& ref, std::uint64_t max_bytes) const {
  const std::uint64_t chunk_at = chunks_[chunk].offset;
  if (ref.locator2 > records.size()) throw InputError(name(), at_byte(chunk_at), "message index points past the chunk's end");
  return message_data(records.data() + ref.locator2, records.size() - ref.locator2, chunk_at, ref.topic, max_bytes);
}

/// How far into its chunk's records the message at `inner` reaches (its first max_bytes of data,
/// or all of it for 0): the next message's start bounds it.
std::uint64_t McapReader::needed_end(std::size_t chunk, std::uint64_t inner, std::uint64_t max_bytes) const {
  const std::vector<std::uint64_t>& starts = message_starts_[chunk];
  const auto next = std::upper_bound(starts.begin(), starts.end(), inner);
  const std::uint64_t end = next == starts.end() ? chunks_[chunk].uncompressed_size : *next;
  if (max_bytes == 0) return end;
  return std::min(end, inner + kRecordHeaderBytes + kMessageHeaderBytes + max_bytes);
}

void McapReader::read_batch(const std::vector<BatchRequest>& requests, const BatchHandler& on) const {
  std::call_once(index_once_, [this] { build_index(); });
  // Requests grouped by chunk (a recorder's chunk holds INS messages and a cloud), file order.
  std::vector<std::size_t> order(requests.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return requests[a].ref.locator < requests[b].ref.locator; });
  for (std::size_t begin = 0; begin < order.size();) {
    std::size_t end = begin + 1;
    while (end < order.size() && requests[order[end]].ref.locator == requests[order[begin]].ref.locator) ++end;
    serve_chunk(requests, std::vector<std::size_t>(order.begin() + begin, order.begin() + end), on);
    begin = end;
  }
}

/// The requests `run` (one chunk's) from one decompression of that chunk, as far as the furthest
/// of them needs: the whole chunk (CRC-checked, cached) only when one of them reaches its end.
void McapReader::serve_chunk(const std::vector<BatchRequest>& requests, const std::vector<std::size_t>& run,
                             const BatchHandler& on) const {
  const auto limit = [](std::size_t max_bytes) {
    return max_bytes == 0 ? std::numeric_limits<std::uint64_t>::max() - kMessageHeaderBytes - kRecordHeaderBytes
                          : std::uint64_t(max_bytes);
  };
  const MessageRef& first = requests[run.front()].ref;
  check_readable(first);
  if (first.locator == 0 || first.locator > message_starts_.size()) {  // outside chunks
    for (std::size_t k : run) on(k, read_bytes(requests[k].ref, limit(requests[k].max_bytes)));
    return;
  }
  const std::size_t chunk = static_cast<std::size_t>(first.locator - 1);
  std::shared_ptr<const Bytes> records = cache_.find(chunk);
  if (!records) {
    std::uint64_t need = 0;
    for (std::size_t k : run) need = std::max(need, needed_end(chunk, requests[k].ref.locator2, requests[k].max_bytes));
    records = need >= chunks_[chunk].uncompressed_size ? chunk_records(chunk)
                                                       : std::make_shared<const Bytes>(chunk_prefix(chunk, need));
  }
  for (std::size_t k : run) {
    check_readable(requests[k].ref);
    on(k, from_records(*records, chunk, requests[k].ref, limit(requests[k].max_bytes)));
  }
}

std::vector<std::uint8_t> McapReader::read(const MessageRef& ref) const {
  return read_bytes(ref, std::numeric_limits<std::uint64_t>::max() - kMessageHeaderBytes - kRecordHeaderBytes);
}

std::vector<std::uint8_t> McapReader::read_prefix(const MessageRef& ref, std::size_t max_bytes) const {
  return read_bytes(ref, max_bytes);
}

BagReader::SharedMessage McapReader::read_shared(const MessageRef& ref) const {
  check_readable(ref);
  if (ref.locator == 0) return BagReader::read_shared(ref);  // outside chunks: read from the file
  const std::size_t chunk = static_cast<std::size_t>(ref.locator - 1);
  const std::shared_ptr<const Bytes> records = chunk_records(chunk);
  if (ref.locator2 >= records->size()) {
    throw InputError(name(), at_byte(chunks_[chunk].offset), "message index points past the chunk's end");
  }
  const std::uint64_t all = std::numeric_limits<std::uint64_t>::max() - kMessageHeaderBytes - kRecordHeaderBytes;
  return {records, message_view(records->data() + ref.locator2, records->size() - ref.locator2, chunks_[chunk].offset,
                                ref.topic, all)};
}

std::string McapReader::describe() const {
  std::set<std::string> compressions;
  for (const ChunkLocation& c : chunks_) compressions.insert(c.compression.empty() ? "uncompressed" : c.compression);
  std::string chunks;
  for (const std::string& c : compressions) chunks += (chunks.empty() ? "" : " and ") + c;
  return "MCAP (" + (profile_.empty() ? std::string("no profile") : profile_ + " profile") + "), " +
         (chunks.empty() ? std::string("no chunks") : chunks + " chunks") + ", " +
         (indexed_ ? "indexed" : "streamed (no summary)");
}

}  // namespace

std::unique_ptr<BagReader> open_mcap(const std::filesystem::path& path) { return std::make_unique<McapReader>(path); }

}  // namespace insalign::io::bag
