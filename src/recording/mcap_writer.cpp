// MCAP writer: header, schema and channel records, chunks (none / zstd / lz4) each followed by
// its message index records, then Data End, the summary section (schemas, channels, statistics,
// chunk indexes), the summary offsets and the footer, with every CRC the format has.
#include <unistd.h>
#include <zstd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <map>
#include <new>
#include <stdexcept>
#include <string>
#include <tuple>

#include "core/errors.hpp"
#include "recording/lz4_frame.hpp"
#include "recording/mcap.hpp"

namespace insalign::io::bag {
namespace {

namespace fs = std::filesystem;
using namespace mcap_format;
using Bytes = std::vector<std::uint8_t>;

// zstd level 3 (its default) costs ~3x level 1's time for a few percent on point clouds; a
// simulated 3 GB drive is written in a fraction of the time it takes to render.
constexpr int kZstdLevel = 3;

// Little-endian record building.
struct Out {
  Bytes b;
  void u8(std::uint8_t v) { b.push_back(v); }
  void u16(std::uint16_t v) { le(v, 2); }
  void u32(std::uint32_t v) { le(v, 4); }
  void u64(std::uint64_t v) { le(v, 8); }
  void bytes(const std::uint8_t* p, std::size_t n) { b.insert(b.end(), p, p + n); }
  void str(const std::string& s) {
    u32(static_cast<std::uint32_t>(s.size()));
    bytes(reinterpret_cast<const std::uint8_t*>(s.data()), s.size());
  }
  /// Opens a record; close_record(at) fills in its length.
  std::size_t open_record(std::uint8_t opcode) {
    u8(opcode);
    u64(0);
    return b.size();
  }
  void close_record(std::size_t content_at) { set_record_length(content_at, b.size() - content_at); }
  void set_record_length(std::size_t content_at, std::uint64_t n) { patch_u64(content_at - 8, n); }
  /// Opens a uint32 byte-length prefix (maps, arrays); close_prefix(at) fills it in.
  std::size_t open_prefix() {
    u32(0);
    return b.size();
  }
  void close_prefix(std::size_t at) {
    const std::uint64_t n = b.size() - at;
    for (int i = 0; i < 4; ++i) b[at - 4 + i] = static_cast<std::uint8_t>(n >> (8 * i));
  }

