// insalign check end to end on simulated ordinary drives (insalign simulate --trajectory
// city-loop ... --knock): every verdict and exit code, the check.json shape, corrected/, the
// history's step detection, and the bad inputs of the issue (inverted extrinsic, another
// LiDAR's extrinsic, a drive that barely moves, a recording without INS). Reduced resolution
// (VLP-16 at 0.8 deg) keeps each test well under a minute.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <nlohmann/json.hpp>
#include <tuple>

#include "cli_test_util.hpp"
#include "core/geometry.hpp"
#include "recording/bag_writer.hpp"
#include "recording/bag_reader.hpp"
#include "recording/bag_topics.hpp"
#include "files/extrinsic_json.hpp"
#include "files/read_file.hpp"

namespace insalign {
namespace {

namespace fs = std::filesystem;
using insalign::testing::contains;
using insalign::testing::run_command;
using nlohmann::json;

std::string exe() { return INSALIGN_EXE; }

// A simulated drive shared by the tests of this file (each runs in its own process): made once
// under the temp directory, renamed into place when complete so a parallel test never sees half.
// Kept after the run on purpose: a cache across test processes and runs, not scratch.
fs::path drive(const std::string& name, const std::string& options) {
  const fs::path dir = fs::temp_directory_path() / ("insalign_check_drive_" + name);
  if (fs::exists(dir / "installed-extrinsic.json")) return dir;
  const fs::path tmp = fs::temp_directory_path() / ("insalign_check_drive_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(tmp);
  const auto [rc, text] = run_command(exe() + " simulate --quiet --lidar vlp16 --azimuth-step-deg 0.8 --seed 5 --out " +
                                      tmp.string() + " " + options);
  if (rc != 0) {  // never cached: the next run simulates again
    ADD_FAILURE() << text;
    fs::remove_all(tmp);
    return dir;
  }
  std::error_code ec;
  fs::rename(tmp, dir, ec);  // another process may have won: its copy is as good
  if (ec) fs::remove_all(tmp);
  return dir;
}

fs::path city_drive() { return drive("city", "--trajectory city-loop --duration-s 100 --traffic 6"); }
fs::path knocked_city_drive() {
  return drive("city_knock", "--trajectory city-loop --duration-s 110 --traffic 6 --knock \"0.025 0 0 0 0 0.12\"");
}

struct Check {
  int rc = -1;
  std::string text;
  json out;
};

Check check(const fs::path& d, const std::string& extrinsic, const fs::path& out, const std::string& more = "") {
  fs::remove_all(out);
  Check c;
  std::tie(c.rc, c.text) = run_command(exe() + " check --lidar-dir " + (d / "lidar").string() + " --poses " +
                                       (d / "poses_tum.txt").string() + " --extrinsic " + extrinsic + " --out " +
                                       out.string() + " " + more);
  if (fs::exists(out / "check.json")) c.out = json::parse(io::read_file(out / "check.json"));
  return c;
}

std::string verdict(const Check& c, const char* dof) { return c.out["dofs"][dof]["verdict"].get<std::string>(); }

TEST(CheckCli, UnchangedExtrinsicIsNeverDriftedAndOkWithTzUnchecked) {
  const fs::path d = city_drive();
  const insalign::testing::ScratchDir scratch("check_", "unchanged");
  const fs::path out = scratch.path();
  const Check c = check(d, (d / "installed-extrinsic.json").string(), out / "a");
  // tz cannot be seen without fiducials or a height: inconclusive (exit 3), naming it.
  EXPECT_EQ(c.rc, 3) << c.text;
  ASSERT_TRUE(c.out.is_object()) << c.text;
  EXPECT_EQ(c.out["verdict"], "inconclusive");
  EXPECT_TRUE(contains(c.text, "tz needs fiducials")) << c.text;
  for (const char* dof : {"tx", "ty", "roll", "pitch", "yaw"}) EXPECT_EQ(verdict(c, dof), "ok") << dof << c.text;
  // The time offset's honest stddev on this 100 s one-way loop (about 0.9 ms) cannot clear the 2 ms
  // tolerance by 2 stddev: not-observable is allowed, drifted never; its correction stays covered.
  EXPECT_NE(verdict(c, "time_offset"), "drifted") << c.text;
  const json& offset = c.out["dofs"]["time_offset"];
  EXPECT_LE(std::abs(offset["correction"].get<double>()), 3.0 * offset["stddev"].get<double>());
  EXPECT_EQ(verdict(c, "tz"), "not-observable");
  EXPECT_FALSE(fs::exists(out / "a" / "corrected"));
  EXPECT_TRUE(fs::exists(out / "a" / "check.html"));
  EXPECT_TRUE(fs::exists(out / "a" / "report" / "viewer_data.js"));  // its 3D view (docs/viewer.md)
  EXPECT_EQ(c.out["drives"], 1);
  EXPECT_FALSE(c.out["used"].empty());
  for (const char* key : {"checked", "corrected", "since", "warnings"}) EXPECT_TRUE(c.out.contains(key)) << key;
  // The crispness at the installed and the corrected extrinsic are both measured.
  EXPECT_GT(c.out["crispness_m"]["installed"].get<double>(), 0.0);
  const Check ok = check(d, (d / "installed-extrinsic.json").string(), out / "b", "--set check.unchecked_dofs=tz,time_offset");
  EXPECT_EQ(ok.rc, 0) << ok.text;
  EXPECT_EQ(ok.out["verdict"], "ok");
}

TEST(CheckCli, KnockIsRecalibrateWithTheCorrectionWithinThreeStddev) {
  const fs::path d = knocked_city_drive();
  const insalign::testing::ScratchDir scratch("check_", "knock");
  const fs::path out = scratch.path();
  const Check c = check(d, (d / "installed-extrinsic.json").string(), out);
  EXPECT_EQ(c.rc, 4) << c.text;
  ASSERT_TRUE(c.out.is_object()) << c.text;
  EXPECT_EQ(c.out["verdict"], "recalibrate");
  EXPECT_EQ(verdict(c, "tx"), "drifted");
  EXPECT_EQ(verdict(c, "yaw"), "drifted");
  EXPECT_TRUE(contains(c.text, "tx") && contains(c.text, "yaw")) << c.text;
  const double knock[] = {0.025, 0.0, 0.0, 0.0, 0.0, 0.12};
  const char* names[] = {"tx", "ty", "tz", "roll", "pitch", "yaw"};
  for (int i : {0, 1, 3, 4, 5}) {
    const json& dof = c.out["dofs"][names[i]];
    EXPECT_LE(std::abs(dof["correction"].get<double>() - knock[i]), 3.0 * dof["stddev"].get<double>()) << names[i];
  }
  // The time offset too (the installed one is the true one): its stddev is the segments' honest
  // one, not the formal few microseconds that a 0.1-0.4 ms error exceeded by 20-70 stddev.
  const json& offset = c.out["dofs"]["time_offset"];
  EXPECT_LE(std::abs(offset["correction"].get<double>()), 3.0 * offset["stddev"].get<double>());
  EXPECT_GT(offset["stddev"].get<double>(), 2e-5);
  // corrected/ in every format calibrate writes, and the corrected extrinsic is nearer the truth.
  for (const char* f : {"extrinsic.json", "gnss-to-lidar-extrinsic.json", "extrinsic.urdf.xacro", "calib_imu_to_velo.txt",
                        "static_transform_publisher.sh", "extrinsic_autoware.yaml"})
    EXPECT_TRUE(fs::exists(out / "corrected" / f)) << f;
  const json gt = json::parse(io::read_file(d / "ground_truth.json"));
  const Iso3 truth = io::transform_from_json(gt["T_ins_lidar"], "gt");
  const Iso3 corrected = io::read_extrinsic_file(out / "corrected" / "extrinsic.json").T_ins_lidar;
  const Iso3 installed = io::read_extrinsic_file(d / "installed-extrinsic.json").T_ins_lidar;
  EXPECT_LT(extrinsic_error(corrected, truth).angle_deg, 0.04);
  EXPECT_GT(extrinsic_error(installed, truth).angle_deg, 0.11);
  // The corrected extrinsic checks ok (with tz unchecked) on the same drive.
  const Check again = check(d, (out / "corrected" / "extrinsic.json").string(), out / "again", "--set check.unchecked_dofs=tz");
  EXPECT_EQ(again.rc, 0) << again.text;
}

// A highway's gentle curves cannot show the lever arm or roll; pitch and yaw they do show: those
// DOFs are held at the installed values and the others still checked (before, the stages stopped
// and the highway decided nothing).
TEST(CheckCli, HighwayChecksPitchAndYawAndHoldsTheLeverArm) {
  const fs::path d = drive("highway_knock", "--trajectory highway --duration-s 120 --traffic 4 --knock \"0 0 0 0 0 0.12\"");
  const insalign::testing::ScratchDir scratch("check_", "highway");
  const fs::path out = scratch.path();
  const Check c = check(d, (d / "installed-extrinsic.json").string(), out / "a");
  EXPECT_EQ(c.rc, 4) << c.text;
  ASSERT_TRUE(c.out.is_object()) << c.text;
  EXPECT_EQ(verdict(c, "yaw"), "drifted") << c.text;
  const json& yaw = c.out["dofs"]["yaw"];
  EXPECT_LE(std::abs(yaw["correction"].get<double>() - 0.12), 3.0 * yaw["stddev"].get<double>()) << c.text;
  EXPECT_NE(verdict(c, "pitch"), "drifted") << c.text;
  for (const char* dof : {"tx", "ty", "roll", "time_offset"}) {
    EXPECT_EQ(verdict(c, dof), "not-observable") << dof << c.text;
    EXPECT_TRUE(c.out["dofs"][dof]["stddev"].is_null()) << dof;
  }
  EXPECT_TRUE(contains(c.text, "held at the starting values")) << c.text;
  // The corrected extrinsic: nothing drifted any more.
  const Check again = check(d, (out / "a" / "corrected" / "extrinsic.json").string(), out / "b");
  EXPECT_EQ(again.rc, 3) << again.text;
  for (const char* dof : {"tx", "ty", "roll", "pitch", "yaw"}) EXPECT_NE(verdict(again, dof), "drifted") << dof;
}

// The same car 10 s later after a knock: its true mount is drive A's knocked, and it still believes
// drive A's (which is A's truth).
fs::path later_knocked_city_drive() {
  const json gt = json::parse(io::read_file(city_drive() / "ground_truth.json"));
  const Iso3 T = io::transform_from_json(gt["T_ins_lidar"], "gt");
  Iso3 knocked = T;
  knocked.linear() = rotation_from_rpy(Vec3(0, 0, 0.12 * kRadPerDeg)) * T.linear();
  knocked.translation() += Vec3(0.025, 0, 0);
  const Vec3 t = knocked.translation(), rpy = rpy_from_rotation(knocked.linear()) * kDegPerRad;
  const std::string extrinsic = std::to_string(t.x()) + " " + std::to_string(t.y()) + " " + std::to_string(t.z()) + " " +
                                std::to_string(rpy.x()) + " " + std::to_string(rpy.y()) + " " + std::to_string(rpy.z());
  return drive("city_later", "--trajectory city-loop --duration-s 110 --traffic 6 --extrinsic \"" + extrinsic + "\"");
}

TEST(CheckCli, HistoryCombinesDrivesAndDatesTheKnock) {
  const fs::path a = city_drive(), b = later_knocked_city_drive();
  const insalign::testing::ScratchDir scratch("check_", "history");
  const fs::path out = scratch.path();
  const std::string installed = (a / "installed-extrinsic.json").string();  // the same for both drives
  const fs::path history = out / "history";
  const Check first = check(a, installed, out / "1", "--history " + history.string());
  EXPECT_EQ(first.out["drives"], 1);
  const Check second = check(b, installed, out / "2", "--history " + history.string());
  EXPECT_EQ(second.rc, 4) << second.text;
  ASSERT_TRUE(second.out.contains("history_steps")) << second.text;
  ASSERT_EQ(second.out["history_steps"].size(), 1u) << second.out.dump(2);
  EXPECT_EQ(second.out["history_steps"][0]["date"], second.out["drive_end"]);
  EXPECT_EQ(second.out["drives"], 1);  // the knock is not averaged with the drive before it
  EXPECT_EQ(second.out["since"], second.out["drive_end"]);
  int records = 0;
  for (const auto& e : fs::directory_iterator(history)) records += e.path().string().ends_with(".check.json");
  EXPECT_EQ(records, 2);
  // Checking the unchanged drive again replaces its record and finds the same step.
  const Check repeat = check(a, installed, out / "3", "--history " + history.string());
  EXPECT_EQ(repeat.out["history_steps"].size(), 1u);
}

TEST(CheckCli, InvertedExtrinsicIsGrosslyOffAndSaysInvertIt) {
  const fs::path d = city_drive();
  const insalign::testing::ScratchDir scratch("check_", "inverted");
  const fs::path out = scratch.path();
  const Iso3 installed = io::read_extrinsic_file(d / "installed-extrinsic.json").T_ins_lidar;
  std::ofstream(out / "inverted.json") << json{{"T_ins_lidar", io::transform_to_json(installed.inverse())}}.dump();
  const Check c = check(d, (out / "inverted.json").string(), out / "o");
  EXPECT_EQ(c.rc, 4) << c.text;
  EXPECT_TRUE(contains(c.text, "invert it")) << c.text;
  // Another LiDAR's extrinsic (a left-side mount): grossly off, and the message asks whether it is this LiDAR's.
  const Iso3 side = make_transform(Vec3(0.1, 0.9, 1.3), Vec3(0.0, 15.0, 90.0));
  std::ofstream(out / "side.json") << json{{"T_ins_lidar", io::transform_to_json(side)}}.dump();
  const Check s = check(d, (out / "side.json").string(), out / "s");
  EXPECT_EQ(s.rc, 4) << s.text;
  EXPECT_TRUE(contains(s.text, "another LiDAR")) << s.text;
}

TEST(CheckCli, DriveThatBarelyMovesIsInconclusiveWithWhy) {
  const fs::path d = drive("standstill", "--trajectory standstill --duration-s 10");
  const insalign::testing::ScratchDir scratch("check_", "standstill");
  const fs::path out = scratch.path();
  const Check c = check(d, (d / "installed-extrinsic.json").string(), out);
  EXPECT_EQ(c.rc, 3) << c.text;
  EXPECT_EQ(c.out["verdict"], "inconclusive");
  EXPECT_TRUE(contains(c.text, "m")) << c.text;
  EXPECT_TRUE(c.out["drive"].contains("why_unobservable")) << c.out.dump(2);
}

TEST(CheckCli, RecordingWithoutInsAndBadExtrinsicsExitTwo) {
  const fs::path bag = fs::path(INSALIGN_TEST_DATA_DIR) / "bags" / "ros1_hesai_inspva.bag";
  const insalign::testing::ScratchDir scratch("check_", "noins");
  const fs::path out = scratch.path();
  // The recording rewritten without its INS topics.
  const auto reader = io::bag::open_bag(bag);
  const auto writer = io::bag::make_bag_writer(io::bag::BagFormat::kRos1, out / "no_ins.bag");
  std::vector<std::tuple<std::int64_t, std::uint32_t, io::bag::MessageRef>> all;
  for (std::uint32_t t = 0, w = 0; t < reader->topics().size(); ++t) {
    if (io::ins_source_kind(reader->topics()[t].type)) continue;
    ASSERT_EQ(writer->add_topic(reader->topics()[t]), w++);
    for (const io::bag::MessageRef& m : reader->messages(t)) all.emplace_back(m.log_time_ns, w - 1, m);
  }
  std::sort(all.begin(), all.end(), [](const auto& a, const auto& b) { return std::get<0>(a) < std::get<0>(b); });
  for (const auto& [ns, t, ref] : all) writer->write(t, ns, reader->read(ref));
  writer->close();
  const fs::path d = city_drive();
  const auto [rc, text] = run_command(exe() + " check --bag " + (out / "no_ins.bag").string() + " --extrinsic " +
                                      (d / "installed-extrinsic.json").string() + " --out " + (out / "o").string());
  EXPECT_EQ(rc, 2) << text;
  EXPECT_TRUE(contains(text, "INS")) << text;
  EXPECT_FALSE(fs::exists(out / "o" / "check.json"));
  // An extrinsic file that is none of the formats, and two extrinsics for one LiDAR.
  std::ofstream(out / "junk.txt") << "hello\n";
  const Check junk = check(d, (out / "junk.txt").string(), out / "j");
  EXPECT_EQ(junk.rc, 2) << junk.text;
  EXPECT_TRUE(contains(junk.text, "junk.txt")) << junk.text;
  const std::string e = (d / "installed-extrinsic.json").string();
  const Check two = check(d, e + " --extrinsic " + e, out / "t");
  EXPECT_EQ(two.rc, 2) << two.text;
  const Check bad_key = check(d, e, out / "k", "--set check.unchecked_dofs=height");
  EXPECT_EQ(bad_key.rc, 2) << bad_key.text;
}

}  // namespace
}  // namespace insalign
