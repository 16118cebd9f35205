// The input options end to end through the real `insalign` binary: simulated drives written as
// each recording format (`simulate --format`), calibrated with `calibrate --bag` from the
// simulator's wrong guess against ground_truth.json; `info --bag` on the real bags of the shared
// data; bad input (cut-off recording, missing or ambiguous topic, clocks apart) exits 2 and
// writes nothing. Drives are short and sparse (VLP-16 at 2 deg, 15 s) to keep each run a few
// seconds of CPU.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <nlohmann/json.hpp>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "cli_test_util.hpp"
#include "core/errors.hpp"
#include "core/geometry.hpp"
#include "recording/bag_reader.hpp"
#include "recording/bag_writer.hpp"
#include "recording/bag_topics.hpp"
#include "files/extrinsic_json.hpp"
#include "files/formats.hpp"
#include "input/input_info.hpp"
#include "input/input_source.hpp"
#include "files/read_file.hpp"

namespace insalign {
namespace {

namespace fs = std::filesystem;

fs::path fresh_dir(const std::string& tag) { return testing::fresh_dir("insalign_cli_inputs_", tag); }

/// Exit code and stdout + stderr of an insalign command line.
std::pair<int, std::string> run(const std::string& args) { return testing::run_command(std::string(INSALIGN_EXE) + " " + args); }
using testing::contains;

/// `simulate --format ...` of the short sparse drive into dir; returns the recording's path.
fs::path simulate(const fs::path& dir, const std::string& format, const std::string& convention, const std::string& ins,
                  const std::string& extra = "--duration-s 15") {
  const auto [rc, out] = run("simulate --out " + dir.string() + " --format " + format + " --lidar-convention " + convention +
                             " --ins-message " + ins + " --lidar vlp16 --azimuth-step-deg 2 --seed 1 --quiet " + extra);
  EXPECT_EQ(rc, 0) << out;
  for (const char* name : {"drive.bag", "drive.mcap", "drive"}) {
    if (fs::exists(dir / name)) return dir / name;
  }
  ADD_FAILURE() << "no recording in " << dir << "\n" << out;
  return dir / "drive";
}

// ---------------------------------------------------------------- calibrate --bag, each format

struct BagCase {
  const char* format;
  const char* convention;
  const char* ins;
  const char* driver;       ///< in the detected time convention's description
  const char* ins_kind;     ///< in extrinsic.json input.poses.format
  bool deskewed;            ///< false: no per-point time, looser bounds (half a sweep of skew)
};

class CliCalibrateBag : public ::testing::TestWithParam<BagCase> {};

TEST_P(CliCalibrateBag, WithinTheAccuracyBoundsFromTheWrongGuess) {
  const BagCase& c = GetParam();
  const fs::path dir = fresh_dir(std::string("cal_") + c.format + "_" + c.convention);
  const fs::path bag = simulate(dir / "sim", c.format, c.convention, c.ins);
  const fs::path out = dir / "out";
  const auto [rc, text] = run("calibrate --bag " + bag.string() + " --init " + (dir / "sim" / "init-extrinsic.json").string() +
                              " --fiducials " + (dir / "sim" / "fiducials.txt").string() + " --out " + out.string() +
                              " --segments 0 --no-report");
  ASSERT_EQ(rc, 0) << text;
  // What was read is printed before the work: time convention, pose source, clocks.
  EXPECT_TRUE(contains(text, "Input            recording: " + bag.string())) << text;
  EXPECT_TRUE(contains(text, c.driver)) << text;
  EXPECT_TRUE(contains(text, "Clocks ")) << text;

  const io::ExtrinsicFile truth = io::read_extrinsic_file(dir / "sim" / "ground_truth.json");
  const io::ExtrinsicFile result = io::read_extrinsic_file(out / "extrinsic.json");
  const ExtrinsicError e = extrinsic_error(result.T_ins_lidar, truth.T_ins_lidar);
  const Iso3 init = io::read_opencalib_extrinsic(dir / "sim" / "init-extrinsic.json");
  EXPECT_GT(extrinsic_error(init, truth.T_ins_lidar).angle_deg, 5.0);  // a wrong start
  std::printf("%s %s %s: |t| %.1f %.1f %.1f mm, |rpy| %.4f %.4f %.4f deg, offset %.1f ms\n", c.format, c.convention, c.ins,
              1e3 * e.dt_m.x(), 1e3 * e.dt_m.y(), 1e3 * e.dt_m.z(), e.drpy_deg.x(), e.drpy_deg.y(), e.drpy_deg.z(),
              1e3 * result.time_offset_s.value_or(0.0));
  // README bounds (stage 2: 0.03 deg per axis, 1 cm in x and y; stage 3: tz within 2 cm with fiducials).
  EXPECT_LT(e.drpy_deg.maxCoeff(), c.deskewed ? 0.03 : 0.1);
  EXPECT_LT(e.dt_m.head<2>().maxCoeff(), c.deskewed ? 0.01 : 0.05);
  EXPECT_LT(e.dt_m.z(), 0.02);
  if (c.deskewed) {
    EXPECT_LT(std::abs(result.time_offset_s.value_or(1.0) - truth.time_offset_s.value_or(0.0)), 0.002);
  }

  const nlohmann::json j = nlohmann::json::parse(io::read_file(out / "extrinsic.json"));
  EXPECT_EQ(j["input"]["kind"], "recording");
  EXPECT_TRUE(contains(j["input"]["frame_time_source"].get<std::string>(), c.driver)) << j["input"].dump(2);
  EXPECT_TRUE(contains(j["input"]["poses"]["format"].get<std::string>(), c.ins_kind)) << j["input"].dump(2);
  EXPECT_TRUE(j["input"]["clock"].is_object());
  EXPECT_TRUE(contains(j["input"]["init"].get<std::string>(), "init-extrinsic.json"));
  // Every calibration also writes KITTI's calib_imu_to_velo.txt (T_velo_imu): it reads back as the result.
  const io::ReadTransform kitti = io::parse_kitti_imu_to_velo(io::read_file(out / io::kKittiFile), io::kKittiFile);
  EXPECT_LT(extrinsic_error(kitti.T_parent_child, result.T_ins_lidar).angle_deg, 1e-9);
  fs::remove_all(dir);
}

INSTANTIATE_TEST_SUITE_P(
    Formats, CliCalibrateBag,
    ::testing::Values(BagCase{"mcap", "hesai", "inspva", "(Hesai, RoboSense)", "NovAtel INSPVAX", true},
                      BagCase{"ros1", "velodyne", "navsatfix-imu", "(Velodyne)", "NavSatFix + Imu", true},
                      BagCase{"db3", "ouster", "tf", "(Ouster)", "TF", true},
                      BagCase{"ros1", "none", "odometry", "no per-point time field", "Odometry", false}),
    [](const ::testing::TestParamInfo<BagCase>& info) {
      return std::string(info.param.format) + "_" + info.param.convention;
    });

// A KITTI raw drive: sweeps without per-point time (derived from the azimuth), oxts, and
// ../calib_imu_to_velo.txt as the wrong guess; the result is also KITTI's calib_imu_to_velo.txt.
TEST(CliInputs, KittiRawDriveCalibratesWithinTheBounds) {
  const fs::path dir = fresh_dir("kitti");
  const auto [sim_rc, sim_out] = run("simulate --out " + (dir / "sim").string() +
                                     " --poses-format kitti --lidar vlp16 --azimuth-step-deg 2 --seed 1 --duration-s 15 --quiet");
  if (sim_rc == 2 && contains(sim_out, "--poses-format")) GTEST_SKIP() << "simulate cannot write KITTI raw here: " << sim_out;
  ASSERT_EQ(sim_rc, 0) << sim_out;
  fs::path drive;  // the ..._sync folder
  for (const auto& entry : fs::directory_iterator(dir / "sim")) {
    const std::string name = entry.path().filename().string();
    if (entry.is_directory() && name.size() > 5 && name.substr(name.size() - 5) == "_sync") drive = entry.path();
  }
  ASSERT_TRUE(fs::is_directory(drive / "oxts")) << sim_out;
  const auto [rc, text] = run("calibrate --kitti-raw " + drive.string() + " --fiducials " + (dir / "sim" / "fiducials.txt").string() +
                              " --out " + (dir / "out").string() + " --segments 0 --no-report");
  ASSERT_EQ(rc, 0) << text;
  EXPECT_TRUE(contains(text, "derived from each point's azimuth")) << text;
  EXPECT_TRUE(contains(text, "Initial guess    " + (dir / "sim" / "calib_imu_to_velo.txt").string())) << text;
  const io::ExtrinsicFile truth = io::read_extrinsic_file(dir / "sim" / "ground_truth.json");
  const io::ExtrinsicFile result = io::read_extrinsic_file(dir / "out" / "extrinsic.json");
  const ExtrinsicError e = extrinsic_error(result.T_ins_lidar, truth.T_ins_lidar);
  std::printf("kitti raw: |t| %.1f %.1f %.1f mm, |rpy| %.4f %.4f %.4f deg\n", 1e3 * e.dt_m.x(), 1e3 * e.dt_m.y(), 1e3 * e.dt_m.z(),
              e.drpy_deg.x(), e.drpy_deg.y(), e.drpy_deg.z());
  EXPECT_LT(e.drpy_deg.maxCoeff(), 0.03);
  EXPECT_LT(e.dt_m.head<2>().maxCoeff(), 0.01);
  EXPECT_LT(e.dt_m.z(), 0.02);
  const io::ReadTransform kitti = io::parse_kitti_imu_to_velo(io::read_file(dir / "out" / io::kKittiFile), io::kKittiFile);
  EXPECT_LT(extrinsic_error(kitti.T_parent_child, truth.T_ins_lidar).angle_deg, 0.03);
  fs::remove_all(dir);
}

// Through the library: a fixture written by python3-rosbag with two drivers, named in what is read.
TEST(CliInputs, EachLidarOfARecordingSaysItsTimeConvention) {
  io::InputSpec spec;
  spec.bag = fs::path(INSALIGN_TEST_DATA_DIR) / "bags" / "ros1_ouster_livox_tf_lz4.bag";
  spec.lidar_topics = {"/ouster/points", "/livox/lidar"};
  const io::LoadedInput input = io::load_input(spec);
  ASSERT_EQ(input.reports.size(), 2u);
  EXPECT_EQ(input.lidar_names, (std::vector<std::string>{"ouster_points", "livox_lidar"}));
  EXPECT_EQ(input.reports[0].time_field, "t");
  EXPECT_TRUE(contains(input.reports[1].time_field, "nanoseconds")) << input.reports[1].time_field;  // Livox: not seconds
  EXPECT_TRUE(contains(io::describe_load(input.reports[1]), "nanoseconds")) << io::describe_load(input.reports[1]);
  EXPECT_THROW(io::input_kind([&] {
                 io::InputSpec two = spec;
                 two.inits = {"a.json", "b.json", "c.json"};
                 return two;
               }()),
               InputError);
}

// ---------------------------------------------------------------- info --bag on real bags

#ifdef INSALIGN_SHARED_DATA_DIR
const fs::path kBags = fs::path(INSALIGN_SHARED_DATA_DIR) / "bags";
#else
const fs::path kBags;
#endif

std::string info_of(const fs::path& bag, const std::string& extra = "") {
  const auto [rc, out] = run("info --bag " + bag.string() + extra);
  EXPECT_EQ(rc, 0) << out;
  return out;
}

void expect_lines(const std::string& out, const std::vector<std::string>& lines) {
  for (const std::string& line : lines) EXPECT_TRUE(contains(out, line)) << line << "\n" << out;
}

TEST(CliInfoBag, RealRos1BagsListEveryTopicWithItsCount) {
  if (kBags.empty() || !fs::exists(kBags / "ros1")) GTEST_SKIP() << "no shared bags at " << kBags;
  for (const char* file : {"example.bag", "example-bz2.bag", "example-lz4.bag"}) {
    SCOPED_TRACE(file);
    const std::string out = info_of(kBags / "ros1" / file);
    expect_lines(out, {"  /rosout  rosgraph_msgs/Log  10 msgs  (not read)", "  /tf  tf/tfMessage  2688 msgs  (INS: TF)",
                       "  /tf_static  tf2_msgs/TFMessage  1 msgs", "  /turtle1/cmd_vel  geometry_msgs/Twist  357 msgs",
                       "  /turtle1/color_sensor  turtlesim/Color  1351 msgs", "  /turtle1/pose  turtlesim/Pose  1344 msgs",
                       "  /turtle2/cmd_vel  geometry_msgs/Twist  208 msgs", "  /turtle2/color_sensor  turtlesim/Color  1344 msgs",
                       "  /turtle2/pose  turtlesim/Pose  1344 msgs", "record times 1396293887.845 .. 1396293909.545 s",
                       "no sensor_msgs/PointCloud2 topic"});
    // Two turtles move in /tf: the INS frame is not guessed, the note says which option settles it.
    expect_lines(out, {"INS              not read:", "turtle1, turtle2", "--ins-frame"});
  }
  const std::string one = info_of(kBags / "ros1" / "example.bag", " --ins-frame turtle1");
  expect_lines(one, {"INS TF: /tf", "first pose at 13962938", "poses          "});
  expect_lines(info_of(kBags / "ros1" / "no-messages.bag"), {"nothing insalign reads"});
}

TEST(CliInfoBag, RealRosbag2BagsListTopicsAndTheOdometryTrajectory) {
  if (kBags.empty() || !fs::exists(kBags / "rosbag2")) GTEST_SKIP() << "no shared bags at " << kBags;
  const fs::path r2 = kBags / "rosbag2";
  for (const char* folder : {"talker-db3", "talker-mcap"}) {
    SCOPED_TRACE(folder);
    expect_lines(info_of(r2 / folder), {"  /rosout  rcl_interfaces/msg/Log  10 msgs", "  /topic  std_msgs/msg/String  10 msgs",
                                        "  /parameter_events  rcl_interfaces/msg/ParameterEvent  0 msgs"});
  }
  for (const char* folder : {"cdr-test-db3", "cdr-test-mcap"}) {
    expect_lines(info_of(r2 / folder), {"  /test_topic  test_msgs/msg/BasicTypes  3 msgs", "  /array_topic  test_msgs/msg/Arrays  4 msgs"});
  }
  expect_lines(info_of(r2 / "split-db3-no-metadata"),
               {"3 files", "  /chatter  std_msgs/msg/String  3177 msgs", "record times 1616653333.034 .. 1616653339.386 s"});
  expect_lines(info_of(r2 / "autoware-odometry-db3"),
               {"  /localization/kinematic_state  nav_msgs/msg/Odometry  2130 msgs  (INS: Odometry)",
                "ins = the Odometry child frame 'base_link'", "world = 'map'",
                "position 966.5026 1036.0884 100.0000 m, orientation (x y z w) 0.0000000 0.0000000 0.0077518 0.9999700",
                "position 1091.8456 1090.6974 100.0000 m, orientation (x y z w) 0.0000000 0.0000000 0.7015913 0.7125796",
                "2130 records used", "40.00 Hz", "distance       166.9 m"});
}

// ---------------------------------------------------------------- bad input: exit 2, nothing written

/// The recording rewritten with every INS message's header.stamp moved by shift_s (both ROS 1 and
/// CDR put header.stamp's seconds and nanoseconds at bytes 4..12); record times unchanged, as a
/// recorder whose INS driver stamps another clock would write them.
fs::path with_ins_stamps_shifted(const fs::path& bag, io::bag::BagFormat format, double shift_s, const fs::path& out) {
  const auto reader = io::bag::open_bag(bag);
  const auto writer = io::bag::make_bag_writer(format, out);
  std::vector<std::tuple<std::int64_t, std::uint32_t, io::bag::MessageRef>> all;
  for (std::uint32_t t = 0; t < reader->topics().size(); ++t) {
    EXPECT_EQ(writer->add_topic(reader->topics()[t]), t);
    for (const io::bag::MessageRef& m : reader->messages(t)) all.emplace_back(m.log_time_ns, t, m);
  }
  std::sort(all.begin(), all.end(), [](const auto& a, const auto& b) { return std::get<0>(a) < std::get<0>(b); });
  const auto shift_ns = static_cast<std::int64_t>(shift_s * 1e9);
  for (const auto& [log_ns, t, ref] : all) {
    std::vector<std::uint8_t> bytes = reader->read(ref);
    if (io::ins_source_kind(reader->topics()[t].type)) {
      std::uint32_t sec = 0, nsec = 0;
      std::memcpy(&sec, bytes.data() + 4, 4);
      std::memcpy(&nsec, bytes.data() + 8, 4);
      const std::int64_t ns = static_cast<std::int64_t>(sec) * 1000000000 + nsec + shift_ns;
      sec = static_cast<std::uint32_t>(ns / 1000000000), nsec = static_cast<std::uint32_t>(ns % 1000000000);
      std::memcpy(bytes.data() + 4, &sec, 4);
      std::memcpy(bytes.data() + 8, &nsec, 4);
    }
    writer->write(t, log_ns, bytes);
  }
  writer->close();
  return out;
}

void expect_exit_2_nothing_written(const std::string& args, const fs::path& out, const std::vector<std::string>& parts) {
  const auto [rc, text] = run(args + " --out " + out.string());
  EXPECT_EQ(rc, 2) << args << "\n" << text;
  for (const std::string& p : parts) EXPECT_TRUE(contains(text, p)) << p << "\n" << text;
  EXPECT_FALSE(fs::exists(out)) << args;
}

TEST(CliBadInput, RecordingsThatCannotBeReadExitTwoAndWriteNothing) {
  const fs::path dir = fresh_dir("bad");
  const fs::path bag = simulate(dir / "sim", "ros1", "ouster", "odometry", "--duration-s 4");
  const std::string b = "calibrate --bag ";
  // Cut off inside its first chunk: no whole message before the cut.
  {
    const std::string bytes = io::read_file(bag);
    std::ofstream(dir / "cut.bag", std::ios::binary).write(bytes.data(), 200000);
  }
  expect_exit_2_nothing_written(b + (dir / "cut.bag").string(), dir / "out_cut",
                                {(dir / "cut.bag").string(), "cut off mid-chunk", "the file ends at byte 200000",
                                 "no whole chunk comes before it"});
  expect_exit_2_nothing_written(b + bag.string() + " --lidar-topic /nope", dir / "out_missing",
                                {bag.string(), "/nope", "/ouster/points"});
  expect_exit_2_nothing_written(b + bag.string() + " --ins-topic /nope", dir / "out_ins", {bag.string(), "/nope"});
  // INS stamps 7.3 s away from the LiDAR's: no known offset explains it.
  const fs::path apart = with_ins_stamps_shifted(bag, io::bag::BagFormat::kRos1, 7.3, dir / "apart.bag");
  expect_exit_2_nothing_written(b + apart.string(), dir / "out_apart",
                                {apart.string(), "7.3", "not a whole number of seconds", "LiDAR frames 1700000000.100 .. "});
  // Two LiDAR topics: ambiguous without --lidar-topic.
  const fs::path rig = simulate(dir / "rig", "mcap", "hesai", "odometry", "--duration-s 1 --rig top:vlp16,left:vlp16@left");
  expect_exit_2_nothing_written(b + rig.string(), dir / "out_rig", {rig.string(), "/top", "/left", "--lidar-topic"});
  fs::remove_all(dir);
}

/// `bytes` cut to its first `n` bytes, written to `path`.
fs::path cut_copy(const std::string& bytes, std::size_t n, const fs::path& path) {
  std::ofstream(path, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(n));
  return path;
}

/// The number after `prefix` in `text` (0, with a failure, when absent).
std::uint64_t number_after(const std::string& text, const std::string& prefix) {
  const std::size_t at = text.find(prefix);
  EXPECT_NE(at, std::string::npos) << prefix << " in:\n" << text;
  return at == std::string::npos ? 0 : std::stoull(text.substr(at + prefix.size()));
}

// A recording cut off, per container. ROS 1: the file ending inside a chunk exits 2 naming the
// cut chunk's byte and the file's end, nothing written, unless --set input.read_cut_off=true
// (then it calibrates from the whole chunks before the cut, with a warning); ending where a
// chunk starts loses nothing and is read with a warning. MCAP: streamed to its last whole record
// with a warning giving the byte. rosbag2 sqlite3: a cut .db3 exits 2 naming the file.
TEST(CliBadInput, CutOffRecordingsPerContainer) {
  const fs::path dir = fresh_dir("cutoff");
  const fs::path bag = simulate(dir / "ros1", "ros1", "hesai", "odometry");
  const std::string bytes = io::read_file(bag);
  const std::size_t end = bytes.size() * 5 / 6;
  const fs::path cut = cut_copy(bytes, end, dir / "cut.bag");
  const std::string calibrate = "calibrate --bag " + cut.string() + " --init " + (dir / "ros1" / "init-extrinsic.json").string() +
                                " --segments 0 --no-report";
  const auto [rc, text] = run(calibrate + " --out " + (dir / "out_cut").string());
  EXPECT_EQ(rc, 2) << text;
  EXPECT_FALSE(fs::exists(dir / "out_cut"));
  const std::uint64_t chunk = number_after(text, cut.string() + ":byte ");
  EXPECT_LT(chunk, end);
  EXPECT_GT(chunk, end / 2);
  for (const std::string& part : std::vector<std::string>{"cut off mid-chunk: the chunk starting at byte " + std::to_string(chunk),
                                                         "the file ends at byte " + std::to_string(end),
                                                         "`rosbag reindex` cannot recover", "--set input.read_cut_off=true reads the "}) {
    EXPECT_TRUE(contains(text, part)) << part << "\n" << text;
  }
  // With the switch: the whole chunks before the cut, a warning naming where it stopped, a result.
  const auto [rc_on, on] = run(calibrate + " --set input.read_cut_off=true --out " + (dir / "out_on").string());
  ASSERT_EQ(rc_on, 0) << on;
  EXPECT_TRUE(contains(on, "stopped at byte " + std::to_string(chunk))) << on;
  EXPECT_TRUE(contains(on, "read because input.read_cut_off is true")) << on;
  const io::ExtrinsicFile truth = io::read_extrinsic_file(dir / "ros1" / "ground_truth.json");
  const ExtrinsicError e = extrinsic_error(io::read_extrinsic_file(dir / "out_on" / "extrinsic.json").T_ins_lidar, truth.T_ins_lidar);
  EXPECT_LT(e.drpy_deg.maxCoeff(), 0.05) << e.drpy_deg.transpose();
  EXPECT_LT(e.dt_m.head<2>().maxCoeff(), 0.02) << e.dt_m.transpose();
  // Ending where that chunk starts (the index lost, no chunk cut): read, with a warning.
  const fs::path boundary = cut_copy(bytes, chunk, dir / "boundary.bag");
  const auto [rc_b, at_boundary] = run("info --bag " + boundary.string());
  EXPECT_EQ(rc_b, 0) << at_boundary;
  EXPECT_TRUE(contains(at_boundary, "lies past the end of the file")) << at_boundary;
  EXPECT_TRUE(contains(at_boundary, "in file order, to the end of the file")) << at_boundary;

  // MCAP without summary: streamed to the last whole record.
  const fs::path mcap = simulate(dir / "mcap", "mcap", "hesai", "odometry", "--duration-s 4");
  const std::string mcap_bytes = io::read_file(mcap);
  const fs::path mcap_cut = cut_copy(mcap_bytes, mcap_bytes.size() * 2 / 3, dir / "cut.mcap");
  const auto [rc_m, streamed] = run("info --bag " + mcap_cut.string());
  EXPECT_EQ(rc_m, 0) << streamed;
  const std::uint64_t readable = number_after(streamed, "the file stops being readable at byte ");
  EXPECT_LT(readable, mcap_bytes.size() * 2 / 3);
  EXPECT_GT(readable, mcap_bytes.size() / 3);
  // rosbag2 sqlite3 cut in half: exit 2 naming the file.
  const fs::path db3 = simulate(dir / "db3", "db3", "hesai", "odometry", "--duration-s 4");
  fs::path db3_file;
  for (const auto& e : fs::directory_iterator(db3)) {
    if (e.path().extension() == ".db3") db3_file = e.path();
  }
  const std::string db3_bytes = io::read_file(db3_file);
  const fs::path db3_cut = cut_copy(db3_bytes, db3_bytes.size() / 2, dir / "cut.db3");
  expect_exit_2_nothing_written("calibrate --bag " + db3_cut.string(), dir / "out_db3", {db3_cut.string(), "truncated"});
  fs::remove_all(dir);
}

TEST(CliBadInput, OptionsNamingNoneOrSeveralInputsExitTwo) {
  const fs::path dir = fresh_dir("usage");
  expect_exit_2_nothing_written("calibrate", dir / "o1", {"no input", "--lidar-dir", "--bag", "--kitti-raw"});
  expect_exit_2_nothing_written("calibrate --bag x.bag --kitti-raw y", dir / "o2", {"give one input"});
  expect_exit_2_nothing_written("calibrate --lidar-dir a --poses p --lidar-topic /points", dir / "o3", {"go with --bag"});
  expect_exit_2_nothing_written("calibrate --lidar-dir a --lidar-dir b --poses p --init i1 --init i2 --init i3", dir / "o4",
                                {"3 --init for 2 LiDARs", "--lidar-dir"});
  expect_exit_2_nothing_written("calibrate --bag x.bag --poses p", dir / "o5", {"--poses goes with --lidar-dir"});
  fs::remove_all(dir);
}

// An INS on GPS time and a LiDAR on UTC: 18 s apart, found, corrected and reported.
TEST(CliInputs, WholeSecondClockOffsetIsDetectedAndCorrected) {
  const fs::path dir = fresh_dir("clock18");
  const fs::path bag = simulate(dir / "sim", "mcap", "hesai", "odometry", "--duration-s 15");
  const fs::path shifted = with_ins_stamps_shifted(bag, io::bag::BagFormat::kMcap, 18.0, dir / "gps.mcap");
  const auto [rc, out] = run("info --bag " + shifted.string());
  ASSERT_EQ(rc, 0) << out;
  expect_lines(out, {"Clocks ", "close to 18 s: GPS - UTC", "corrected (INS times shifted by -18 s) (confirmed by the LiDAR motion)",
                     "applied        t_ins = t_lidar +18 s", "shifted by -18 s onto the LiDAR clock", "frames used 150 of 150"});
  fs::remove_all(dir);
}

// The TUM file `in` with every time shifted by shift_s, as `out`.
void write_shifted_tum(const fs::path& in_path, double shift_s, const fs::path& out_path) {
  std::ifstream in(in_path);
  std::ofstream out(out_path);
  for (std::string line; std::getline(in, line);) {
    std::istringstream fields(line);
    double t = 0.0;
    std::string rest;
    if (line.empty() || line[0] == '#' || !(fields >> t)) continue;
    std::getline(fields, rest);
    out << fmt::format("{:.9f}{}\n", t + shift_s, rest);
  }
}

// A PCD folder whose TUM poses are stamped 18 s ahead (GPS time vs UTC): the ranges overlap, so
// only the motion can tell; the offset is found, applied and reported. Two folders are a rig:
// both described, one named twice is refused.
TEST(CliInputs, PcdFolderClockOffsetFoundFromTheMotionAndRigFolders) {
  const fs::path dir = fresh_dir("pcd_clock");
  const auto [sim_rc, sim_out] = run("simulate --out " + (dir / "sim").string() +
                                     " --lidar vlp16 --azimuth-step-deg 2 --seed 1 --duration-s 25 --quiet");
  ASSERT_EQ(sim_rc, 0) << sim_out;
  write_shifted_tum(dir / "sim" / "poses_tum.txt", 18.0, dir / "gps_tum.txt");
  const std::string lidar = (dir / "sim" / "lidar").string(), poses = (dir / "gps_tum.txt").string();
  const auto [rc, out] = run("info --lidar-dir " + lidar + " --poses " + poses);
  ASSERT_EQ(rc, 0) << out;
  expect_lines(out, {"Clocks ", "GPS - UTC", "applied        t_ins = t_lidar +18 s", "  evidence       LiDAR rotation angles",
                     "format         TUM"});
  const auto [poses_rc, alone] = run("info --poses " + poses);  // a pose source alone: its facts and drive
  EXPECT_EQ(poses_rc, 0) << alone;
  expect_lines(alone, {"format         TUM (t x y z qx qy qz qw)", "records        2541 (0 skipped), 100.00 Hz", "Drive", "distance "});
  fs::create_directory_symlink(dir / "sim" / "lidar", dir / "left");
  const auto [rig_rc, rig] = run("info --lidar-dir " + lidar + " --lidar-dir " + (dir / "left").string() + " --poses " + poses);
  ASSERT_EQ(rig_rc, 0) << rig;
  expect_lines(rig, {"LiDAR            " + lidar + " (PCD folder)", "LiDAR            " + (dir / "left").string() + " (PCD folder)"});
  const auto [twice_rc, twice] = run("info --lidar-dir " + lidar + " --lidar-dir " + lidar + " --poses " + poses);
  EXPECT_EQ(twice_rc, 2) << twice;
  EXPECT_TRUE(contains(twice, "two LiDARs are named 'lidar'")) << twice;
  fs::remove_all(dir);
}

// A host-stamped LiDAR on UTC beside a GPS-time INS: 18 s plus 0.4 s of latency matches no
// whole-second candidate, so the check refuses it and says what to give; with the whole seconds
// given, the start measures the rest.
TEST(CliInputs, WholeSecondsPlusHostLatencyNeedTheWholeSecondsGiven) {
  const fs::path dir = fresh_dir("clock18_4");
  const auto [sim_rc, sim_out] = run("simulate --out " + (dir / "sim").string() +
                                     " --lidar vlp16 --azimuth-step-deg 2 --seed 3 --duration-s 40 --time-offset-s 0.4 --quiet");
  ASSERT_EQ(sim_rc, 0) << sim_out;
  write_shifted_tum(dir / "sim" / "poses_tum.txt", 18.0, dir / "gps_tum.txt");
  const std::string inputs = "--lidar-dir " + (dir / "sim" / "lidar").string() + " --poses " + (dir / "gps_tum.txt").string();
  const auto [rc, out] = run("calibrate " + inputs + " --out " + (dir / "refused").string());
  EXPECT_EQ(rc, 2) << out;
  EXPECT_TRUE(contains(out, "give the whole seconds as input.clock_offset_s")) << out;
  EXPECT_FALSE(fs::exists(dir / "refused" / "extrinsic.json"));
  {
    std::ofstream config(dir / "clock.yaml");
    config << "input:\n  clock_offset_s: 18\n";
  }
  const auto [given_rc, given] =
      run("calibrate " + inputs + " --config " + (dir / "clock.yaml").string() + " --out " + (dir / "given").string());
  ASSERT_EQ(given_rc, 0) << given;
  std::ifstream result(dir / "given" / "extrinsic.json");
  const auto j = nlohmann::json::parse(result);
  EXPECT_NEAR(j.at("time_offset_s").get<double>(), 0.4, 0.005) << given;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace insalign
