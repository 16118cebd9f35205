// ROS 1 bag v2.0: the real rosbag-written bags, write/read round trips in each compression, and
// broken bags (cut off, corrupt chunk data, unknown compression).
#include "recording/ros1_bag.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <thread>

#include "core/errors.hpp"

namespace insalign::io::bag {
namespace {

namespace fs = std::filesystem;
using Bytes = std::vector<std::uint8_t>;

const fs::path kRealDir = fs::path(INSALIGN_SHARED_DATA_DIR) / "bags" / "ros1";
// The chunk info's times as python3-rosbag reads them (README: 1396293887.844784, 1396293909.544870).
constexpr std::int64_t kRealStartNs = 1396293887844783943;
constexpr std::int64_t kRealEndNs = 1396293909544870199;

// A fresh folder per test.
fs::path temp_dir() {
  const fs::path dir = fs::temp_directory_path() / ("insalign_ros1_bag_" + std::to_string(::getpid()) + "_" +
                                                   ::testing::UnitTest::GetInstance()->current_test_info()->name());
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string slurp(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void spit(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

// The bag header's index_pos field (its 8 bytes follow "index_pos=").
std::size_t index_pos_offset(const std::string& bag) { return bag.find("index_pos=") + 10; }
std::uint64_t index_pos(const std::string& bag) {
  std::uint64_t v = 0;
  std::memcpy(&v, bag.data() + index_pos_offset(bag), 8);
  return v;
}
void set_index_pos(std::string& bag, std::uint64_t v) { std::memcpy(bag.data() + index_pos_offset(bag), &v, 8); }

// The first chunk record starts right after the magic and the 4096-byte bag header record.
constexpr std::uint64_t kFirstChunkPos = 13 + 4 + 4 + 4096;

struct Expected {
  std::string type;
  std::uint64_t count;
};
const std::map<std::string, Expected> kRealTopics = {
    {"/rosout", {"rosgraph_msgs/Log", 10}},
    {"/tf", {"tf/tfMessage", 2688}},
    {"/tf_static", {"tf2_msgs/TFMessage", 1}},
    {"/turtle1/cmd_vel", {"geometry_msgs/Twist", 357}},
    {"/turtle1/color_sensor", {"turtlesim/Color", 1351}},
    {"/turtle1/pose", {"turtlesim/Pose", 1344}},
    {"/turtle2/cmd_vel", {"geometry_msgs/Twist", 208}},
    {"/turtle2/color_sensor", {"turtlesim/Color", 1344}},
    {"/turtle2/pose", {"turtlesim/Pose", 1344}},
};

// Every message of every topic, keyed by topic name: (log time, bytes) in index order.
using AllMessages = std::map<std::string, std::vector<std::pair<std::int64_t, Bytes>>>;
AllMessages read_all(const BagReader& bag) {
  AllMessages all;
  for (std::uint32_t t = 0; t < bag.topics().size(); ++t) {
    for (const MessageRef& ref : bag.messages(t)) all[bag.topics()[t].name].emplace_back(ref.log_time_ns, bag.read(ref));
  }
  return all;
}

void expect_real_topics(const BagReader& bag) {
  ASSERT_EQ(bag.topics().size(), kRealTopics.size());
  for (std::uint32_t t = 0; t < bag.topics().size(); ++t) {
    const Topic& topic = bag.topics()[t];
    const auto it = kRealTopics.find(topic.name);
    ASSERT_NE(it, kRealTopics.end()) << topic.name;
    EXPECT_EQ(topic.type, it->second.type) << topic.name;
    EXPECT_EQ(topic.message_count, it->second.count) << topic.name;
    EXPECT_EQ(bag.messages(t).size(), it->second.count) << topic.name;
    EXPECT_EQ(topic.encoding, MessageEncoding::kRos1);
    EXPECT_EQ(topic.definition_encoding, "ros1msg");
    EXPECT_EQ(topic.md5sum.size(), 32u) << topic.name;
  }
}

TEST(Ros1Bag, RealBagsTopicsTypesCountsAndTimeRange) {
  if (!fs::exists(kRealDir)) GTEST_SKIP() << "shared bags not found at " << kRealDir;
  for (const char* name : {"example.bag", "example-bz2.bag", "example-lz4.bag"}) {
    SCOPED_TRACE(name);
    const auto bag = open_ros1_bag(kRealDir / name);
    expect_real_topics(*bag);
    EXPECT_EQ(bag->start_time_ns(), kRealStartNs);
    EXPECT_EQ(bag->end_time_ns(), kRealEndNs);
    EXPECT_TRUE(bag->warnings().empty());
  }
  EXPECT_EQ(open_ros1_bag(kRealDir / "example.bag")->describe(), "ROS 1 bag v2.0, uncompressed chunks, indexed");
  EXPECT_EQ(open_ros1_bag(kRealDir / "example-bz2.bag")->describe(), "ROS 1 bag v2.0, bz2 chunks, indexed");
  EXPECT_EQ(open_ros1_bag(kRealDir / "example-lz4.bag")->describe(), "ROS 1 bag v2.0, lz4 chunks, indexed");
}

TEST(Ros1Bag, RealBagsThreeCompressionsGiveIdenticalMessages) {
  if (!fs::exists(kRealDir)) GTEST_SKIP() << "shared bags not found at " << kRealDir;
  const AllMessages none = read_all(*open_ros1_bag(kRealDir / "example.bag"));
  const AllMessages bz2 = read_all(*open_ros1_bag(kRealDir / "example-bz2.bag"));
  const AllMessages lz4 = read_all(*open_ros1_bag(kRealDir / "example-lz4.bag"));
  ASSERT_EQ(none.size(), 9u);
  EXPECT_TRUE(none == bz2);
  EXPECT_TRUE(none == lz4);
  // A turtlesim/Pose is 5 float32: x, y, theta, linear and angular velocity.
  EXPECT_EQ(none.at("/turtle1/pose").front().second.size(), 20u);
  const auto& times = none.at("/tf");
  EXPECT_TRUE(std::is_sorted(times.begin(), times.end(), [](const auto& a, const auto& b) { return a.first < b.first; }));
}

TEST(Ros1Bag, RealBagWithoutMessages) {
  if (!fs::exists(kRealDir)) GTEST_SKIP() << "shared bags not found at " << kRealDir;
  const auto bag = open_ros1_bag(kRealDir / "no-messages.bag");
  EXPECT_TRUE(bag->topics().empty());
  EXPECT_EQ(bag->start_time_ns(), 0);
  EXPECT_EQ(bag->end_time_ns(), 0);
  EXPECT_EQ(bag->describe(), "ROS 1 bag v2.0, no chunks, indexed");
}

// rosbag's own output with its index removed: the scan finds the connections inside the chunk.
TEST(Ros1Bag, RealBagScannedWithoutIndexMatchesIndexedRead) {
  if (!fs::exists(kRealDir)) GTEST_SKIP() << "shared bags not found at " << kRealDir;
  const fs::path dir = temp_dir();
  for (const char* name : {"example.bag", "example-lz4.bag"}) {
    SCOPED_TRACE(name);
    std::string bytes = slurp(kRealDir / name);
    set_index_pos(bytes, 0);
    spit(dir / name, bytes);
    const auto scanned = open_ros1_bag(dir / name);
    expect_real_topics(*scanned);
    ASSERT_EQ(scanned->warnings().size(), 1u);
    EXPECT_NE(scanned->warnings()[0].find("not indexed"), std::string::npos) << scanned->warnings()[0];
    EXPECT_NE(scanned->describe().find("not indexed"), std::string::npos);
    EXPECT_TRUE(read_all(*scanned) == read_all(*open_ros1_bag(kRealDir / name)));
  }
  fs::remove_all(dir);
}

// ---------------------------------------------------------------------------------------------
// Round trips through the writer.

struct Written {
  std::vector<Topic> topics;
  std::vector<std::vector<std::pair<std::int64_t, Bytes>>> messages;  ///< per topic
};

Written write_random_bag(const fs::path& path, Compression compression, std::size_t chunk_bytes, unsigned seed) {
  std::mt19937 rng(seed);
  Written w;
  fs::remove(path);
  for (int i = 0; i < 3; ++i) {
    Topic t;
    t.name = "/topic" + std::to_string(i);
    t.type = i == 0 ? "sensor_msgs/PointCloud2" : "std_msgs/String";
    t.md5sum = std::string(32, static_cast<char>('a' + i));
    t.definition = "string data\n# topic " + std::to_string(i);
    w.topics.push_back(t);
  }
  w.topics.push_back({"/never", "std_msgs/Empty", MessageEncoding::kRos1, "", "", "d41d8cd98f00b204e9800998ecf8427e", 0});
  w.messages.resize(w.topics.size());
  WriterOptions options;
  options.compression = compression;
  options.chunk_bytes = chunk_bytes;
  auto writer = make_ros1_bag_writer(path, options);
  for (const Topic& t : w.topics) writer->add_topic(t);
  std::int64_t t_ns = 1'700'000'000'123'456'789;
  std::uniform_int_distribution<int> byte(0, 255), topic(0, 2), size(0, 3000);
  for (int i = 0; i < 300; ++i) {
    const int k = topic(rng);
    Bytes msg(i == 150 ? 5 * chunk_bytes : static_cast<std::size_t>(size(rng)));  // one larger than a chunk
    for (auto& b : msg) b = static_cast<std::uint8_t>(byte(rng) % (k + 2));       // some compressible
    t_ns += (i % 7 == 0) ? 0 : 1'234'567;                                          // some equal times
    writer->write(static_cast<std::uint32_t>(k), t_ns, msg);
    w.messages[static_cast<std::size_t>(k)].emplace_back(t_ns, std::move(msg));
  }
  EXPECT_FALSE(fs::exists(path)) << "visible before close()";
  writer->close();
  return w;
}

void expect_same(const BagReader& bag, const Written& w) {
  ASSERT_EQ(bag.topics().size(), w.topics.size());
  for (std::uint32_t t = 0; t < w.topics.size(); ++t) {
    const Topic& topic = bag.topics()[t];
    EXPECT_EQ(topic.name, w.topics[t].name);
    EXPECT_EQ(topic.type, w.topics[t].type);
    EXPECT_EQ(topic.md5sum, w.topics[t].md5sum);
    EXPECT_EQ(topic.definition, w.topics[t].definition);
    EXPECT_EQ(topic.definition_encoding, w.topics[t].definition.empty() ? "" : "ros1msg");  // empty: none stored
    EXPECT_EQ(topic.message_count, w.messages[t].size());
    const std::vector<MessageRef> refs = bag.messages(t);
    ASSERT_EQ(refs.size(), w.messages[t].size()) << topic.name;
    for (std::size_t i = 0; i < refs.size(); ++i) {
      EXPECT_EQ(refs[i].log_time_ns, w.messages[t][i].first);
      ASSERT_EQ(bag.read(refs[i]), w.messages[t][i].second) << topic.name << " message " << i;
      const BagReader::SharedMessage shared = bag.read_shared(refs[i]);
      ASSERT_EQ(Bytes(shared.bytes.begin(), shared.bytes.end()), w.messages[t][i].second) << topic.name << " message " << i;
    }
  }
}

// A recorder's bz2 chunk (small messages, then a cloud of several 900 kB bzip2 blocks): the small
// messages and the cloud's first bytes come from a partial decompression, byte for byte what the
// whole chunk holds, and the cloud read whole afterwards is complete.
TEST(Ros1Bag, PrefixesOfMultiBlockBz2ChunksMatchTheMessages) {
  const fs::path dir = temp_dir();
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> byte(0, 255);
  const std::vector<Topic> topics = {
      {"/ins", "std_msgs/String", MessageEncoding::kRos1, "string data\n", "ros1msg", std::string(32, 'a'), 0},
      {"/points", "sensor_msgs/PointCloud2", MessageEncoding::kRos1, "string data\n", "ros1msg", std::string(32, 'b'), 0}};
  std::vector<std::vector<Bytes>> written(2);
  {
    auto writer = make_ros1_bag_writer(dir / "bz2.bag", {Compression::kBz2, 768 * 1024});
    for (const Topic& t : topics) writer->add_topic(t);
    std::int64_t t_ns = 1'700'000'000'000'000'000;
    for (int sweep = 0; sweep < 2; ++sweep) {
      for (int k = 0; k < 10; ++k) {
        Bytes ins(300);
        for (auto& b : ins) b = static_cast<std::uint8_t>(byte(rng));
        writer->write(0, t_ns += 10'000'000, ins);
        written[0].push_back(std::move(ins));
      }
      Bytes cloud(3'000'000);  // about half random: bzip2 keeps it in several blocks
      for (std::size_t i = 0; i < cloud.size(); ++i) cloud[i] = static_cast<std::uint8_t>(i % 2 ? byte(rng) : i / 64);
      writer->write(1, t_ns, cloud);
      written[1].push_back(std::move(cloud));
    }
    writer->close();
  }
  const auto bag = open_ros1_bag(dir / "bz2.bag");
  for (std::uint32_t t = 0; t < 2; ++t) {
    const std::vector<MessageRef> refs = bag->messages(t);
    ASSERT_EQ(refs.size(), written[t].size());
    for (std::size_t i = 0; i < refs.size(); ++i) {
      EXPECT_EQ(bag->read_prefix(refs[i], 64), Bytes(written[t][i].begin(), written[t][i].begin() + 64)) << t << " " << i;
    }
  }
  for (std::uint32_t t = 0; t < 2; ++t) {
    const std::vector<MessageRef> refs = bag->messages(t);
    for (std::size_t i = 0; i < refs.size(); ++i) {
      const BagReader::SharedMessage m = bag->read_shared(refs[i]);
      EXPECT_TRUE(std::equal(m.bytes.begin(), m.bytes.end(), written[t][i].begin(), written[t][i].end())) << t << " " << i;
      EXPECT_EQ(bag->read(refs[i]), written[t][i]) << t << " " << i;
    }
  }
  fs::remove_all(dir);
}

TEST(Ros1Bag, WriteReadRoundTripInEachCompression) {
  const fs::path dir = temp_dir();
  const std::pair<Compression, const char*> kinds[] = {
      {Compression::kNone, "uncompressed"}, {Compression::kBz2, "bz2"}, {Compression::kLz4, "lz4"}};
  int written = 0;
  for (const auto& [compression, name] : kinds) {
    SCOPED_TRACE(name);
    const fs::path path = dir / (std::string(name) + ".bag");
    const Written w = write_random_bag(path, compression, 8192, 7);
    const auto bag = open_ros1_bag(path);
    EXPECT_EQ(bag->describe(), std::string("ROS 1 bag v2.0, ") + name + " chunks, indexed");
    EXPECT_TRUE(bag->warnings().empty());
    expect_same(*bag, w);
    EXPECT_EQ(bag->start_time_ns(), 1'700'000'000'123'456'789);
    std::int64_t last = 0;
    for (const auto& m : w.messages) last = m.empty() ? last : std::max(last, m.back().first);
    EXPECT_EQ(bag->end_time_ns(), last);
    EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), ++written)
        << "a temporary file was left behind";
  }
  fs::remove_all(dir);
}

TEST(Ros1Bag, BagWithTopicsButNoMessages) {
  const fs::path dir = temp_dir();
  auto writer = make_ros1_bag_writer(dir / "empty.bag", {});
  writer->add_topic({"/imu", "sensor_msgs/Imu", MessageEncoding::kRos1, "Header header\n", "ros1msg",
                     "6a62c6daae103f4ff57a132d6f95cec2", 0});
  writer->close();
  const auto bag = open_ros1_bag(dir / "empty.bag");
  ASSERT_EQ(bag->topics().size(), 1u);
  EXPECT_EQ(bag->topics()[0].name, "/imu");
  EXPECT_EQ(bag->topics()[0].definition, "Header header\n");
  EXPECT_EQ(bag->topics()[0].message_count, 0u);
  EXPECT_TRUE(bag->messages(0).empty());
  EXPECT_EQ(bag->describe(), "ROS 1 bag v2.0, no chunks, indexed");
  EXPECT_EQ(bag->start_time_ns(), 0);
  fs::remove_all(dir);
}

TEST(Ros1Bag, ParallelReadsOfACompressedBagAgreeWithSequentialOnes) {
  const fs::path dir = temp_dir();
  const Written w = write_random_bag(dir / "lz4.bag", Compression::kLz4, 4096, 11);
  const auto bag = open_ros1_bag(dir / "lz4.bag");
  std::vector<MessageRef> refs;
  for (std::uint32_t t = 0; t < bag->topics().size(); ++t) {
    for (const MessageRef& r : bag->messages(t)) refs.push_back(r);
  }
  std::vector<Bytes> sequential, parallel(refs.size());
  for (const MessageRef& r : refs) sequential.push_back(bag->read(r));
  std::vector<std::thread> threads;
  for (std::size_t k = 0; k < 4; ++k) {
    threads.emplace_back([&, k] {
      for (std::size_t i = k; i < refs.size(); i += 4) parallel[i] = bag->read(refs[i]);
    });
  }
  for (auto& th : threads) th.join();
  EXPECT_TRUE(parallel == sequential);
  fs::remove_all(dir);
}

TEST(Ros1Bag, WriterRefusesWhatARos1BagCannotHold) {
  const fs::path dir = temp_dir();
  WriterOptions zstd;
  zstd.compression = Compression::kZstd;
  EXPECT_THROW(make_ros1_bag_writer(dir / "z.bag", zstd), InputError);
  auto writer = make_ros1_bag_writer(dir / "a.bag", {});
  Topic cdr{"/x", "std_msgs/msg/String", MessageEncoding::kCdr, "", "", "", 0};
  EXPECT_THROW(writer->add_topic(cdr), InputError);
  writer.reset();  // never closed: nothing left behind
  EXPECT_TRUE(fs::is_empty(dir));
  fs::remove_all(dir);
}

// ---------------------------------------------------------------------------------------------
// Broken bags.

template <typename F>
InputError catch_input_error(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e;
  }
  ADD_FAILURE() << "no InputError thrown";
  return InputError("", "", "");
}

std::uint64_t byte_of(const InputError& e) {
  EXPECT_EQ(e.location().rfind("byte ", 0), 0u) << e.what();
  return e.location().size() > 5 ? std::stoull(e.location().substr(5)) : 0;
}

constexpr OpenOptions kReadCutOff{true};

bool has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// The number after `prefix` in `text` (0 when absent, with a failure).
std::uint64_t number_after(const std::string& text, const std::string& prefix) {
  const std::size_t at = text.find(prefix);
  EXPECT_NE(at, std::string::npos) << prefix << " in: " << text;
  return at == std::string::npos ? 0 : std::stoull(text.substr(at + prefix.size()));
}

// Every message a cut bag lists reads back as written, the lost ones are the last ones; returns
// how many are listed. A scan meets the topics in the order of their first messages: by name.
std::size_t expect_written_prefix(const BagReader& bag, const Written& w) {
  std::size_t listed = 0;
  for (std::uint32_t t = 0; t < bag.topics().size(); ++t) {
    const auto refs = bag.messages(t);
    const auto& written = w.messages[bag.topics()[t].name.back() - '0'];
    EXPECT_LE(refs.size(), written.size());
    for (std::size_t i = 0; i < refs.size() && i < written.size(); ++i) EXPECT_EQ(bag.read(refs[i]), written[i].second);
    listed += refs.size();
  }
  return listed;
}

// A bag cut off in the middle of a chunk (its index lost with it): exit 2 by default, naming the
// cut chunk's byte, the file's end and the way on; input.read_cut_off reads the whole chunks
// before it with a warning.
TEST(Ros1Bag, CutOffMidChunkIsAnErrorUnlessReadCutOff) {
  const fs::path dir = temp_dir();
  for (Compression compression : {Compression::kNone, Compression::kLz4}) {
    SCOPED_TRACE(static_cast<int>(compression));
    const Written w = write_random_bag(dir / "full.bag", compression, 8192, 3);
    const std::string full = slurp(dir / "full.bag");
    const std::size_t cut = index_pos(full) * 2 / 3;
    spit(dir / "cut.bag", full.substr(0, cut));
    const InputError e = catch_input_error([&] { (void)open_ros1_bag(dir / "cut.bag"); });
    const std::string what = e.what();
    EXPECT_EQ(e.file(), (dir / "cut.bag").string());
    const std::uint64_t chunk_at = byte_of(e);
    EXPECT_LT(chunk_at, cut);
    EXPECT_GT(chunk_at + 7 * 8192, cut);  // at most the big message's chunk back
    EXPECT_TRUE(has(what, "cut off mid-chunk: the chunk starting at byte " + std::to_string(chunk_at))) << what;
    EXPECT_TRUE(has(what, "the file ends at byte " + std::to_string(cut))) << what;
    EXPECT_TRUE(has(what, compression == Compression::kLz4 ? "(lz4 compression)" : "(none compression)")) << what;
    EXPECT_TRUE(has(what, "`rosbag reindex` cannot recover a partial chunk")) << what;
    const std::uint64_t whole = number_after(what, "--set input.read_cut_off=true reads the ");

    const auto bag = open_ros1_bag(dir / "cut.bag", kReadCutOff);
    ASSERT_EQ(bag->warnings().size(), 1u);
    const std::string& warning = bag->warnings()[0];
    EXPECT_TRUE(has(warning, "lies past the end of the file")) << warning;
    EXPECT_TRUE(has(warning, "read " + std::to_string(whole) + " chunks in file order")) << warning;
    EXPECT_EQ(number_after(warning, "stopped at byte "), chunk_at) << warning;
    EXPECT_TRUE(has(warning, "input.read_cut_off")) << warning;
    const std::size_t listed = expect_written_prefix(*bag, w);
    EXPECT_TRUE(has(what, "(" + std::to_string(listed) + " messages over ")) << what;
    std::size_t total = 0;
    for (const auto& m : w.messages) total += m.size();
    EXPECT_GT(listed, total / 3);
    EXPECT_LT(listed, total);
  }
  fs::remove_all(dir);
}

// Not closed (index_pos 0, or the index gone) but ending where a chunk starts, or inside the
// index data behind a whole chunk: no message is lost, it is read with a warning.
TEST(Ros1Bag, UnclosedBagEndingAtAChunkBoundaryIsReadWithAWarning) {
  const fs::path dir = temp_dir();
  const Written w = write_random_bag(dir / "full.bag", Compression::kLz4, 8192, 3);
  std::string full = slurp(dir / "full.bag");
  const std::uint64_t index = index_pos(full);
  spit(dir / "cut.bag", full.substr(0, index * 2 / 3));
  const std::string scanned = open_ros1_bag(dir / "cut.bag", kReadCutOff)->warnings().at(0);
  const std::uint64_t boundary = number_after(scanned, "stopped at byte ");  // where the cut chunk starts
  const std::uint64_t chunks = number_after(scanned, "read ");
  const AllMessages expected = read_all(*open_ros1_bag(dir / "cut.bag", kReadCutOff));
  set_index_pos(full, 0);
  struct Case {
    std::uint64_t end;
    const char* says;
  };
  for (const Case& c : {Case{boundary, "to the end of the file"}, Case{boundary - 5, "stopped at byte "}}) {
    SCOPED_TRACE(c.end);
    spit(dir / "unclosed.bag", full.substr(0, c.end));
    const auto bag = open_ros1_bag(dir / "unclosed.bag");
    ASSERT_EQ(bag->warnings().size(), 1u);
    const std::string& warning = bag->warnings()[0];
    EXPECT_TRUE(has(warning, "index_pos is 0: the recording was not closed")) << warning;
    EXPECT_TRUE(has(warning, "read " + std::to_string(chunks) + " chunks in file order, " + c.says)) << warning;
    EXPECT_FALSE(has(warning, "read_cut_off")) << warning;
    EXPECT_TRUE(read_all(*bag) == expected);
  }
  // The whole bag without its index: every message.
  spit(dir / "unindexed.bag", full.substr(0, index));
  const auto all = open_ros1_bag(dir / "unindexed.bag");
  EXPECT_TRUE(has(all->warnings().at(0), "to the end of the file")) << all->warnings()[0];
  EXPECT_EQ(expect_written_prefix(*all, w), 300u);
  fs::remove_all(dir);
}

// rosbag killed while recording: index_pos 0, the last chunk's header still says 0 bytes (rosbag
// rewrites it when the chunk closes) and its data is cut mid-record. The file ends inside a chunk:
// an error by default; input.read_cut_off keeps the unfinished uncompressed chunk's whole records.
TEST(Ros1Bag, UnclosedRecordingKeepsTheUnfinishedUncompressedChunksWholeRecords) {
  const fs::path dir = temp_dir();
  const Written w = write_random_bag(dir / "full.bag", Compression::kNone, 1u << 20, 5);
  std::string bag = slurp(dir / "full.bag");
  // One chunk: zero its sizes, drop the index and cut the data in the middle of a record.
  const std::size_t size_field = bag.find("size=", kFirstChunkPos) + 5;
  std::memset(bag.data() + size_field, 0, 4);
  const std::size_t header_len = static_cast<unsigned char>(bag[kFirstChunkPos]);
  std::memset(bag.data() + kFirstChunkPos + 4 + header_len, 0, 4);
  set_index_pos(bag, 0);
  const std::size_t cut = index_pos(slurp(dir / "full.bag")) / 2 + 7;
  spit(dir / "unclosed.bag", bag.substr(0, cut));
  const InputError e = catch_input_error([&] { (void)open_ros1_bag(dir / "unclosed.bag"); });
  EXPECT_EQ(byte_of(e), kFirstChunkPos);
  EXPECT_TRUE(has(e.what(), "was never finished")) << e.what();
  EXPECT_TRUE(has(e.what(), "the file ends at byte " + std::to_string(cut))) << e.what();
  EXPECT_TRUE(has(e.what(), "no whole chunk comes before it")) << e.what();

  const auto reader = open_ros1_bag(dir / "unclosed.bag", kReadCutOff);
  ASSERT_EQ(reader->warnings().size(), 1u);
  EXPECT_NE(reader->warnings()[0].find("index_pos is 0"), std::string::npos) << reader->warnings()[0];
  EXPECT_NE(reader->warnings()[0].find("read up to its last whole record"), std::string::npos);
  const std::size_t listed = expect_written_prefix(*reader, w);
  EXPECT_GT(listed, 100u);
  EXPECT_LT(listed, 300u);
  fs::remove_all(dir);
}

// A cut inside a chunk's header: too little is left to tell the record, it counts as a cut chunk.
TEST(Ros1Bag, CutInsideAChunkHeaderIsACutChunk) {
  const fs::path dir = temp_dir();
  write_random_bag(dir / "full.bag", Compression::kBz2, 8192, 3);
  std::string full = slurp(dir / "full.bag");
  set_index_pos(full, 0);
  spit(dir / "cut.bag", full.substr(0, kFirstChunkPos + 2));
  InputError e = catch_input_error([&] { (void)open_ros1_bag(dir / "cut.bag"); });
  EXPECT_EQ(byte_of(e), kFirstChunkPos);
  EXPECT_TRUE(has(e.what(), "its header is cut off: most likely a chunk")) << e.what();
  // The writer's chunk header: compression (19 bytes), size (13), op (8); then the data length.
  spit(dir / "cut.bag", full.substr(0, kFirstChunkPos + 4 + 40 + 2));
  e = catch_input_error([&] { (void)open_ros1_bag(dir / "cut.bag"); });
  EXPECT_EQ(byte_of(e), kFirstChunkPos);
  EXPECT_TRUE(has(e.what(), "cut off mid-chunk: the chunk starting at byte " + std::to_string(kFirstChunkPos) +
                                " (bz2 compression) is cut before its data length")) << e.what();
  fs::remove_all(dir);
}

// The index survives but a chunk is cut short (bytes lost from the middle of the file).
TEST(Ros1Bag, TruncatedChunkUnderAnIntactIndexIsAnErrorWithItsByte) {
  const fs::path dir = temp_dir();
  write_random_bag(dir / "full.bag", Compression::kNone, 8192, 9);
  const std::string full = slurp(dir / "full.bag");
  const std::uint64_t index = index_pos(full);
  const std::size_t cut = index / 2;
  std::string broken = full.substr(0, cut) + full.substr(index);
  set_index_pos(broken, cut);
  spit(dir / "broken.bag", broken);
  const InputError e = catch_input_error([&] { (void)open_ros1_bag(dir / "broken.bag"); });
  EXPECT_EQ(e.file(), (dir / "broken.bag").string());
  EXPECT_LE(byte_of(e), broken.size());
  EXPECT_GE(byte_of(e), kFirstChunkPos);
  fs::remove_all(dir);
}

TEST(Ros1Bag, CorruptCompressedChunkIsAnErrorAtTheChunk) {
  const fs::path dir = temp_dir();
  for (Compression compression : {Compression::kBz2, Compression::kLz4}) {
    write_random_bag(dir / "ok.bag", compression, 1u << 16, 4);
    std::string bytes = slurp(dir / "ok.bag");
    for (std::size_t i = 300; i < 340; ++i) bytes[kFirstChunkPos + i] = static_cast<char>(bytes[kFirstChunkPos + i] ^ 0x5a);
    spit(dir / "corrupt.bag", bytes);
    const auto bag = open_ros1_bag(dir / "corrupt.bag");  // the index is intact
    MessageRef first = bag->messages(0).front();  // the earliest message is in the first chunk
    for (std::uint32_t t = 1; t < 3; ++t) {
      if (bag->messages(t).front().log_time_ns < first.log_time_ns) first = bag->messages(t).front();
    }
    const InputError e = catch_input_error([&] { (void)bag->read(first); });
    EXPECT_EQ(e.file(), (dir / "corrupt.bag").string());
    EXPECT_EQ(byte_of(e), kFirstChunkPos) << e.what();
  }
  fs::remove_all(dir);
}

TEST(Ros1Bag, UnknownCompressionIsAnErrorNamingIt) {
  const fs::path dir = temp_dir();
  write_random_bag(dir / "ok.bag", Compression::kLz4, 1u << 16, 4);
  std::string bytes = slurp(dir / "ok.bag");
  const std::size_t at = bytes.find("compression=lz4");
  ASSERT_NE(at, std::string::npos);
  bytes.replace(at, 15, "compression=xyz");
  spit(dir / "xyz.bag", bytes);
  const InputError e = catch_input_error([&] { (void)open_ros1_bag(dir / "xyz.bag"); });
  EXPECT_EQ(e.file(), (dir / "xyz.bag").string());
  EXPECT_EQ(byte_of(e), kFirstChunkPos);
  EXPECT_NE(std::string(e.what()).find("compression=xyz"), std::string::npos) << e.what();
  fs::remove_all(dir);
}

TEST(Ros1Bag, NotABagAndOpCodesOutOfPlace) {
  const fs::path dir = temp_dir();
  spit(dir / "text.bag", "hello, this is not a bag\n");
  EXPECT_EQ(byte_of(catch_input_error([&] { (void)open_ros1_bag(dir / "text.bag"); })), 0u);
  EXPECT_FALSE(is_ros1_bag("#ROSBAG V1.2\n"));
  EXPECT_TRUE(is_ros1_bag(std::string(ros1::kMagic) + "rest"));
  // index_pos pointing at the first chunk: a chunk where connections and chunk infos belong.
  write_random_bag(dir / "ok.bag", Compression::kNone, 8192, 4);
  std::string bytes = slurp(dir / "ok.bag");
  set_index_pos(bytes, kFirstChunkPos);
  spit(dir / "misplaced.bag", bytes);
  const InputError e = catch_input_error([&] { (void)open_ros1_bag(dir / "misplaced.bag"); });
  EXPECT_EQ(byte_of(e), kFirstChunkPos);
  EXPECT_NE(std::string(e.what()).find("out of place"), std::string::npos) << e.what();
  fs::remove_all(dir);
}

}  // namespace
}  // namespace insalign::io::bag
