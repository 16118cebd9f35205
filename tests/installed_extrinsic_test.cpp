// io/installed_extrinsic: every format calibrate writes (and the rig's) reads back as the
// T_ins_lidar written, detected from the content; anything else is an InputError naming the file.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "cli_test_util.hpp"
#include "core/errors.hpp"
#include "files/atomic_file.hpp"
#include "files/extrinsic_json.hpp"
#include "files/formats.hpp"
#include "files/installed_extrinsic.hpp"
#include "files/read_file.hpp"

namespace insalign::io {
namespace {

const Iso3 kT = make_transform(Vec3(1.27, -0.07, 1.05), Vec3(9.9, -2.4, 152.8));

void expect_same(const Iso3& a, const Iso3& b, const std::string& what) {
  EXPECT_LT(extrinsic_error(a, b).angle_deg, 1e-9) << what;
  EXPECT_LT(extrinsic_error(a, b).dt_norm_m, 1e-9) << what;
}

TEST(InstalledExtrinsic, ReadsEveryFormatCalibrateWrites) {
  const insalign::testing::ScratchDir scratch("installed_", "formats");
  const auto dir = scratch.path();
  std::vector<std::filesystem::path> files = write_all_formats(dir, kT);
  write_opencalib_extrinsic(dir / "opencalib.json", kT);
  files.push_back(dir / "opencalib.json");
  nlohmann::json ext = {{"T_ins_lidar", transform_to_json(kT)}, {"time_offset_s", 0.004}};
  write_file_atomic(dir / "extrinsic.json", ext.dump());
  files.push_back(dir / "extrinsic.json");
  for (const auto& f : files) {
    const auto e = read_installed_extrinsics(f);
    ASSERT_EQ(e.size(), 1u) << f;
    expect_same(e[0].T_ins_lidar, kT, f.string());
  }
  EXPECT_DOUBLE_EQ(read_installed_extrinsics(dir / "extrinsic.json")[0].time_offset_s, 0.004);
  EXPECT_EQ(read_installed_extrinsics(dir / "opencalib.json")[0].format, "opencalib");
  EXPECT_EQ(read_installed_extrinsics(dir / kKittiFile)[0].format, "kitti");
}

TEST(InstalledExtrinsic, ReadsARigByName) {
  const Iso3 left = make_transform(Vec3(0.2, 0.9, 1.2), Vec3(0.0, 10.0, 90.0));
  nlohmann::json rig = {{"lidars",
                         {{"top", {{"T_ins_lidar", transform_to_json(kT)}, {"time_offset_s", 0.0}}},
                          {"left", {{"T_ins_lidar", transform_to_json(left)}, {"time_offset_s", 0.01}}}}},
                        {"T_lidar_lidar", nlohmann::json::object()}};
  const auto e = parse_installed_extrinsics(rig.dump(), "rig.json");
  ASSERT_EQ(e.size(), 2u);
  for (const auto& x : e) expect_same(x.T_ins_lidar, x.name == "top" ? kT : left, x.name);
  const std::string urdf = "<robot name=\"r\">\n<link name=\"ins\"/>\n" + format_urdf(kT, {"ins", "top"}) + format_urdf(left, {"ins", "left"}) + "</robot>\n";
  const auto u = parse_installed_extrinsics(urdf, "rig.urdf");
  ASSERT_EQ(u.size(), 2u);
  EXPECT_EQ(u[0].name, "top");
  EXPECT_EQ(u[1].name, "left");
  expect_same(u[1].T_ins_lidar, left, "urdf left");
}

// --init takes the same files: a previous result re-used as the start; a rig's file is refused
// with what to do instead.
TEST(InstalledExtrinsic, InitTakesAnyFormatOfOneExtrinsic) {
  const insalign::testing::ScratchDir scratch("installed_", "init");
  const auto dir = scratch.path();
  for (const auto& f : write_all_formats(dir, kT)) expect_same(read_init_extrinsic(f), kT, f.string());
  write_opencalib_extrinsic(dir / "opencalib.json", kT);
  expect_same(read_init_extrinsic(dir / "opencalib.json"), kT, "opencalib");
  const Iso3 left = make_transform(Vec3(0.2, 0.9, 1.2), Vec3(0.0, 10.0, 90.0));
  const std::string urdf = "<robot name=\"r\">\n<link name=\"ins\"/>\n" + format_urdf(kT, {"ins", "top"}) +
                           format_urdf(left, {"ins", "left"}) + "</robot>\n";
  write_file_atomic(dir / "rig.urdf", urdf);
  try {
    (void)read_init_extrinsic(dir / "rig.urdf");
    ADD_FAILURE() << "a rig's URDF taken as one --init";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("rig.urdf"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("one --init per LiDAR"), std::string::npos) << e.what();
  }
}

TEST(InstalledExtrinsic, SomethingElseIsAnInputErrorNamingTheFile) {
  for (const std::string text : {"", "hello", "{\"a\": 1}", "{\"T_ins_lidar\": [1, 2]}", "{broken"}) {
    try {
      (void)parse_installed_extrinsics(text, "x.json");
      ADD_FAILURE() << "accepted: " << text;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("x.json"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace insalign::io