 private:
  void le(std::uint64_t v, int n) {
    for (int i = 0; i < n; ++i) b.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  void patch_u64(std::size_t at, std::uint64_t v) {
    for (int i = 0; i < 8; ++i) b[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
  }
};

struct ChunkIndexEntry {
  std::uint64_t start_ns = 0, end_ns = 0, offset = 0, length = 0;
  std::map<std::uint16_t, std::uint64_t> index_offsets;
  std::uint64_t index_length = 0, compressed_size = 0, uncompressed_size = 0;
};

const char* compression_name(Compression c) { return c == Compression::kZstd ? "zstd" : c == Compression::kLz4 ? "lz4" : ""; }

// One context for the whole file: ZSTD_compress() would allocate one per chunk.
class ZstdCompressor {
 public:
  ZstdCompressor() : ctx_(ZSTD_createCCtx()) {
    if (ctx_ == nullptr) throw std::bad_alloc();
  }
  ~ZstdCompressor() { ZSTD_freeCCtx(ctx_); }
  ZstdCompressor(const ZstdCompressor&) = delete;
  ZstdCompressor& operator=(const ZstdCompressor&) = delete;
  /// Compresses `in` into `out` (its capacity reused from chunk to chunk).
  void compress(const Bytes& in, Bytes& out) {
    out.resize(ZSTD_compressBound(in.size()));
    const std::size_t n = ZSTD_compressCCtx(ctx_, out.data(), out.size(), in.data(), in.size(), kZstdLevel);
    if (ZSTD_isError(n)) throw std::runtime_error(std::string("zstd compression failed: ") + ZSTD_getErrorName(n));
    out.resize(n);
  }

 private:
  ZSTD_CCtx* ctx_;
};

class McapWriter final : public BagWriter {
 public:
  McapWriter(const fs::path& path, const WriterOptions& options);
  ~McapWriter() override;
  McapWriter(const McapWriter&) = delete;
  McapWriter& operator=(const McapWriter&) = delete;

  std::uint32_t add_topic(const Topic& topic) override;
  void write(std::uint32_t topic, std::int64_t log_time_ns, const std::vector<std::uint8_t>& bytes) override;
  void close() override;

 private:
  void emit(const std::uint8_t* data, std::size_t size);
  void emit(const Bytes& b) { emit(b.data(), b.size()); }
  void write_header();
  void flush_chunk();
  void write_message_indexes(ChunkIndexEntry& index);
  void write_summary_and_footer();
  void append_statistics(Out& o) const;
  void append_chunk_index(Out& o, const ChunkIndexEntry& c) const;
  void append_schema(Out& o, std::uint16_t id) const;
  void append_channel(Out& o, std::uint16_t id) const;
  [[noreturn]] void fail(const std::string& what) const { throw InputError(path_.string(), "", what); }

  fs::path path_, tmp_;
  WriterOptions options_;
  std::FILE* file_ = nullptr;
  std::uint64_t pos_ = 0;
  std::uint32_t data_crc_ = 0;
  bool header_written_ = false;

  struct Schema {
    std::string name, encoding, data;
  };
  std::vector<Schema> schemas_;           ///< id = index + 1
  std::vector<Topic> topics_;             ///< channel id = index + 1
  std::vector<std::uint16_t> schema_of_;  ///< per topic
  std::vector<std::uint32_t> sequence_;   ///< per topic
  std::vector<std::uint64_t> counts_;     ///< per topic

  Out chunk_;     ///< the open chunk's records, uncompressed
  Bytes packed_;  ///< the same, compressed
  ZstdCompressor zstd_;
  std::map<std::uint16_t, std::vector<std::pair<std::uint64_t, std::uint64_t>>> chunk_index_;  ///< channel -> (t, offset)
  std::uint64_t chunk_start_ns_ = 0, chunk_end_ns_ = 0;
  bool chunk_has_messages_ = false;
  std::vector<ChunkIndexEntry> chunks_;
  std::uint64_t message_count_ = 0, start_ns_ = 0, end_ns_ = 0;
  std::int64_t last_ns_ = 0;
  bool closed_ = false;
};

McapWriter::McapWriter(const fs::path& path, const WriterOptions& options)
    : path_(path), tmp_(path.string() + ".tmp." + std::to_string(::getpid())), options_(options) {
  if (options.compression == Compression::kBz2) fail("MCAP chunks are uncompressed, zstd or lz4: bz2 is not supported");
  file_ = std::fopen(tmp_.c_str(), "wb");
  if (file_ == nullptr) fail(std::string("cannot write: ") + std::strerror(errno));
  std::setvbuf(file_, nullptr, _IOFBF, std::size_t(1) << 20);
}

McapWriter::~McapWriter() {
  if (file_ != nullptr) std::fclose(file_);
  if (!closed_) {
    std::error_code ec;
    fs::remove(tmp_, ec);  // never closed: nothing becomes visible
  }
}

void McapWriter::emit(const std::uint8_t* data, std::size_t size) {
  if (std::fwrite(data, 1, size, file_) != size) fail(std::string("write failed: ") + std::strerror(errno));
  data_crc_ = crc32_update(data_crc_, data, size);
  pos_ += size;
}

void McapWriter::write_header() {
  bool ros1 = false, cdr = false;
  for (const Topic& t : topics_) (t.encoding == MessageEncoding::kRos1 ? ros1 : cdr) = true;
  Out o;
  o.bytes(reinterpret_cast<const std::uint8_t*>(kMagic.data()), kMagic.size());
  const std::size_t at = o.open_record(kHeader);
  o.str(ros1 && !cdr ? "ros1" : cdr && !ros1 ? "ros2" : "");
  o.str("insalign");
  o.close_record(at);
  for (std::size_t i = 0; i < schemas_.size(); ++i) append_schema(o, static_cast<std::uint16_t>(i + 1));
  for (std::size_t i = 0; i < topics_.size(); ++i) append_channel(o, static_cast<std::uint16_t>(i + 1));
  emit(o.b);
  header_written_ = true;
}

void McapWriter::append_schema(Out& o, std::uint16_t id) const {
  const Schema& s = schemas_[id - 1];
  const std::size_t at = o.open_record(kSchema);
  o.u16(id);
  o.str(s.name);
  o.str(s.encoding);
  o.str(s.data);
  o.close_record(at);
}

void McapWriter::append_channel(Out& o, std::uint16_t id) const {
  const Topic& t = topics_[id - 1];
  const bool ros1 = t.encoding == MessageEncoding::kRos1;
  const std::size_t at = o.open_record(kChannel);
  o.u16(id);
  o.u16(schema_of_[id - 1]);
  o.str(t.name);
  o.str(ros1 ? "ros1" : "cdr");
  const std::size_t map_at = o.open_prefix();
  if (ros1 && !t.md5sum.empty()) {
    o.str("md5sum");
    o.str(t.md5sum);
  }
  if (!ros1) {  // required by the ros2 profile
    o.str("offered_qos_profiles");
    o.str("");
  }
  o.close_prefix(map_at);
  o.close_record(at);
}

std::uint32_t McapWriter::add_topic(const Topic& topic) {
  if (closed_) fail("add_topic after close");
  if (topics_.size() >= 0xFFFF) fail("an MCAP file holds at most 65535 channels");
  const std::string encoding = !topic.definition_encoding.empty() ? topic.definition_encoding
                               : topic.encoding == MessageEncoding::kRos1 ? "ros1msg"
                                                                           : "ros2msg";
  std::uint16_t schema = 0;
  for (std::size_t i = 0; i < schemas_.size() && schema == 0; ++i) {
    const Schema& s = schemas_[i];
    if (std::tie(s.name, s.encoding, s.data) == std::tie(topic.type, encoding, topic.definition)) {
      schema = static_cast<std::uint16_t>(i + 1);
    }
  }
  const bool new_schema = schema == 0;
  if (new_schema) {
    schemas_.push_back({topic.type, encoding, topic.definition});
    schema = static_cast<std::uint16_t>(schemas_.size());
  }
  topics_.push_back(topic);
  schema_of_.push_back(schema);
  sequence_.push_back(0);
  counts_.push_back(0);
  const auto id = static_cast<std::uint16_t>(topics_.size());
  if (!header_written_) return id - 1u;  // the header (its profile needs the topics) writes them
  // Into the open chunk if there is one, else straight into the data section: either way before
  // the channel's first message, so a reader streaming a cut-off file knows every channel.
  Out direct;
  Out& o = chunk_has_messages_ ? chunk_ : direct;
  if (new_schema) append_schema(o, schema);
  append_channel(o, id);
  emit(direct.b);
  return id - 1u;
}

void McapWriter::write(std::uint32_t topic, std::int64_t log_time_ns, const std::vector<std::uint8_t>& bytes) {
  if (closed_) fail("write after close");
  if (topic >= topics_.size()) fail("write to topic " + std::to_string(topic) + ", which add_topic did not return");
  if (log_time_ns < 0 || log_time_ns < last_ns_) {
    fail("message times must not decrease and not be negative (" + std::to_string(log_time_ns) + " ns after " +
         std::to_string(last_ns_) + " ns)");
  }
  if (!header_written_) write_header();
  // A message that fills a chunk by itself (a point cloud) gets a chunk of its own: the small
  // messages around it (INS at 100 Hz) then stay in small chunks, and reading all of them does
  // not decompress every cloud of the drive.
  if (chunk_has_messages_ && kRecordHeaderBytes + kMessageHeaderBytes + bytes.size() >= options_.chunk_bytes) {
    flush_chunk();
  }
  last_ns_ = log_time_ns;
  const auto t = static_cast<std::uint64_t>(log_time_ns);
  const auto channel = static_cast<std::uint16_t>(topic + 1);
  chunk_index_[channel].emplace_back(t, chunk_.b.size());
  const std::size_t at = chunk_.open_record(kMessage);
  chunk_.u16(channel);
  chunk_.u32(sequence_[topic]++);
  chunk_.u64(t);  // log_time
  chunk_.u64(t);  // publish_time: not known, the log time as the spec asks
  chunk_.bytes(bytes.data(), bytes.size());
  chunk_.close_record(at);
  if (!chunk_has_messages_) chunk_start_ns_ = t;
  chunk_end_ns_ = t;
  chunk_has_messages_ = true;
  if (message_count_ == 0) start_ns_ = t;
  end_ns_ = t;
  ++message_count_;
  ++counts_[topic];
  if (chunk_.b.size() >= options_.chunk_bytes) flush_chunk();
}

void McapWriter::flush_chunk() {
  if (chunk_.b.empty()) return;
  if (options_.compression == Compression::kZstd) zstd_.compress(chunk_.b, packed_);
  if (options_.compression == Compression::kLz4) packed_ = lz4_frame_compress(chunk_.b.data(), chunk_.b.size());
  const Bytes& records = options_.compression == Compression::kNone ? chunk_.b : packed_;
  ChunkIndexEntry index;
  index.start_ns = chunk_start_ns_;
  index.end_ns = chunk_end_ns_;
  index.offset = pos_;
  index.compressed_size = records.size();
  index.uncompressed_size = chunk_.b.size();
  Out head;
  const std::size_t at = head.open_record(kChunk);
  head.u64(index.start_ns);
  head.u64(index.end_ns);
  head.u64(index.uncompressed_size);
  head.u32(crc32_update(0, chunk_.b.data(), chunk_.b.size()));
  head.str(compression_name(options_.compression));
  head.u64(records.size());
  head.set_record_length(at, head.b.size() - at + records.size());
  emit(head.b);
  emit(records);
  index.length = pos_ - index.offset;
  write_message_indexes(index);
  chunks_.push_back(std::move(index));
  chunk_.b.clear();
  chunk_index_.clear();
  chunk_has_messages_ = false;
}

void McapWriter::write_message_indexes(ChunkIndexEntry& index) {
  const std::uint64_t start = pos_;
  for (const auto& [channel, entries] : chunk_index_) {
    index.index_offsets[channel] = pos_;
    Out o;
    const std::size_t at = o.open_record(kMessageIndex);
    o.u16(channel);
    const std::size_t array_at = o.open_prefix();
    for (const auto& [t, offset] : entries) {
      o.u64(t);
      o.u64(offset);
    }
    o.close_prefix(array_at);
    o.close_record(at);
    emit(o.b);
  }
  index.index_length = pos_ - start;
}

void McapWriter::close() {
  if (closed_) return;
  if (!header_written_) write_header();
  flush_chunk();
  Out end;
  const std::size_t at = end.open_record(kDataEnd);
  end.u32(data_crc_);  // every byte before this record, magic included
  end.close_record(at);
  emit(end.b);
  write_summary_and_footer();
  const bool ok = std::fflush(file_) == 0 && ::fsync(::fileno(file_)) == 0;
  const int err = errno;
  const bool closed_ok = std::fclose(file_) == 0;
  file_ = nullptr;
  if (!ok || !closed_ok) fail(std::string("write failed: ") + std::strerror(err));
  std::error_code ec;
  fs::rename(tmp_, path_, ec);
  if (ec) fail("cannot move the finished file into place: " + ec.message());
  closed_ = true;
}

void McapWriter::append_statistics(Out& o) const {
  const std::size_t at = o.open_record(kStatistics);
  o.u64(message_count_);
  o.u16(static_cast<std::uint16_t>(schemas_.size()));
  o.u32(static_cast<std::uint32_t>(topics_.size()));
  o.u32(0);  // attachments
  o.u32(0);  // metadata
  o.u32(static_cast<std::uint32_t>(chunks_.size()));
  o.u64(start_ns_);
  o.u64(end_ns_);
  const std::size_t map_at = o.open_prefix();
  for (std::size_t i = 0; i < topics_.size(); ++i) {
    o.u16(static_cast<std::uint16_t>(i + 1));
    o.u64(counts_[i]);
  }
  o.close_prefix(map_at);
  o.close_record(at);
}

void McapWriter::append_chunk_index(Out& o, const ChunkIndexEntry& c) const {
  const std::size_t at = o.open_record(kChunkIndex);
  o.u64(c.start_ns);
  o.u64(c.end_ns);
  o.u64(c.offset);
  o.u64(c.length);
  const std::size_t map_at = o.open_prefix();
  for (const auto& [channel, offset] : c.index_offsets) {
    o.u16(channel);
    o.u64(offset);
  }
  o.close_prefix(map_at);
  o.u64(c.index_length);
  o.str(compression_name(options_.compression));
  o.u64(c.compressed_size);
  o.u64(c.uncompressed_size);
  o.close_record(at);
}

/// Summary records grouped by opcode, a Summary Offset per group, the footer, the magic.
void McapWriter::write_summary_and_footer() {
  const std::uint64_t summary_start = pos_;
  Out s;
  std::vector<std::tuple<std::uint8_t, std::uint64_t, std::uint64_t>> groups;
  std::size_t from = 0;
  const auto close_group = [&](std::uint8_t opcode) {
    if (s.b.size() > from) groups.emplace_back(opcode, summary_start + from, s.b.size() - from);
    from = s.b.size();
  };
  for (std::size_t i = 0; i < schemas_.size(); ++i) append_schema(s, static_cast<std::uint16_t>(i + 1));
  close_group(kSchema);
  for (std::size_t i = 0; i < topics_.size(); ++i) append_channel(s, static_cast<std::uint16_t>(i + 1));
  close_group(kChannel);
  append_statistics(s);
  close_group(kStatistics);
  for (const ChunkIndexEntry& c : chunks_) append_chunk_index(s, c);
  close_group(kChunkIndex);
  const std::uint64_t summary_offset_start = summary_start + s.b.size();
  for (const auto& [opcode, start, length] : groups) {
    const std::size_t at = s.open_record(kSummaryOffset);
    s.u8(opcode);
    s.u64(start);
    s.u64(length);
    s.close_record(at);
  }
  s.u8(kFooter);  // its length written up front: the summary CRC covers it
  s.u64(kFooterContentBytes);
  s.u64(summary_start);
  s.u64(summary_offset_start);
  s.u32(crc32_update(0, s.b.data(), s.b.size()));  // summary start up to and including summary_offset_start
  s.bytes(reinterpret_cast<const std::uint8_t*>(kMagic.data()), kMagic.size());
  emit(s.b);
}

}  // namespace

std::unique_ptr<BagWriter> make_mcap_writer(const std::filesystem::path& path, const WriterOptions& options) {
  return std::make_unique<McapWriter>(path, options);
}

}  // namespace insalign::io::bag
