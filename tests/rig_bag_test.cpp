// A rig from a recording (issue 20, CONVENTIONS.md "Rigs"): `simulate --rig ... --format mcap`
// writes one PointCloud2 topic per LiDAR; `calibrate --bag X --lidar-topic /top --lidar-topic
// /left` with one --init per LiDAR runs the rig calibration, names the LiDARs after their topics,
// writes OUT/<name>/, rig.json and rig.urdf, starts from the wrong guesses and lands within the
// bounds of ground_truth.json, and gives the answer of the same drive read from its PCD folders
// (same seed, --format opencalib, the 100 Hz TUM poses = the recording's INS rate) to 1e-6.
// A short sparse drive (20 s, 2 deg) keeps the four runs under a minute on 2 cores; it passes
// too few fiducials for stage 3, so tz is not checked (both runs must say so alike).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "cli_test_util.hpp"
#include "core/geometry.hpp"
#include "recording/bag_topics.hpp"
#include "files/extrinsic_json.hpp"
#include "files/read_file.hpp"

namespace insalign {
namespace {

namespace fs = std::filesystem;

fs::path fresh_dir(const std::string& tag) { return testing::fresh_dir("insalign_rig_bag_", tag); }

/// Exit code and stdout + stderr of an insalign command line.
std::pair<int, std::string> run(const std::string& args) { return testing::run_command(std::string(INSALIGN_EXE) + " " + args); }
using testing::contains;

nlohmann::json read_json(const fs::path& path) { return nlohmann::json::parse(io::read_file(path)); }

Iso3 transform_of(const nlohmann::json& rows) {
  Iso3 T = Iso3::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) T.matrix()(r, c) = rows.at(r).at(c).get<double>();
  }
  return T;
}

constexpr const char* kRig = "top:pandar64,left:vlp16@left";
const std::vector<std::string> kNames = {"top", "left"};

// The same drive both ways: the seed fixes the world, the format only how it is written.
std::string simulate_args(const fs::path& out, const std::string& format) {
  return "simulate --out " + out.string() + " --format " + format + " --rig " + kRig +
         " --seed 2 --duration-s 20 --azimuth-step-deg 2 --quiet" +
         (format == "opencalib" ? "" : " --lidar-convention hesai --ins-message odometry");
}

// CONVENTIONS "Rigs": the topic without its leading '/', every other '/' as '_'.
TEST(RigBag, LidarNamesFromTopics) {
  EXPECT_EQ(io::lidar_name("/top"), "top");
  EXPECT_EQ(io::lidar_name("/sensing/lidar/left/pointcloud"), "sensing_lidar_left_pointcloud");
  EXPECT_EQ(io::lidar_name("velodyne_points"), "velodyne_points");
}

