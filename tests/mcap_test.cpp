// MCAP reader and writer: the real rosbag2 recordings, round trips in every compression, files
// cut off mid-recording, corruption of every kind the reader must name.
#include "recording/mcap.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <fstream>
#include <map>
#include <set>
#include <algorithm>
#include <random>
#include <sstream>
#include <thread>

#include "core/errors.hpp"

namespace insalign::io::bag {
namespace {

namespace fs = std::filesystem;
using Bytes = std::vector<std::uint8_t>;

const fs::path kRosbag2Dir = fs::path(INSALIGN_SHARED_DATA_DIR) / "bags" / "rosbag2";

fs::path temp_dir(const std::string& tag) {
  const fs::path dir = fs::temp_directory_path() / ("insalign_mcap_" + tag + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string read_raw(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void write_raw(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

std::uint64_t le64(const std::string& s, std::size_t at) {
  std::uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | static_cast<std::uint8_t>(s[at + static_cast<std::size_t>(i)]);
  return v;
}

void put_le64(std::string& s, std::size_t at, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) s[at + static_cast<std::size_t>(i)] = static_cast<char>(v >> (8 * i));
}

/// The byte offset in an "byte N" location.
std::uint64_t byte_of(const InputError& e) {
  EXPECT_EQ(e.location().rfind("byte ", 0), 0u) << e.what();
  return e.location().size() > 5 ? std::stoull(e.location().substr(5)) : ~0ull;
}

const Topic* find_topic(const BagReader& r, const std::string& name) {
  for (const Topic& t : r.topics()) {
    if (t.name == name) return &t;
  }
  return nullptr;
}

std::uint32_t topic_index(const BagReader& r, const std::string& name) {
  for (std::uint32_t i = 0; i < r.topics().size(); ++i) {
    if (r.topics()[i].name == name) return i;
  }
  ADD_FAILURE() << "no topic " << name;
  return 0;
}

Bytes first_bytes(const Bytes& data, std::size_t n) { return {data.begin(), data.begin() + std::min(n, data.size())}; }

// ---------------------------------------------------------------------------------------------
// The real recordings (written by the ROS 2 tools: "mcap go" with zstd, libmcap 0.8.0 uncompressed)

TEST(Mcap, RealTalkerRecording) {
  const fs::path file = kRosbag2Dir / "talker-mcap" / "talker.mcap";
  if (!fs::exists(file)) GTEST_SKIP() << "shared bag data not found at " << file;
  const auto reader = open_mcap(file);
  ASSERT_EQ(reader->topics().size(), 3u);
  const std::map<std::string, std::pair<std::string, std::uint64_t>> expected = {
      {"/rosout", {"rcl_interfaces/msg/Log", 10}},
      {"/parameter_events", {"rcl_interfaces/msg/ParameterEvent", 0}},
      {"/topic", {"std_msgs/msg/String", 10}}};
  for (const auto& [name, type_count] : expected) {
    const Topic* t = find_topic(*reader, name);
    ASSERT_NE(t, nullptr) << name;
    EXPECT_EQ(t->type, type_count.first);
    EXPECT_EQ(t->message_count, type_count.second) << name;
    EXPECT_EQ(t->encoding, MessageEncoding::kCdr);
    EXPECT_EQ(t->definition_encoding, "ros2msg");
    EXPECT_EQ(reader->messages(topic_index(*reader, name)).size(), type_count.second) << name;
  }
  EXPECT_NE(find_topic(*reader, "/topic")->definition.find("string data"), std::string::npos);
  EXPECT_EQ(reader->describe(), "MCAP (ros2 profile), zstd chunks, indexed");
  EXPECT_TRUE(reader->warnings().empty());
  EXPECT_EQ(reader->start_time_ns(), 1585866235112411371);
  EXPECT_EQ(reader->end_time_ns(), 1585866235112411371 + 4531096768);
  // std_msgs/String in CDR: encapsulation header (little endian), uint32 length, the text.
  std::int64_t previous = 0;
  for (const MessageRef& ref : reader->messages(topic_index(*reader, "/topic"))) {
    const Bytes data = reader->read(ref);
    ASSERT_GE(data.size(), 9u);
    EXPECT_EQ(data[0], 0);
    EXPECT_EQ(data[1], 1);
    const std::string text(data.begin() + 8, data.end());
    EXPECT_NE(text.find("Hello"), std::string::npos) << text;
    EXPECT_GE(ref.log_time_ns, previous);
    previous = ref.log_time_ns;
  }
}

TEST(Mcap, RealCdrTestRecording) {
  const fs::path file = kRosbag2Dir / "cdr-test-mcap" / "cdr_test_0.mcap";
  if (!fs::exists(file)) GTEST_SKIP() << "shared bag data not found at " << file;
  const auto reader = open_mcap(file);
  ASSERT_EQ(reader->topics().size(), 2u);
  const Topic* arrays = find_topic(*reader, "/array_topic");
  const Topic* basic = find_topic(*reader, "/test_topic");
  ASSERT_TRUE(arrays && basic);
  EXPECT_EQ(arrays->type, "test_msgs/msg/Arrays");
  EXPECT_EQ(arrays->message_count, 4u);
  EXPECT_EQ(basic->type, "test_msgs/msg/BasicTypes");
  EXPECT_EQ(basic->message_count, 3u);
  EXPECT_EQ(basic->encoding, MessageEncoding::kCdr);
  EXPECT_EQ(reader->describe(), "MCAP (ros2 profile), uncompressed chunks, indexed");
  EXPECT_EQ(reader->start_time_ns(), 1586406456763032325);
  EXPECT_EQ(reader->end_time_ns(), 1586406456763032325 + 151137181);
  std::size_t total = 0;
  for (std::uint32_t t = 0; t < 2; ++t) {
    for (const MessageRef& ref : reader->messages(t)) {
      const Bytes data = reader->read(ref);
      EXPECT_GE(data.size(), 4u);
      EXPECT_EQ(data[1], 1) << "CDR little-endian encapsulation";
      ++total;
    }
  }
  EXPECT_EQ(total, 7u);
}

// Files written by @mcap/core (tests/fixtures/bags/make_mcap.mjs; facts in out/mcap_summary.json).
const fs::path kFixtureDir = fs::path(INSALIGN_TEST_DATA_DIR) / "bags";

TEST(Mcap, IndependentWriterZstdAndLz4) {
  for (const char* name : {"mcap_hesai_ouster_zstd.mcap", "mcap_hesai_ouster_lz4.mcap"}) {
    const auto reader = open_mcap(kFixtureDir / name);
    EXPECT_NE(reader->describe().find(std::string(name).find("lz4") != std::string::npos ? "lz4 chunks" : "zstd chunks"),
              std::string::npos);
    const std::map<std::string, std::pair<std::string, std::uint64_t>> expected = {
        {"/novatel/oem7/inspvax", {"novatel_oem7_msgs/msg/INSPVAX", 36}},
        {"/odom", {"nav_msgs/msg/Odometry", 36}},
        {"/hesai/pandar", {"sensor_msgs/msg/PointCloud2", 3}},
        {"/ouster/points", {"sensor_msgs/msg/PointCloud2", 3}}};
    ASSERT_EQ(reader->topics().size(), expected.size());
    for (const auto& [topic, type_count] : expected) {
      const Topic* t = find_topic(*reader, topic);
      ASSERT_NE(t, nullptr) << topic;
      EXPECT_EQ(t->type, type_count.first);
      EXPECT_EQ(t->message_count, type_count.second);
      const auto refs = reader->messages(topic_index(*reader, topic));
      ASSERT_EQ(refs.size(), type_count.second);
      for (const MessageRef& ref : refs) {
        const Bytes prefix = reader->read_prefix(ref, 64), all = reader->read(ref);
        EXPECT_GT(all.size(), 64u);
        EXPECT_EQ(prefix, first_bytes(all, 64));
      }
    }
    // An 800-point Hesai cloud of 48-byte points: its data alone is 38,400 bytes.
    EXPECT_GT(reader->read(reader->messages(topic_index(*reader, "/hesai/pandar"))[0]).size(), 38400u);
    EXPECT_EQ(reader->start_time_ns(), 1699999999982000000);
    EXPECT_EQ(reader->end_time_ns(), 1700000000332000000);
  }
}

TEST(Mcap, IndependentWriterCutOffAndCorruptCopies) {
  const auto cut = open_mcap(kFixtureDir / "mcap_truncated.mcap");  // cut in the middle of the chunk at 46523
  ASSERT_EQ(cut->warnings().size(), 1u);
  EXPECT_NE(cut->warnings()[0].find("stops being readable at byte 46523"), std::string::npos) << cut->warnings()[0];
  const std::map<std::string, std::size_t> counts = {
      {"/novatel/oem7/inspvax", 23}, {"/odom", 23}, {"/hesai/pandar", 2}, {"/ouster/points", 1}};
  for (const auto& [topic, count] : counts) {
    const auto refs = cut->messages(topic_index(*cut, topic));
    EXPECT_EQ(refs.size(), count) << topic;
    for (const MessageRef& ref : refs) EXPECT_FALSE(cut->read(ref).empty());
  }
  EXPECT_EQ(cut->end_time_ns(), 1700000000203000000);
  // A byte flipped inside the lz4 chunk at 24136: reading any of its messages names that chunk.
  const auto corrupt = open_mcap(kFixtureDir / "mcap_corrupt_chunk.mcap");
  std::size_t failures = 0;
  for (std::uint32_t t = 0; t < corrupt->topics().size(); ++t) {
    for (const MessageRef& ref : corrupt->messages(t)) {
      try {
        (void)corrupt->read(ref);
      } catch (const InputError& e) {
        EXPECT_EQ(e.location(), "byte 24136") << e.what();
        ++failures;
      }
    }
  }
  EXPECT_GT(failures, 0u);
  EXPECT_LT(failures, 78u / 2) << "only one chunk of six is corrupt";
}

// ---------------------------------------------------------------------------------------------
// Round trips of the writer

struct Written {
  std::uint32_t topic;
  std::int64_t t_ns;
  Bytes data;
};

std::vector<Topic> sample_topics() {
  Topic points{"/points", "sensor_msgs/PointCloud2", MessageEncoding::kRos1, "Header header\nuint32 height\n", "ros1msg",
               "1158d486dd51d683ce2f1be655c3c181", 0};
  Topic ins{"/ins", "novatel_oem7_msgs/msg/INSPVA", MessageEncoding::kCdr, "float64 latitude\n", "ros2msg", "", 0};
  Topic imu{"/imu", "sensor_msgs/msg/Imu", MessageEncoding::kCdr, "", "", "", 0};
  Topic idle{"/idle", "std_msgs/msg/String", MessageEncoding::kCdr, "string data\n", "ros2msg", "", 0};
  return {points, ins, imu, idle};
}

/// 400 small messages on /ins and /imu, a 20 kB cloud every 50, two messages sharing a time.
std::vector<Written> sample_messages(unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<Written> out;
  std::int64_t t = 1'700'000'000'000'000'000;
  for (int i = 0; i < 400; ++i) {
    t += 5'000'000;
    Bytes small(40 + rng() % 80);
    for (auto& b : small) b = static_cast<std::uint8_t>(rng());
    out.push_back({1u + static_cast<std::uint32_t>(i % 2), t, small});
    if (i % 50 == 10) {
      Bytes cloud(20000 + rng() % 1000);
      for (std::size_t k = 0; k < cloud.size(); ++k) cloud[k] = static_cast<std::uint8_t>(k % 7 == 0 ? rng() : k);
      out.push_back({0u, t, cloud});
    }
  }
  out.push_back({1u, t, Bytes{1, 2, 3}});  // same time as the last: file order decides
  out.push_back({0u, t + 1, Bytes{}});     // an empty message
  return out;
}

void write_sample(const fs::path& file, Compression compression, std::size_t chunk_bytes,
                  const std::vector<Written>& messages) {
  auto writer = make_mcap_writer(file, WriterOptions{compression, chunk_bytes});
  for (const Topic& t : sample_topics()) writer->add_topic(t);
  for (const Written& m : messages) writer->write(m.topic, m.t_ns, m.data);
  EXPECT_FALSE(fs::exists(file)) << "visible before close()";
  writer->close();
}

/// Every message of every topic read back equals what was written, in order; prefixes too (read
/// first, so that they come from a partial decompression rather than the cache).
void expect_same_messages(const BagReader& reader, const std::vector<Written>& messages, std::size_t expected_count) {
  std::map<std::uint32_t, std::vector<const Written*>> by_topic;
  for (const Written& m : messages) by_topic[m.topic].push_back(&m);
  std::size_t seen = 0;
  for (std::uint32_t t = 0; t < reader.topics().size(); ++t) {
    const std::vector<MessageRef> refs = reader.messages(t);
    ASSERT_LE(refs.size(), by_topic[t].size()) << reader.topics()[t].name;
    for (std::size_t i = 0; i < refs.size(); ++i) {
      ASSERT_EQ(refs[i].topic, t);
      EXPECT_EQ(refs[i].log_time_ns, by_topic[t][i]->t_ns);
      ASSERT_EQ(reader.read_prefix(refs[i], 24), first_bytes(by_topic[t][i]->data, 24)) << reader.topics()[t].name;
      ASSERT_EQ(reader.read(refs[i]), by_topic[t][i]->data) << reader.topics()[t].name << " #" << i;
    }
    seen += refs.size();
  }
  EXPECT_EQ(seen, expected_count);
}

class McapRoundTrip : public ::testing::TestWithParam<Compression> {};

TEST_P(McapRoundTrip, EveryTopicAndMessageComesBack) {
  const fs::path file = temp_dir("roundtrip") / "drive.mcap";
  const std::vector<Written> messages = sample_messages(7);
  write_sample(file, GetParam(), 4096, messages);
  const auto reader = open_mcap(file);
  EXPECT_TRUE(reader->warnings().empty());
  const char* name = GetParam() == Compression::kZstd ? "zstd" : GetParam() == Compression::kLz4 ? "lz4" : "uncompressed";
  EXPECT_EQ(reader->describe(), std::string("MCAP (no profile), ") + name + " chunks, indexed");
  const std::vector<Topic> topics = sample_topics();
  ASSERT_EQ(reader->topics().size(), topics.size());
  std::map<std::uint32_t, std::uint64_t> counts;
  for (const Written& m : messages) ++counts[m.topic];
  for (std::uint32_t i = 0; i < topics.size(); ++i) {
    const Topic& t = reader->topics()[i];
    EXPECT_EQ(t.name, topics[i].name);
    EXPECT_EQ(t.type, topics[i].type);
    EXPECT_EQ(t.encoding, topics[i].encoding);
    EXPECT_EQ(t.definition, topics[i].definition);
    EXPECT_EQ(t.definition_encoding, i == 2 ? "ros2msg" : topics[i].definition_encoding);
    EXPECT_EQ(t.md5sum, topics[i].md5sum);
    EXPECT_EQ(t.message_count, counts[i]);
  }
  EXPECT_EQ(reader->start_time_ns(), messages.front().t_ns);
  EXPECT_EQ(reader->end_time_ns(), messages.back().t_ns);
  expect_same_messages(*reader, messages, messages.size());
  fs::remove_all(file.parent_path());
}

INSTANTIATE_TEST_SUITE_P(Mcap, McapRoundTrip,
                         ::testing::Values(Compression::kNone, Compression::kZstd, Compression::kLz4),
                         [](const auto& info) {
                           return info.param == Compression::kZstd  ? std::string("Zstd")
                                  : info.param == Compression::kLz4 ? std::string("Lz4")
                                                                    : std::string("None");
                         });

TEST(Mcap, ParallelReadsShareTheChunkCache) {
  const fs::path file = temp_dir("threads") / "drive.mcap";
  const std::vector<Written> messages = sample_messages(9);
  write_sample(file, Compression::kZstd, 2048, messages);
  const auto reader = open_mcap(file);
  std::vector<std::pair<MessageRef, const Bytes*>> all;
  std::map<std::uint32_t, std::size_t> next;
  std::map<std::uint32_t, std::vector<MessageRef>> refs;
  for (std::uint32_t t = 0; t < reader->topics().size(); ++t) refs[t] = reader->messages(t);
  for (const Written& m : messages) all.emplace_back(refs[m.topic][next[m.topic]++], &m.data);
  std::atomic<int> mismatches{0};
  std::vector<std::thread> threads;
  for (int k = 0; k < 4; ++k) {
    threads.emplace_back([&, k] {
      for (std::size_t i = static_cast<std::size_t>(k); i < all.size() * 3; i += 2) {  // overlapping, out of order
        const auto& [ref, data] = all[(i * 7) % all.size()];
        if (reader->read(ref) != *data) ++mismatches;
      }
    });
  }
  for (std::thread& t : threads) t.join();
  EXPECT_EQ(mismatches.load(), 0);
  fs::remove_all(file.parent_path());
}

// The recorder's layout (clouds and small messages share chunks): read_batch() serves whole
// messages and prefixes from partly decompressed chunks, byte for byte what read() gives; the
// chunk CRC is still checked by a whole read.
TEST(Mcap, BatchReadsOfRecorderChunksMatchSingleReads) {
  const fs::path dir = temp_dir("batch");
  const std::vector<Written> messages = sample_messages(4);
  for (const Compression c : {Compression::kZstd, Compression::kLz4, Compression::kNone}) {
    const fs::path file = dir / "drive.mcap";
    auto writer = make_mcap_writer(file, WriterOptions{c, 16 * 1024, false});
    for (const Topic& t : sample_topics()) writer->add_topic(t);
    for (const Written& m : messages) writer->write(m.topic, m.t_ns, m.data);
    writer->close();
    const auto reader = open_mcap(file);
    std::vector<BagReader::BatchRequest> requests;
    for (std::uint32_t t = 0; t < reader->topics().size(); ++t) {
      for (const MessageRef& ref : reader->messages(t)) requests.push_back({ref, t == 0 ? std::size_t{16} : 0});
    }
    std::stable_sort(requests.begin(), requests.end(),
                     [](const auto& a, const auto& b) { return a.ref.log_time_ns < b.ref.log_time_ns; });
    std::set<std::uint64_t> chunks_with_cloud_and_small;
    std::map<std::uint64_t, std::set<std::uint32_t>> topics_of_chunk;
    for (const auto& q : requests) topics_of_chunk[q.ref.locator].insert(q.ref.topic);
    for (const auto& [chunk, topics] : topics_of_chunk) {
      if (topics.count(0) && topics.size() > 1) chunks_with_cloud_and_small.insert(chunk);
    }
    EXPECT_GE(chunks_with_cloud_and_small.size(), 5u) << "clouds share chunks with small messages";
    std::vector<int> served(requests.size(), 0);
    reader->read_batch(requests, [&](std::size_t k, Bytes bytes) {
      ++served[k];
      const Bytes whole = reader->read(requests[k].ref);
      EXPECT_EQ(bytes, requests[k].max_bytes == 0 ? whole : first_bytes(whole, requests[k].max_bytes)) << k;
    });
    EXPECT_EQ(std::count(served.begin(), served.end(), 1), static_cast<std::ptrdiff_t>(requests.size()));
  }
  fs::remove_all(dir);
}

TEST(Mcap, ProfileFollowsTheEncodings) {
  const fs::path dir = temp_dir("profile");
  for (const MessageEncoding encoding : {MessageEncoding::kRos1, MessageEncoding::kCdr}) {
    const fs::path file = dir / "one.mcap";
    auto writer = make_mcap_writer(file, {});
    const std::uint32_t id = writer->add_topic({"/a", "std_msgs/String", encoding, "string data\n", "", "", 0});
    writer->write(id, 5, {1, 2, 3});
    writer->close();
    const auto reader = open_mcap(file);
    EXPECT_EQ(reader->describe(), encoding == MessageEncoding::kRos1
                                      ? "MCAP (ros1 profile), uncompressed chunks, indexed"
                                      : "MCAP (ros2 profile), uncompressed chunks, indexed");
    EXPECT_EQ(reader->topics()[0].definition_encoding, encoding == MessageEncoding::kRos1 ? "ros1msg" : "ros2msg");
  }
  fs::remove_all(dir);
}

TEST(Mcap, WriterRefusesWhatMcapCannotHold) {
  const fs::path dir = temp_dir("refuse");
  EXPECT_THROW(make_mcap_writer(dir / "a.mcap", WriterOptions{Compression::kBz2, 1024}), InputError);
  auto writer = make_mcap_writer(dir / "b.mcap", {});
  const std::uint32_t id = writer->add_topic({"/a", "std_msgs/String", MessageEncoding::kCdr, "", "", "", 0});
  writer->write(id, 100, {1});
  EXPECT_THROW(writer->write(id, 99, {1}), InputError);
  EXPECT_THROW(writer->write(id + 1, 101, {1}), InputError);
  writer.reset();  // never closed: nothing left behind
  EXPECT_TRUE(fs::is_empty(dir));
  fs::remove_all(dir);
}

// ---------------------------------------------------------------------------------------------
// Files without a summary

TEST(Mcap, CutOffRecordingIsStreamedUpToTheCut) {
  const fs::path dir = temp_dir("cut");
  const std::vector<Written> messages = sample_messages(3);
  write_sample(dir / "full.mcap", Compression::kZstd, 4096, messages);
  const std::string full = read_raw(dir / "full.mcap");
  const std::size_t cut_at = full.size() * 6 / 10;
  write_raw(dir / "cut.mcap", full.substr(0, cut_at));
  const auto reader = open_mcap(dir / "cut.mcap");
  ASSERT_EQ(reader->warnings().size(), 1u);
  const std::string& warning = reader->warnings()[0];
  EXPECT_NE(warning.find("no summary section"), std::string::npos) << warning;
  EXPECT_NE(warning.find("stops being readable at byte "), std::string::npos) << warning;
  const std::uint64_t readable = std::stoull(warning.substr(warning.find("readable at byte ") + 17));
  EXPECT_LT(readable, cut_at);
  EXPECT_GT(readable, cut_at - 30000);  // the cut chunk is at most one chunk (4 kB or a cloud) long
  EXPECT_EQ(reader->describe(), "MCAP (no profile), zstd chunks, streamed (no summary)");
  std::size_t total = 0;
  for (const Topic& t : reader->topics()) total += t.message_count;
  EXPECT_GT(total, messages.size() / 3);
  EXPECT_LT(total, messages.size() * 2 / 3);
  expect_same_messages(*reader, messages, total);
  EXPECT_EQ(reader->start_time_ns(), messages.front().t_ns);
  fs::remove_all(dir);
}

TEST(Mcap, FileEndingAfterItsDataSectionKeepsEveryMessage) {
  const fs::path dir = temp_dir("dataend");
  const std::vector<Written> messages = sample_messages(4);
  write_sample(dir / "full.mcap", Compression::kLz4, 8192, messages);
  std::string full = read_raw(dir / "full.mcap");
  const std::uint64_t summary_start = le64(full, full.size() - 8 - 20);
  write_raw(dir / "cut.mcap", full.substr(0, summary_start));
  const auto cut = open_mcap(dir / "cut.mcap");
  ASSERT_EQ(cut->warnings().size(), 1u);
  EXPECT_EQ(cut->warnings()[0].find("stops being readable"), std::string::npos) << cut->warnings()[0];
  expect_same_messages(*cut, messages, messages.size());
  // A whole file whose footer says there is no summary: streamed too, nothing lost.
  put_le64(full, full.size() - 8 - 20, 0);
  write_raw(dir / "nosummary.mcap", full);
  const auto streamed = open_mcap(dir / "nosummary.mcap");
  ASSERT_EQ(streamed->warnings().size(), 1u);
  EXPECT_NE(streamed->warnings()[0].find("summary_start 0"), std::string::npos);
  expect_same_messages(*streamed, messages, messages.size());
  fs::remove_all(dir);
}

// A minimal MCAP builder for layouts insalign's writer never makes (messages outside chunks,
// foreign compressions and encodings).
struct Builder {
  std::string b{"\x89MCAP0\r\n", 8};
  static std::string u16(std::uint16_t v) { return {static_cast<char>(v), static_cast<char>(v >> 8)}; }
  static std::string u32(std::uint32_t v) { return u16(static_cast<std::uint16_t>(v)) + u16(static_cast<std::uint16_t>(v >> 16)); }
  static std::string u64(std::uint64_t v) { return u32(static_cast<std::uint32_t>(v)) + u32(static_cast<std::uint32_t>(v >> 32)); }
  static std::string str(const std::string& s) { return u32(static_cast<std::uint32_t>(s.size())) + s; }
  static std::string record(char opcode, const std::string& content) { return std::string(1, opcode) + u64(content.size()) + content; }
  static std::string message(std::uint16_t channel, std::uint64_t t, const std::string& data) {
    return record(0x05, u16(channel) + u32(0) + u64(t) + u64(t) + data);
  }
  std::size_t add(const std::string& r) {
    b += r;
    return b.size() - r.size();
  }
  void header() { add(record(0x01, str("ros2") + str("test"))); }
  void schema_and_channel(std::uint16_t id, const std::string& topic, const std::string& encoding) {
    add(record(0x03, u16(id) + str("std_msgs/msg/String") + str("ros2msg") + str("string data\n")));
    add(record(0x04, u16(id) + u16(id) + str(topic) + str(encoding) + u32(0)));
  }
  /// Data End, then a footer without summary, then the magic.
  void finish() {
    add(record(0x0F, u32(0)));
    add(record(0x02, u64(0) + u64(0) + u32(0)));
    b += std::string("\x89MCAP0\r\n", 8);
  }
};

TEST(Mcap, MessagesOutsideChunks) {
  Builder f;
  f.header();
  f.schema_and_channel(1, "/a", "cdr");
  f.add(Builder::message(1, 20, "second"));
  f.add(Builder::message(1, 10, "first"));  // out of order on purpose: messages() sorts by log time
  f.schema_and_channel(2, "/b", "cdr");
  f.add(Builder::message(2, 15, "bee"));
  f.finish();
  const fs::path dir = temp_dir("unchunked");
  write_raw(dir / "u.mcap", f.b);
  const auto reader = open_mcap(dir / "u.mcap");
  ASSERT_EQ(reader->topics().size(), 2u);
  const auto a = reader->messages(0);
  ASSERT_EQ(a.size(), 2u);
  EXPECT_EQ(a[0].log_time_ns, 10);
  const Bytes first = reader->read(a[0]), bee = reader->read(reader->messages(1).at(0));
  EXPECT_EQ(std::string(first.begin(), first.end()), "first");
  EXPECT_EQ(std::string(bee.begin(), bee.end()), "bee");
  EXPECT_EQ(reader->start_time_ns(), 10);
  EXPECT_EQ(reader->end_time_ns(), 20);
  EXPECT_EQ(reader->describe(), "MCAP (ros2 profile), no chunks, streamed (no summary)");
  fs::remove_all(dir);
}

TEST(Mcap, SummaryWithoutChunkIndexOrStatistics) {
  Builder f;
  f.header();
  f.schema_and_channel(1, "/a", "cdr");
  const std::string records = Builder::message(1, 5, "chunked");
  f.add(Builder::record(0x06, Builder::u64(5) + Builder::u64(5) + Builder::u64(records.size()) + Builder::u32(0) +
                                  Builder::str("") + Builder::u64(records.size()) + records));
  f.add(Builder::message(1, 7, "loose"));
  f.add(Builder::record(0x0F, Builder::u32(0)));
  const std::size_t summary_start = f.b.size();
  f.schema_and_channel(1, "/a", "cdr");  // the summary: schema and channel only
  f.add(Builder::record(0x02, Builder::u64(summary_start) + Builder::u64(0) + Builder::u32(0)));
  f.b += std::string("\x89MCAP0\r\n", 8);
  const fs::path dir = temp_dir("noindex");
  write_raw(dir / "n.mcap", f.b);
  const auto reader = open_mcap(dir / "n.mcap");
  EXPECT_EQ(reader->describe(), "MCAP (ros2 profile), uncompressed chunks, indexed");
  ASSERT_EQ(reader->topics().size(), 1u);
  EXPECT_EQ(reader->topics()[0].message_count, 2u);
  const auto refs = reader->messages(0);
  ASSERT_EQ(refs.size(), 2u);
  const Bytes a = reader->read(refs[0]), b = reader->read(refs[1]);
  EXPECT_EQ(std::string(a.begin(), a.end()), "chunked");
  EXPECT_EQ(std::string(b.begin(), b.end()), "loose");
  EXPECT_EQ(reader->end_time_ns(), 7);
  fs::remove_all(dir);
}

TEST(Mcap, ForeignMessageEncodingIsListedButNotRead) {
  Builder f;
  f.header();
  f.schema_and_channel(1, "/json", "json");
  f.add(Builder::message(1, 1, "{}"));
  f.finish();
  const fs::path dir = temp_dir("json");
  write_raw(dir / "j.mcap", f.b);
  const auto reader = open_mcap(dir / "j.mcap");
  ASSERT_EQ(reader->topics().size(), 1u);
  EXPECT_EQ(reader->topics()[0].message_count, 1u);
  try {
    (void)reader->read(reader->messages(0).at(0));
    FAIL() << "json message read as ROS";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("'json'"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

// ---------------------------------------------------------------------------------------------
// Corruption

TEST(Mcap, ChunkCrcMismatchNamesTheChunk) {
  const fs::path dir = temp_dir("crc");
  const std::vector<Written> messages = sample_messages(5);
  write_sample(dir / "a.mcap", Compression::kNone, 4096, messages);
  std::string bytes = read_raw(dir / "a.mcap");
  const Bytes& payload = messages[20].data;  // a message in the middle, in an uncompressed chunk
  const std::size_t at = bytes.find(std::string(payload.begin(), payload.end()));
  ASSERT_NE(at, std::string::npos);
  bytes[at + 5] = static_cast<char>(bytes[at + 5] ^ 0x40);
  write_raw(dir / "a.mcap", bytes);
  const auto reader = open_mcap(dir / "a.mcap");  // the summary is intact: opening works
  std::size_t nth = 0;
  for (std::size_t i = 0; i < 20; ++i) nth += messages[i].topic == messages[20].topic;
  const MessageRef ref = reader->messages(messages[20].topic).at(nth);
  try {
    (void)reader->read(ref);
    FAIL() << "corrupt chunk read without error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("CRC mismatch"), std::string::npos) << e.what();
    const std::uint64_t chunk = byte_of(e);
    ASSERT_LT(chunk, at);
    EXPECT_EQ(bytes[chunk], '\x06') << "the offset names the chunk record";
    EXPECT_GT(chunk, at - 4096 - 200);
  }
  fs::remove_all(dir);
}

TEST(Mcap, DamagedCloudChunkKeepsTheSmallMessages) {
  const fs::path dir = temp_dir("ownchunk");
  const std::vector<Written> messages = sample_messages(8);
  write_sample(dir / "a.mcap", Compression::kNone, 4096, messages);
  std::string bytes = read_raw(dir / "a.mcap");
  const Written& cloud = messages[11];  // a 20 kB message: a chunk of its own
  ASSERT_EQ(cloud.topic, 0u);
  const std::size_t at = bytes.find(std::string(cloud.data.begin(), cloud.data.begin() + 64));
  ASSERT_NE(at, std::string::npos);
  bytes[at + 1000] = static_cast<char>(bytes[at + 1000] ^ 0x01);
  write_raw(dir / "a.mcap", bytes);
  const auto reader = open_mcap(dir / "a.mcap");
  for (std::uint32_t t = 1; t < reader->topics().size(); ++t) {
    for (const MessageRef& ref : reader->messages(t)) EXPECT_NO_THROW((void)reader->read(ref));
  }
  const auto clouds = reader->messages(0);
  EXPECT_THROW((void)reader->read(clouds[0]), InputError);
  EXPECT_NO_THROW((void)reader->read(clouds[1]));
  fs::remove_all(dir);
}

// A recorder's chunk holds the INS messages and then a cloud. Reading the INS messages decodes the
// chunk only as far as they go: an lz4 chunk's 4 MB block used to be decoded whole for them (every
// cloud decoded once more per run; speed.md 1e). So a chunk damaged in its cloud's part still
// gives them, and the cloud's own read names the damage.
TEST(Mcap, Lz4ChunkGivesItsSmallMessagesWithoutDecodingTheCloudBehindThem) {
  const fs::path dir = temp_dir("lz4prefix");
  {
    auto writer = make_mcap_writer(dir / "a.mcap", WriterOptions{Compression::kLz4, 16 * 1024, false});  // the recorder's layout
    for (const Topic& t : sample_topics()) writer->add_topic(t);
    for (const Written& m : sample_messages(5)) writer->write(m.topic, m.t_ns, m.data);
    writer->close();
  }
  const std::string intact = read_raw(dir / "a.mcap");
  const auto reference = open_mcap(dir / "a.mcap");
  // A chunk whose last message is a cloud after small ones (the writer closes a chunk once full).
  std::optional<std::uint64_t> locator;
  std::vector<MessageRef> small;
  for (const MessageRef& cloud : reference->messages(0)) {
    small.clear();
    for (std::uint32_t t = 1; t < reference->topics().size(); ++t)
      for (const MessageRef& ref : reference->messages(t))
        if (ref.locator == cloud.locator && ref.locator2 < cloud.locator2) small.push_back(ref);
    if (small.size() >= 10) {
      locator = cloud.locator;
      break;
    }
  }
  ASSERT_TRUE(locator.has_value()) << "no chunk with small messages before a cloud";
  // The locator-th chunk record of the data section (records: opcode, u64 length, content).
  std::size_t at = 8, chunks = 0;  // after the magic
  while (at + 9 <= intact.size() && !(intact[at] == 0x06 && ++chunks == *locator)) at += 9 + le64(intact, at + 1);
  ASSERT_EQ(chunks, *locator);
  const std::size_t compression_at = at + 9 + 8 + 8 + 8 + 4;  // after the times, size and CRC
  ASSERT_EQ(intact.substr(compression_at, 7), std::string("\x03\0\0\0lz4", 7));
  const std::size_t records_at = compression_at + 7 + 8, records_size = static_cast<std::size_t>(le64(intact, compression_at + 7));
  std::string damaged = intact;
  for (std::size_t i = records_size - 48; i < records_size - 8; ++i) damaged[records_at + i] = '\xff';
  write_raw(dir / "b.mcap", damaged);
  const auto reader = open_mcap(dir / "b.mcap");
  std::vector<BagReader::BatchRequest> requests;
  for (const MessageRef& ref : small) requests.push_back({ref, 0});
  std::size_t served = 0;
  reader->read_batch(requests, [&](std::size_t k, Bytes bytes) {
    ++served;
    EXPECT_EQ(bytes, reference->read(requests[k].ref)) << k;
  });
  EXPECT_EQ(served, small.size());
  for (const MessageRef& cloud : reader->messages(0))
    if (cloud.locator == *locator) {
      EXPECT_THROW((void)reader->read(cloud), InputError);
    }
  fs::remove_all(dir);
}

TEST(Mcap, CorruptCompressedChunkIsAnInputError) {
  const fs::path dir = temp_dir("zstdbad");
  write_sample(dir / "a.mcap", Compression::kZstd, 4096, sample_messages(6));
  std::string bytes = read_raw(dir / "a.mcap");
  const std::size_t chunk = bytes.find("\x04\0\0\0zstd", 0, 8);
  ASSERT_NE(chunk, std::string::npos);
  for (std::size_t i = 40; i < 60; ++i) bytes[chunk + i] = static_cast<char>(~bytes[chunk + i]);
  write_raw(dir / "a.mcap", bytes);
  const auto reader = open_mcap(dir / "a.mcap");
  EXPECT_THROW(
      {
        for (std::uint32_t t = 0; t < reader->topics().size(); ++t) {
          for (const MessageRef& ref : reader->messages(t)) (void)reader->read(ref);
        }
      },
      InputError);
  fs::remove_all(dir);
}

TEST(Mcap, BadMagicNamesByteZero) {
  const fs::path dir = temp_dir("magic");
  write_sample(dir / "a.mcap", Compression::kNone, 4096, sample_messages(1));
  std::string bytes = read_raw(dir / "a.mcap");
  bytes[1] = 'N';
  write_raw(dir / "a.mcap", bytes);
  try {
    (void)open_mcap(dir / "a.mcap");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.location(), "byte 0");
    EXPECT_NE(std::string(e.what()).find("magic"), std::string::npos);
  }
  EXPECT_FALSE(is_mcap(bytes));
  EXPECT_TRUE(is_mcap(std::string("\x89MCAP0\r\n", 8) + "more"));
  EXPECT_FALSE(is_mcap("\x89MCAP"));
  fs::remove_all(dir);
}

TEST(Mcap, RecordRunningPastItsSectionNamesIt) {
  const fs::path dir = temp_dir("length");
  write_sample(dir / "a.mcap", Compression::kZstd, 4096, sample_messages(2));
  const std::string good = read_raw(dir / "a.mcap");
  const std::size_t footer = good.size() - 8 - 29;
  const std::uint64_t summary_start = le64(good, footer + 9);
  // Indexed: the first summary record claims more bytes than the summary holds.
  std::string bytes = good;
  put_le64(bytes, summary_start + 1, 1u << 30);
  bytes.replace(footer + 9 + 16, 4, std::string(4, '\0'));  // no summary CRC, so the length is what fails
  write_raw(dir / "a.mcap", bytes);
  try {
    (void)open_mcap(dir / "a.mcap");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(byte_of(e), summary_start) << e.what();
  }
  // The summary CRC catches the same damage when it is there.
  bytes = good;
  put_le64(bytes, summary_start + 1, 1u << 30);
  write_raw(dir / "a.mcap", bytes);
  EXPECT_THROW((void)open_mcap(dir / "a.mcap"), InputError);
  // Streamed but complete (the footer is there): a chunk claiming too much is corruption, not a cut.
  bytes = good;
  put_le64(bytes, footer + 9, 0);
  const std::size_t chunk = bytes.find("\x04\0\0\0zstd", 0, 8) - 9 - 28;
  ASSERT_EQ(bytes[chunk], '\x06');
  put_le64(bytes, chunk + 1, 1ull << 40);
  write_raw(dir / "a.mcap", bytes);
  try {
    (void)open_mcap(dir / "a.mcap");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(byte_of(e), chunk) << e.what();
  }
  fs::remove_all(dir);
}

TEST(Mcap, UnknownCompressionNamesTheChunk) {
  Builder f;
  f.header();
  f.schema_and_channel(1, "/a", "cdr");
  const std::string records = Builder::message(1, 1, "x");
  const std::size_t chunk = f.add(Builder::record(
      0x06, Builder::u64(1) + Builder::u64(1) + Builder::u64(records.size()) + Builder::u32(0) + Builder::str("brotli") +
                Builder::u64(records.size()) + records));
  f.finish();
  const fs::path dir = temp_dir("brotli");
  write_raw(dir / "b.mcap", f.b);
  try {
    (void)open_mcap(dir / "b.mcap");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(byte_of(e), chunk);
    EXPECT_NE(std::string(e.what()).find("'brotli'"), std::string::npos) << e.what();
  }
  // Indexed: the chunk index already says so, at open.
  write_sample(dir / "z.mcap", Compression::kZstd, 4096, sample_messages(2));
  std::string bytes = read_raw(dir / "z.mcap");
  const std::string zstd("\x04\0\0\0zstd", 8), brot("\x04\0\0\0brot", 8);
  const std::size_t first_chunk = bytes.find(zstd) - 9 - 28;
  for (std::size_t at = bytes.find(zstd); at != std::string::npos; at = bytes.find(zstd, at)) bytes.replace(at, 8, brot);
  bytes.replace(bytes.size() - 8 - 4, 4, std::string(4, '\0'));  // drop the summary CRC
  write_raw(dir / "z.mcap", bytes);
  try {
    (void)open_mcap(dir / "z.mcap");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(byte_of(e), first_chunk) << e.what();
    EXPECT_NE(std::string(e.what()).find("'brot'"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace insalign::io::bag
