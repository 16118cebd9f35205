// rosbag2 storage: the real bags written by `ros2 bag` (sqlite3 of every schema, split folders,
// MCAP folders), the writer's round trip, and the ways a bag can be broken.
#include "recording/rosbag2.hpp"

#include <gtest/gtest.h>
#include <sqlite3.h>
#include <unistd.h>

#include <cstring>
#include <fstream>
#include <map>
#include <random>
#include <thread>

#include "core/errors.hpp"
#include "recording/bag_reader.hpp"
#include "recording/bag_writer.hpp"

namespace insalign::io::bag {
namespace {

namespace fs = std::filesystem;

const fs::path kBags = fs::path(INSALIGN_SHARED_DATA_DIR) / "bags" / "rosbag2";

fs::path temp_dir(const std::string& tag) {
  const fs::path dir = fs::temp_directory_path() / ("insalign_rosbag2_" + tag + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

std::map<std::string, const Topic*> by_name(const BagReader& bag) {
  std::map<std::string, const Topic*> out;
  for (const Topic& t : bag.topics()) out[t.name] = &t;
  return out;
}

std::uint32_t topic_index(const BagReader& bag, const std::string& name) {
  for (std::uint32_t i = 0; i < bag.topics().size(); ++i) {
    if (bag.topics()[i].name == name) return i;
  }
  ADD_FAILURE() << "no topic " << name;
  return 0;
}

// A CDR std_msgs/String: encapsulation header, uint32 length (with the NUL), the characters.
std::string cdr_string(const std::vector<std::uint8_t>& bytes) {
  if (bytes.size() < 9) return "<short>";
  std::uint32_t n = 0;
  std::memcpy(&n, bytes.data() + 4, 4);
  if (n == 0 || 8 + n > bytes.size()) return "<bad length>";
  return std::string(reinterpret_cast<const char*>(bytes.data() + 8), n - 1);
}

#define SKIP_WITHOUT(dir) \
  if (!fs::exists(dir)) GTEST_SKIP() << "shared bags not found at " << (dir)

void expect_talker(const BagReader& bag) {
  const auto topics = by_name(bag);
  ASSERT_EQ(topics.size(), 3u);
  ASSERT_TRUE(topics.count("/rosout") && topics.count("/parameter_events") && topics.count("/topic"));
  EXPECT_EQ(topics.at("/rosout")->type, "rcl_interfaces/msg/Log");
  EXPECT_EQ(topics.at("/rosout")->message_count, 10u);
  EXPECT_EQ(topics.at("/parameter_events")->type, "rcl_interfaces/msg/ParameterEvent");
  EXPECT_EQ(topics.at("/parameter_events")->message_count, 0u);
  EXPECT_EQ(topics.at("/topic")->type, "std_msgs/msg/String");
  EXPECT_EQ(topics.at("/topic")->message_count, 10u);
  EXPECT_EQ(topics.at("/topic")->encoding, MessageEncoding::kCdr);
  EXPECT_EQ(bag.start_time_ns(), 1585866235112411371);
  EXPECT_EQ(bag.end_time_ns(), 1585866239643508139);  // 4.531 s, as metadata.yaml says
  const auto refs = bag.messages(topic_index(bag, "/topic"));
  ASSERT_EQ(refs.size(), 10u);
  for (std::size_t i = 0; i < refs.size(); ++i) {
    EXPECT_EQ(cdr_string(bag.read(refs[i])), "Hello, world! " + std::to_string(i));
    if (i > 0) {
      EXPECT_GE(refs[i].log_time_ns, refs[i - 1].log_time_ns);
    }
  }
  EXPECT_EQ(refs.front().log_time_ns, 1585866235112609068);
  EXPECT_TRUE(bag.messages(topic_index(bag, "/parameter_events")).empty());
}

TEST(Rosbag2, RealTalkerDb3FolderWithMetadata) {
  SKIP_WITHOUT(kBags / "talker-db3");
  const auto bag = open_bag(kBags / "talker-db3");
  expect_talker(*bag);
  const auto topics = by_name(*bag);
  // rosbag2's test resource stores stub definitions; they are passed on as stored.
  EXPECT_EQ(topics.at("/topic")->definition, "string data");
  EXPECT_EQ(topics.at("/topic")->definition_encoding, "ros2msg");
  EXPECT_NE(bag->describe().find("schema version 4, distro rolling"), std::string::npos) << bag->describe();
  EXPECT_EQ(bag->path(), kBags / "talker-db3");
}

TEST(Rosbag2, RealSingleDb3AndItsFolderAgree) {
  SKIP_WITHOUT(kBags / "talker-db3");
  const auto file = open_bag(kBags / "talker-db3" / "talker.db3");
  const auto folder = open_bag(kBags / "talker-db3");
  expect_talker(*file);
  EXPECT_EQ(file->describe(), "rosbag2 sqlite3 (schema version 4, distro rolling)");
  ASSERT_EQ(file->topics().size(), folder->topics().size());
  for (std::uint32_t t = 0; t < file->topics().size(); ++t) {
    EXPECT_EQ(file->topics()[t].name, folder->topics()[t].name);
    EXPECT_EQ(file->topics()[t].message_count, folder->topics()[t].message_count);
    const auto a = file->messages(t), b = folder->messages(t);
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t i = 0; i < a.size(); ++i) {
      EXPECT_EQ(a[i].log_time_ns, b[i].log_time_ns);
      EXPECT_EQ(file->read(a[i]), folder->read(b[i]));
    }
  }
  // The yaml of a folder stands for the folder.
  EXPECT_EQ(open_bag(kBags / "talker-db3" / "metadata.yaml")->topics().size(), 3u);
}

TEST(Rosbag2, RealCdrTestDb3WithDefinitions) {
  SKIP_WITHOUT(kBags / "cdr-test-db3");
  const auto bag = open_bag(kBags / "cdr-test-db3");
  const auto topics = by_name(*bag);
  ASSERT_EQ(topics.size(), 2u);
  EXPECT_EQ(topics.at("/test_topic")->type, "test_msgs/msg/BasicTypes");
  EXPECT_EQ(topics.at("/test_topic")->message_count, 3u);
  EXPECT_EQ(topics.at("/array_topic")->type, "test_msgs/msg/Arrays");
  EXPECT_EQ(topics.at("/array_topic")->message_count, 4u);
  EXPECT_EQ(topics.at("/test_topic")->definition.rfind("bool bool_value\nbyte byte_value\n", 0), 0u);
  EXPECT_EQ(topics.at("/array_topic")->definition.size(), 2462u);
  EXPECT_EQ(topics.at("/array_topic")->definition_encoding, "ros2msg");
  EXPECT_EQ(bag->start_time_ns(), 1586406456763032325);
  EXPECT_EQ(bag->end_time_ns(), 1586406456763032325 + 151137181);  // metadata.yaml's duration
  for (std::uint32_t t = 0; t < 2; ++t) {
    for (const MessageRef& ref : bag->messages(t)) EXPECT_GT(bag->read(ref).size(), 4u);
  }
}

TEST(Rosbag2, RealSplitOldSchemaFolderWithoutMetadata) {
  SKIP_WITHOUT(kBags / "split-db3-no-metadata");
  const auto bag = open_bag(kBags / "split-db3-no-metadata");
  ASSERT_EQ(bag->topics().size(), 1u);  // the three files' /chatter merged into one topic
  const Topic& chatter = bag->topics()[0];
  EXPECT_EQ(chatter.name, "/chatter");
  EXPECT_EQ(chatter.type, "std_msgs/msg/String");
  EXPECT_EQ(chatter.message_count, 1324u + 1324u + 529u);
  EXPECT_TRUE(chatter.definition.empty());
  EXPECT_TRUE(chatter.definition_encoding.empty());
  EXPECT_EQ(bag->start_time_ns(), 1616653333034080451);
  EXPECT_EQ(bag->end_time_ns(), 1616653339386193357);
  EXPECT_NE(bag->describe().find("3 files"), std::string::npos) << bag->describe();
  EXPECT_NE(bag->describe().find("old schema: no message definitions"), std::string::npos) << bag->describe();
  const auto refs = bag->messages(0);
  ASSERT_EQ(refs.size(), 3177u);
  std::map<std::uint64_t, std::size_t> per_file;
  for (std::size_t i = 0; i < refs.size(); ++i) {
    ++per_file[refs[i].locator2];
    if (i > 0) {
      ASSERT_GE(refs[i].log_time_ns, refs[i - 1].log_time_ns) << i;
    }
  }
  EXPECT_EQ(per_file, (std::map<std::uint64_t, std::size_t>{{0, 1324}, {1, 1324}, {2, 529}}));
  EXPECT_EQ(refs.front().locator2, 0u);
  EXPECT_EQ(refs.back().locator2, 2u);
  EXPECT_EQ(refs.back().log_time_ns, 1616653339386193357);
  EXPECT_EQ(cdr_string(bag->read(refs.front())), "test");
  EXPECT_EQ(cdr_string(bag->read(refs[1324])), "test");  // first of the second file
  EXPECT_EQ(bag->read_prefix(refs[1324], 6), std::vector<std::uint8_t>({0, 1, 0, 0, 5, 0}));
  EXPECT_EQ(cdr_string(bag->read(refs.back())), "test");
  // One file alone is an old-schema bag of its own.
  const auto part = open_bag(kBags / "split-db3-no-metadata" / "multiple_files_1.db3");
  EXPECT_EQ(part->topics().at(0).message_count, 1324u);
  EXPECT_EQ(part->describe(), "rosbag2 sqlite3 (old schema: no message definitions)");
}

TEST(Rosbag2, RealAutowareOdometrySchema3) {
  SKIP_WITHOUT(kBags / "autoware-odometry-db3");
  for (const fs::path& path :
       {kBags / "autoware-odometry-db3", kBags / "autoware-odometry-db3" / "bag_ego_trajectory.db3"}) {
    const auto bag = open_bag(path);
    ASSERT_EQ(bag->topics().size(), 1u);
    EXPECT_EQ(bag->topics()[0].name, "/localization/kinematic_state");
    EXPECT_EQ(bag->topics()[0].type, "nav_msgs/msg/Odometry");
    EXPECT_EQ(normalized_type(bag->topics()[0].type), "nav_msgs/Odometry");
    EXPECT_EQ(bag->topics()[0].message_count, 2130u);
    EXPECT_TRUE(bag->topics()[0].definition.empty());
    EXPECT_EQ(bag->start_time_ns(), 1746721937599626818);
    EXPECT_EQ(bag->end_time_ns(), 1746721990824595166);
    EXPECT_NE(bag->describe().find("schema version 3, distro humble"), std::string::npos) << bag->describe();
    const auto refs = bag->messages(0);
    ASSERT_EQ(refs.size(), 2130u);
    // CDR nav_msgs/Odometry: header (stamp, "map"), "base_link", then pose.position at byte 36.
    const std::vector<std::uint8_t> first = bag->read(refs.front()), last = bag->read(refs.back());
    ASSERT_GT(first.size(), 60u);
    EXPECT_EQ(std::string(reinterpret_cast<const char*>(first.data()) + 16, 3), "map");
    EXPECT_EQ(std::string(reinterpret_cast<const char*>(first.data()) + 24, 9), "base_link");
    double x = 0, y = 0;
    std::memcpy(&x, first.data() + 36, 8);
    std::memcpy(&y, first.data() + 44, 8);
    EXPECT_NEAR(x, 966.5026, 1e-4);
    EXPECT_NEAR(y, 1036.0884, 1e-4);
    std::memcpy(&x, last.data() + 36, 8);
    EXPECT_NEAR(x, 1091.8456, 1e-4);
  }
}

void expect_mcap_folder(const fs::path& folder,
                        const std::map<std::string, std::pair<std::string, std::uint64_t>>& want) {
  const auto bag = open_bag(folder);
  const auto topics = by_name(*bag);
  ASSERT_EQ(topics.size(), want.size()) << bag->describe();
  std::uint64_t total = 0;
  for (const auto& [name, type_count] : want) {
    ASSERT_TRUE(topics.count(name)) << name;
    EXPECT_EQ(topics.at(name)->type, type_count.first);
    EXPECT_EQ(topics.at(name)->message_count, type_count.second);
    EXPECT_EQ(topics.at(name)->encoding, MessageEncoding::kCdr);
    const auto refs = bag->messages(topic_index(*bag, name));
    EXPECT_EQ(refs.size(), type_count.second);
    for (const MessageRef& ref : refs) {
      EXPECT_GT(bag->read(ref).size(), 4u);
      EXPECT_EQ(ref.locator2, 0u);
    }
    total += refs.size();
  }
  EXPECT_GT(total, 0u);
}

TEST(Rosbag2, RealMcapFolders) {
  SKIP_WITHOUT(kBags / "talker-mcap");
  expect_mcap_folder(kBags / "talker-mcap", {{"/rosout", {"rcl_interfaces/msg/Log", 10}},
                                             {"/parameter_events", {"rcl_interfaces/msg/ParameterEvent", 0}},
                                             {"/topic", {"std_msgs/msg/String", 10}}});
  const auto talker = open_bag(kBags / "talker-mcap");
  EXPECT_EQ(talker->start_time_ns(), 1585866235112411371);
  EXPECT_EQ(talker->end_time_ns(), 1585866235112411371 + 4531096768);
  const auto refs = talker->messages(topic_index(*talker, "/topic"));
  ASSERT_EQ(refs.size(), 10u);
  EXPECT_EQ(cdr_string(talker->read(refs[3])), "Hello, world! 3");
  expect_mcap_folder(kBags / "cdr-test-mcap",
                     {{"/test_topic", {"test_msgs/msg/BasicTypes", 3}}, {"/array_topic", {"test_msgs/msg/Arrays", 4}}});
}

std::vector<std::uint8_t> pattern_bytes(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<std::uint8_t> out(n);
  for (auto& b : out) b = static_cast<std::uint8_t>(rng());
  return out;
}

TEST(Rosbag2, WriterRoundTrip) {
  const fs::path dir = temp_dir("roundtrip");
  const fs::path folder = dir / "drive";
  Topic points{"/points",
               "sensor_msgs/PointCloud2",
               MessageEncoding::kCdr,
               "std_msgs/Header header\nuint32 height\n",
               "ros2msg",
               "",
               0};
  Topic imu{"/imu", "sensor_msgs/msg/Imu", MessageEncoding::kCdr, "", "", "", 0};
  {
    auto writer = make_bag_writer(BagFormat::kDb3, folder);
    const std::uint32_t p = writer->add_topic(points), i = writer->add_topic(imu);
    writer->write(i, 1'000'000'000, pattern_bytes(100, 1));
    writer->write(p, 1'050'000'000, pattern_bytes(3'000'000, 2));  // a sweep-sized blob
    writer->write(i, 1'050'000'000, {});                           // same time, empty message
    writer->write(i, 2'000'000'000, pattern_bytes(7, 3));
    EXPECT_THROW(writer->write(i, 1'999'999'999, {1}), InputError);  // time went backwards
    EXPECT_FALSE(fs::exists(folder));                                // nothing visible before close
    writer->close();
  }
  ASSERT_TRUE(fs::exists(folder / "metadata.yaml"));
  ASSERT_TRUE(fs::exists(folder / "drive_0.db3"));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);  // no temporary left
  const auto bag = open_bag(folder);
  const auto topics = by_name(*bag);
  ASSERT_EQ(topics.size(), 2u);
  EXPECT_EQ(topics.at("/points")->type, "sensor_msgs/msg/PointCloud2");  // stored in the ROS 2 form
  EXPECT_EQ(topics.at("/points")->definition, points.definition);
  EXPECT_EQ(topics.at("/points")->definition_encoding, "ros2msg");
  EXPECT_EQ(topics.at("/imu")->definition, "");
  EXPECT_EQ(topics.at("/imu")->message_count, 3u);
  EXPECT_EQ(bag->start_time_ns(), 1'000'000'000);
  EXPECT_EQ(bag->end_time_ns(), 2'000'000'000);
  EXPECT_NE(bag->describe().find("schema version 4, distro humble"), std::string::npos) << bag->describe();
  const auto imu_refs = bag->messages(topic_index(*bag, "/imu"));
  ASSERT_EQ(imu_refs.size(), 3u);
  EXPECT_EQ(bag->read(imu_refs[0]), pattern_bytes(100, 1));
  EXPECT_TRUE(bag->read(imu_refs[1]).empty());
  EXPECT_EQ(bag->read(imu_refs[2]), pattern_bytes(7, 3));
  const auto point_refs = bag->messages(topic_index(*bag, "/points"));
  ASSERT_EQ(point_refs.size(), 1u);
  EXPECT_EQ(point_refs[0].log_time_ns, 1'050'000'000);
  const std::vector<std::uint8_t> cloud = pattern_bytes(3'000'000, 2);
  EXPECT_EQ(bag->read(point_refs[0]), cloud);
  EXPECT_EQ(bag->read_prefix(point_refs[0], 64), std::vector<std::uint8_t>(cloud.begin(), cloud.begin() + 64));
  EXPECT_EQ(bag->read_prefix(imu_refs[2], 64), pattern_bytes(7, 3));  // shorter than asked: all of it
  EXPECT_TRUE(bag->read_prefix(imu_refs[1], 64).empty());
  // The yaml holds what `ros2 bag info` needs.
  std::ifstream in(folder / "metadata.yaml");
  const std::string yaml((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const Rosbag2Metadata m = parse_rosbag2_metadata(yaml, "metadata.yaml");
  EXPECT_EQ(m.version, 5);
  EXPECT_EQ(m.storage_identifier, "sqlite3");
  EXPECT_EQ(m.message_count, 4u);
  EXPECT_EQ(m.relative_file_paths, std::vector<std::string>{"drive_0.db3"});
  for (const char* key : {"duration:\n", "nanoseconds: 1000000000", "nanoseconds_since_epoch: 1000000000",
                          "topics_with_message_count:", "offered_qos_profiles:", "message_count: 3"}) {
    EXPECT_NE(yaml.find(key), std::string::npos) << key << " in\n" << yaml;
  }
  fs::remove_all(dir);
}

TEST(Rosbag2, WriterReplacesABagButNothingElse) {
  const fs::path dir = temp_dir("replace");
  Topic t{"/a", "std_msgs/msg/String", MessageEncoding::kCdr, "", "", "", 0};
  for (int round = 0; round < 2; ++round) {  // the second round replaces the first bag
    auto writer = make_bag_writer(BagFormat::kDb3, dir / "bag");
    const std::uint32_t id = writer->add_topic(t);
    for (int k = 0; k <= round; ++k) writer->write(id, 10 + k, {std::uint8_t(k)});
    writer->close();
  }
  EXPECT_EQ(open_bag(dir / "bag")->topics().at(0).message_count, 2u);
  fs::create_directories(dir / "photos");
  write_text(dir / "photos" / "cat.jpg", "jpeg");
  EXPECT_THROW(make_bag_writer(BagFormat::kDb3, dir / "photos"), InputError);
  EXPECT_TRUE(fs::exists(dir / "photos" / "cat.jpg"));
  Topic ros1 = t;
  ros1.encoding = MessageEncoding::kRos1;
  EXPECT_THROW(make_bag_writer(BagFormat::kDb3, dir / "ros1")->add_topic(ros1), InputError);
  EXPECT_THROW(make_bag_writer(BagFormat::kDb3, dir / "zstd", WriterOptions{Compression::kZstd}), InputError);
  {
    auto abandoned = make_bag_writer(BagFormat::kDb3, dir / "abandoned");
    abandoned->add_topic(t);
  }  // destroyed without close(): leaves nothing
  EXPECT_FALSE(fs::exists(dir / "abandoned"));
  std::size_t entries = 0;
  for (const auto& e : fs::directory_iterator(dir)) entries += e.path().filename().string().front() == '.' ? 100 : 1;
  EXPECT_EQ(entries, 2u);  // bag and photos, no hidden temporaries
  fs::remove_all(dir);
}

TEST(Rosbag2, ParallelReadsOfLargeBlobs) {
  const fs::path dir = temp_dir("parallel");
  constexpr int kMessages = 12;
  constexpr std::size_t kBytes = 3'000'000;
  {
    auto writer = make_bag_writer(BagFormat::kDb3, dir / "bag");
    const std::uint32_t id =
        writer->add_topic({"/points", "sensor_msgs/msg/PointCloud2", MessageEncoding::kCdr, "", "", "", 0});
    for (int k = 0; k < kMessages; ++k) writer->write(id, k, pattern_bytes(kBytes, static_cast<unsigned>(k)));
    writer->close();
  }
  const auto bag = open_bag(dir / "bag" / "bag_0.db3");
  const auto refs = bag->messages(0);
  ASSERT_EQ(refs.size(), static_cast<std::size_t>(kMessages));
  std::vector<std::vector<std::uint8_t>> want;
  for (int k = 0; k < kMessages; ++k) want.push_back(pattern_bytes(kBytes, static_cast<unsigned>(k)));
  std::vector<int> ok(4 * kMessages, 0);
  std::vector<std::thread> threads;
  for (int th = 0; th < 4; ++th) {
    threads.emplace_back([&, th] {
      for (int k = 0; k < kMessages; ++k) {
        const int m = (k + th * 5) % kMessages;
        ok[th * kMessages + m] = bag->read(refs[m]) == want[m] ? 1 : -1;
      }
    });
  }
  for (auto& t : threads) t.join();
  for (int v : ok) EXPECT_EQ(v, 1);
  fs::remove_all(dir);
}

// A database made by hand, for the schemas the real bags above do not cover.
void make_db(const fs::path& path, const char* sql) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  char* err = nullptr;
  EXPECT_EQ(sqlite3_exec(db, sql, nullptr, nullptr, &err), SQLITE_OK) << (err ? err : "");
  sqlite3_free(err);
  sqlite3_close(db);
}

TEST(Rosbag2, OldestSchemaWithoutQosOrFormatColumns) {
  const fs::path dir = temp_dir("oldest");
  make_db(dir / "old.db3",
          "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT, type TEXT);"
          "CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER, timestamp INTEGER, data BLOB);"
          "INSERT INTO topics VALUES(7, '/b', 'pkg/msg/B');"
          "INSERT INTO messages VALUES(1, 7, 30, x'00010000AA');"
          "INSERT INTO messages VALUES(2, 7, 20, x'00010000BB');"
          "INSERT INTO messages VALUES(3, 7, 20, x'00010000CC');"
          "INSERT INTO messages VALUES(4, 99, 5, x'00');");  // a message of no listed topic
  const auto bag = open_bag(dir / "old.db3");
  ASSERT_EQ(bag->topics().size(), 1u);
  EXPECT_EQ(bag->topics()[0].message_count, 3u);
  EXPECT_EQ(bag->start_time_ns(), 20);
  EXPECT_EQ(bag->end_time_ns(), 30);
  ASSERT_EQ(bag->warnings().size(), 1u);
  const auto refs = bag->messages(0);
  ASSERT_EQ(refs.size(), 3u);
  EXPECT_EQ(bag->read(refs[0]).back(), 0xBB);  // time order, ties by row id
  EXPECT_EQ(bag->read(refs[1]).back(), 0xCC);
  EXPECT_EQ(bag->read(refs[2]).back(), 0xAA);
  fs::remove_all(dir);
}

// A recorder still writing (WAL mode, rows not yet checkpointed): read through sqlite's locks, so
// that the rows in the -wal file are seen, with a warning.
TEST(Rosbag2, LiveRecordingWithWriteAheadLog) {
  const fs::path dir = temp_dir("wal");
  sqlite3* recorder = nullptr;
  ASSERT_EQ(sqlite3_open((dir / "live.db3").c_str(), &recorder), SQLITE_OK);
  const char* sql =
      "PRAGMA journal_mode=WAL; PRAGMA wal_autocheckpoint=0;"
      "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT, type TEXT, serialization_format TEXT);"
      "CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER, timestamp INTEGER, data BLOB);"
      "INSERT INTO topics VALUES(1, '/a', 'std_msgs/msg/String', 'cdr');"
      "INSERT INTO messages VALUES(1, 1, 5, x'0001000000');";
  ASSERT_EQ(sqlite3_exec(recorder, sql, nullptr, nullptr, nullptr), SQLITE_OK);
  ASSERT_TRUE(fs::exists(dir / "live.db3-wal"));
  const auto bag = open_bag(dir / "live.db3");
  ASSERT_EQ(bag->topics().size(), 1u);
  EXPECT_EQ(bag->topics()[0].message_count, 1u);
  ASSERT_EQ(bag->warnings().size(), 1u);
  EXPECT_NE(bag->warnings()[0].find("write-ahead log"), std::string::npos);
  EXPECT_EQ(bag->read(bag->messages(0).at(0)).size(), 5u);
  sqlite3_close(recorder);
  fs::remove_all(dir);
}

TEST(Rosbag2, NotARosbag2Database) {
  const fs::path dir = temp_dir("notbag");
  make_db(dir / "other.db3", "CREATE TABLE photos(id INTEGER PRIMARY KEY, jpeg BLOB);");
  try {
    open_bag(dir / "other.db3");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), (dir / "other.db3").string());
    EXPECT_NE(std::string(e.what()).find("no 'messages' table"), std::string::npos) << e.what();
  }
  make_db(dir / "half.db3", "CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER, data BLOB);");
  EXPECT_THROW(open_bag(dir / "half.db3"), InputError);  // no timestamp column
  fs::remove_all(dir);
}

TEST(Rosbag2, FolderWithoutBagFiles) {
  const fs::path dir = temp_dir("nobag");
  write_text(dir / "notes.txt", "hello");
  try {
    open_bag(dir);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), dir.string());
    EXPECT_NE(std::string(e.what()).find("no metadata.yaml and no .db3 or .mcap file"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

TEST(Rosbag2, TruncatedDb3) {
  SKIP_WITHOUT(kBags / "talker-db3");
  const fs::path dir = temp_dir("truncated");
  std::ifstream in(kBags / "talker-db3" / "talker.db3", std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (const std::size_t keep : {std::size_t{50}, std::size_t{2000}, bytes.size() / 2, bytes.size() - 1}) {
    write_text(dir / "cut.db3", bytes.substr(0, keep));
    try {
      open_bag(dir / "cut.db3");
      FAIL() << "expected InputError at " << keep << " bytes";
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), (dir / "cut.db3").string());
      EXPECT_EQ(e.location(), "byte " + std::to_string(keep));
      EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos) << e.what();
    }
  }
  fs::remove_all(dir);
}

TEST(Rosbag2, CorruptPagesAreInputErrors) {
  SKIP_WITHOUT(kBags / "talker-db3");
  const fs::path dir = temp_dir("corrupt");
  std::ifstream in(kBags / "talker-db3" / "talker.db3", std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (std::size_t i = 4096; i < bytes.size(); ++i) bytes[i] = static_cast<char>(0xA5 ^ (i * 31));  // all but page 1
  write_text(dir / "bad.db3", bytes);
  try {
    const auto bag = open_bag(dir / "bad.db3");
    for (std::uint32_t t = 0; t < bag->topics().size(); ++t) {
      for (const MessageRef& ref : bag->messages(t)) (void)bag->read(ref);
    }
    FAIL() << "a bag with garbage pages read cleanly";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), (dir / "bad.db3").string());
    EXPECT_NE(std::string(e.what()).find("corrupt"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

TEST(Rosbag2, GarbageFile) {
  const fs::path dir = temp_dir("garbage");
  write_text(dir / "drive.db3", "hello, this is not a bag\x01\x02");
  try {
    open_bag(dir / "drive.db3");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.location(), "byte 0");
    EXPECT_NE(
        std::string(e.what()).find("not a ROS 1 bag, MCAP or rosbag2 sqlite3 file (starts with \"hello, this is n"),
        std::string::npos)
        << e.what();
  }
  write_text(dir / "empty.bag", "");
  EXPECT_THROW(open_bag(dir / "empty.bag"), InputError);
  EXPECT_THROW(open_bag(dir / "missing.db3"), InputError);
  // The sqlite reader called directly says what it expected.
  EXPECT_THROW(open_rosbag2_db3(dir / "drive.db3"), InputError);
  fs::remove_all(dir);
}

TEST(Rosbag2, MetadataNamingAMissingFile) {
  const fs::path dir = temp_dir("missingfile");
  write_text(dir / "metadata.yaml",
             "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: sqlite3\n"
             "  relative_file_paths:\n    - gone_0.db3\n");
  try {
    open_bag(dir);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), (dir / "metadata.yaml").string());
    EXPECT_NE(std::string(e.what()).find("gone_0.db3"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

TEST(Rosbag2, MetadataParsing) {
  const Rosbag2Metadata m = parse_rosbag2_metadata(
      "rosbag2_bagfile_information:\n  version: 9\n  storage_identifier: mcap\n  future_key: {a: 1}\n"
      "  relative_file_paths: [a_0.mcap, a_1.mcap]\n  message_count: 12\n",
      "m.yaml");
  EXPECT_EQ(m.version, 9);
  EXPECT_EQ(m.storage_identifier, "mcap");
  EXPECT_EQ(m.relative_file_paths, (std::vector<std::string>{"a_0.mcap", "a_1.mcap"}));
  EXPECT_EQ(m.message_count, 12u);
  EXPECT_TRUE(m.warnings.empty());
  EXPECT_EQ(parse_rosbag2_metadata("rosbag2_bagfile_information:\n  version: 12\n  relative_file_paths: []\n", "m")
                .warnings.size(),
            1u);
  try {
    parse_rosbag2_metadata("some_other_tool:\n  x: 1\n", "m.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("rosbag2_bagfile_information"), std::string::npos);
  }
  try {
    parse_rosbag2_metadata("rosbag2_bagfile_information:\n  version: [1\n", "m.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "m.yaml");
    EXPECT_EQ(e.location().rfind("line ", 0), 0u);
  }
  EXPECT_THROW(parse_rosbag2_metadata("rosbag2_bagfile_information:\n  version: five\n", "m"), InputError);
}

TEST(Rosbag2, FolderFileOrderAndOldRelativePaths) {
  const fs::path dir = temp_dir("order");
  for (const char* name : {"x_10.db3", "x_2.db3", "x_0.db3", "x_1.mcap", "notes.txt"}) write_text(dir / name, "");
  std::vector<std::string> warnings;
  std::vector<std::string> names;
  for (const fs::path& p : rosbag2_folder_files(dir, warnings)) names.push_back(p.filename().string());
  EXPECT_EQ(names, (std::vector<std::string>{"x_0.db3", "x_1.mcap", "x_2.db3", "x_10.db3"}));
  // Version 3 wrote paths relative to the parent ("bag/bag_0.db3"); a renamed folder still works.
  const fs::path bag = dir / "renamed";
  fs::create_directories(bag);
  write_text(bag / "bag_0.db3", "");
  write_text(bag / "metadata.yaml",
             "rosbag2_bagfile_information:\n  version: 3\n  storage_identifier: sqlite3\n"
             "  relative_file_paths:\n    - bag/bag_0.db3\n");
  warnings.clear();
  const auto files = rosbag2_folder_files(bag, warnings);
  ASSERT_EQ(files.size(), 1u);
  EXPECT_EQ(files[0], bag / "bag_0.db3");
  EXPECT_EQ(warnings.size(), 1u);
  write_text(bag / "metadata.yaml",
             "rosbag2_bagfile_information:\n  version: 5\n  compression_format: zstd\n  compression_mode: FILE\n"
             "  relative_file_paths:\n    - bag_0.db3.zstd\n");
  EXPECT_THROW(rosbag2_folder_files(bag, warnings), InputError);
  fs::remove_all(dir);
}

TEST(Rosbag2, NormalizedType) {
  EXPECT_EQ(normalized_type("sensor_msgs/msg/PointCloud2"), "sensor_msgs/PointCloud2");
  EXPECT_EQ(normalized_type("sensor_msgs/PointCloud2"), "sensor_msgs/PointCloud2");
  EXPECT_EQ(normalized_type("tf2_msgs/msg/TFMessage"), "tf2_msgs/TFMessage");
  EXPECT_EQ(normalized_type("Header"), "Header");
  EXPECT_EQ(normalized_type("pkg/srv/Call"), "pkg/srv/Call");
}

}  // namespace
}  // namespace insalign::io::bag