TEST(RigBag, TopicsCalibrateLikeFoldersFromEachLidarsOwnInit) {
  const fs::path dir = fresh_dir("topics");
  for (const char* format : {"opencalib", "mcap"}) {
    const auto [rc, text] = run(simulate_args(dir / format, format));
    ASSERT_EQ(rc, 0) << text;
  }
  const fs::path pcd = dir / "opencalib", bag = dir / "mcap";
  ASSERT_TRUE(fs::exists(bag / "drive.mcap"));
  std::string folders = "calibrate", topics = "calibrate --bag " + (bag / "drive.mcap").string();
  for (const std::string& name : kNames) {
    folders += " --lidar-dir " + (pcd / "lidar" / name).string();
    topics += " --lidar-topic /" + name;
  }
  folders += " --poses " + (pcd / "poses_tum.txt").string();
  for (const std::string& name : kNames) {
    folders += " --init " + (pcd / ("init-extrinsic-" + name + ".json")).string();
    topics += " --init " + (bag / ("init-extrinsic-" + name + ".json")).string();
  }
  folders += " --fiducials " + (pcd / "fiducials.txt").string() + " --segments 0 --no-report --out " + (dir / "out_pcd").string();
  topics += " --fiducials " + (bag / "fiducials.txt").string() + " --segments 0 --no-report --out " + (dir / "out_bag").string();
  const auto [rc_pcd, text_pcd] = run(folders);
  ASSERT_EQ(rc_pcd, 0) << folders << "\n" << text_pcd;
  const auto [rc_bag, text_bag] = run(topics);
  ASSERT_EQ(rc_bag, 0) << topics << "\n" << text_bag;

  // The rig outputs, named after the topics.
  const fs::path out = dir / "out_bag";
  for (const char* file : {"rig.json", "rig.urdf"}) EXPECT_TRUE(fs::exists(out / file)) << file;
  const nlohmann::json rig = read_json(out / "rig.json"), rig_pcd = read_json(dir / "out_pcd" / "rig.json");
  const nlohmann::json truth = read_json(bag / "ground_truth.json").at("lidars");
  const nlohmann::json truth_pcd = read_json(pcd / "ground_truth.json").at("lidars");
  EXPECT_TRUE(rig.at("T_lidar_lidar").contains("top__left") || rig.at("T_lidar_lidar").contains("left__top")) << rig.dump(1);
  const std::string urdf = io::read_file(out / "rig.urdf");
  for (const std::string& name : kNames) {
    SCOPED_TRACE(name);
    // Each LiDAR's own outputs, read from its own topic, started from its own --init.
    const nlohmann::json input = read_json(out / name / "extrinsic.json").at("input");
    EXPECT_TRUE(contains(input.at("source").get<std::string>(), "topic /" + name)) << input.dump(1);
    EXPECT_TRUE(contains(input.at("init").get<std::string>(), "init-extrinsic-" + name + ".json")) << input.dump(1);
    EXPECT_TRUE(contains(urdf, name)) << urdf;
    ASSERT_TRUE(rig.at("lidars").contains(name)) << rig.dump(1);
    // Each LiDAR started from its own wrong guess and ends within the README's bounds.
    const Iso3 T_true = transform_of(truth.at(name).at("T_ins_lidar"));
    const Iso3 T_init = io::read_opencalib_extrinsic(bag / ("init-extrinsic-" + name + ".json"));
    EXPECT_GT(extrinsic_error(T_init, T_true).angle_deg, 1.0);
    const Iso3 T = transform_of(rig.at("lidars").at(name).at("T_ins_lidar"));
    const ExtrinsicError e = extrinsic_error(T, T_true);
    std::printf("%s: |t| %.1f %.1f %.1f mm, |rpy| %.4f %.4f %.4f deg\n", name.c_str(), 1e3 * e.dt_m.x(), 1e3 * e.dt_m.y(),
                1e3 * e.dt_m.z(), e.drpy_deg.x(), e.drpy_deg.y(), e.drpy_deg.z());
    EXPECT_LT(e.drpy_deg.maxCoeff(), 0.05);
    EXPECT_LT(e.dt_m.head<2>().maxCoeff(), 0.02);
    const double offset = rig.at("lidars").at(name).at("time_offset_s").get<double>();
    EXPECT_NEAR(offset, truth.at(name).at("time_offset_s").get<double>(), 0.002);
    // This short drive passes too few fiducials for stage 3: tz is said undetermined (not checked).
    EXPECT_EQ(rig.at("lidars").at(name).at("determined").at("tz"), rig_pcd.at("lidars").at(name).at("determined").at("tz"));
    // The same drive from its folders: the same truth (Odometry's ins is the simulator's), the same answer.
    EXPECT_LT(extrinsic_error(transform_of(truth_pcd.at(name).at("T_ins_lidar")), T_true).angle_deg, 1e-9);
    const ExtrinsicError d = extrinsic_error(transform_of(rig_pcd.at("lidars").at(name).at("T_ins_lidar")), T);
    // The recording's sweeps and poses equal the folder's to float rounding; the start the data
    // finds beside the --init (global_init kDataNearInit) carries that into the result: 1e-5.
    // tz, undetermined here (decimetres off), is flat to the data: rounding moves it up to 3e-5.
    EXPECT_LE(d.dt_m.head<2>().norm(), 1e-5);
    EXPECT_LE(d.dt_m.z(), 1e-4);
    EXPECT_LE(d.angle_deg, 1e-5);
    EXPECT_NEAR(rig_pcd.at("lidars").at(name).at("time_offset_s").get<double>(), offset, 1e-6);
  }
  // --init repeated must match the --lidar-topic count: exit 2 before anything is read or written.
  const auto [rc_n, text_n] = run("calibrate --bag " + (bag / "drive.mcap").string() + " --lidar-topic /top --lidar-topic /left --init " +
                                  (bag / "init-extrinsic-top.json").string() + " --init a.json --init b.json --out " +
                                  (dir / "out_n").string());
  EXPECT_EQ(rc_n, 2) << text_n;
  EXPECT_TRUE(contains(text_n, "3 --init for 2 LiDARs")) << text_n;
  EXPECT_TRUE(contains(text_n, "--lidar-topic")) << text_n;
  EXPECT_FALSE(fs::exists(dir / "out_n"));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace insalign
