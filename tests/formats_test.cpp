#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <unistd.h>

#include "core/errors.hpp"
#include "files/formats.hpp"

namespace insalign::io {
namespace {

double max_abs_diff(const Iso3& a, const Iso3& b) { return (a.matrix() - b.matrix()).cwiseAbs().maxCoeff(); }

std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Random mounts, including yaw beyond +-90 deg and a sensor mounted upside down (roll 180 deg).
std::vector<Iso3> sample_transforms() {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Iso3> out = {Iso3::Identity(), make_transform({0.3, -0.1, 1.8}, {180.0, 2.0, -135.0})};
  for (int i = 0; i < 20; ++i) {
    out.push_back(make_transform({2 * u(rng), 2 * u(rng), 2 * u(rng)}, {170 * u(rng), 85 * u(rng), 179 * u(rng)}));
  }
  return out;
}

TEST(Formats, UrdfRoundTrip) {
  const FrameNames names{"gnss", "top_lidar"};
  for (const Iso3& T : sample_transforms()) {
    const ReadTransform back = parse_urdf(format_urdf(T, names), "x.urdf");
    EXPECT_LT(max_abs_diff(back.T_parent_child, T), 1e-9);
    EXPECT_EQ(back.names.parent, "gnss");
    EXPECT_EQ(back.names.child, "top_lidar");
  }
}

TEST(Formats, Ros2StaticTfRoundTrip) {
  for (const Iso3& T : sample_transforms()) {
    const ReadTransform back = parse_ros2_static_tf(format_ros2_static_tf(T, {}), "x.sh");
    EXPECT_LT(max_abs_diff(back.T_parent_child, T), 1e-9);
    EXPECT_EQ(back.names.parent, "ins");
    EXPECT_EQ(back.names.child, "lidar");
  }
}

TEST(Formats, AutowareYamlRoundTrip) {
  for (const Iso3& T : sample_transforms()) {
    const ReadTransform back = parse_autoware_yaml(format_autoware_yaml(T, {"base_link", "velodyne_top"}), "x.yaml");
    EXPECT_LT(max_abs_diff(back.T_parent_child, T), 1e-9);
    EXPECT_EQ(back.names.parent, "base_link");
    EXPECT_EQ(back.names.child, "velodyne_top");
  }
}

TEST(Formats, KittiRoundTripAndDirection) {
  for (const Iso3& T : sample_transforms()) {
    EXPECT_LT(max_abs_diff(parse_kitti_imu_to_velo(format_kitti_imu_to_velo(T), "c.txt").T_parent_child, T), 1e-9);
  }
  // The stored R|T maps IMU coordinates into Velodyne coordinates: a LiDAR 1.5 m above the INS
  // sees the INS origin at z = -1.5.
  const std::string text = format_kitti_imu_to_velo(make_transform({0, 0, 1.5}, {0, 0, 0}));
  EXPECT_NE(text.find("\nT: 0 0 -1.5\n"), std::string::npos) << text;
}

TEST(Formats, UrdfRpyIsFixedAxisXyz) {
  // A yaw of 90 deg about the parent z: the child x axis points along the parent y axis.
  const std::string urdf = "<joint><origin xyz=\"1 2 3\" rpy=\"0 0 1.5707963267948966\"/></joint>";
  const Iso3 T = parse_urdf(urdf, "j.urdf").T_parent_child;
  EXPECT_LT((T.linear() * Vec3::UnitX() - Vec3::UnitY()).norm(), 1e-12);
  EXPECT_LT((T.translation() - Vec3(1, 2, 3)).norm(), 1e-12);
}

TEST(Formats, ReadersRejectBadInputNamingTheLine) {
  try {
    parse_urdf("<robot>\n<joint>\n  <origin xyz=\"1 2\" rpy=\"0 0 0\"/>\n</joint></robot>", "bad.urdf");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "bad.urdf");
    EXPECT_EQ(e.location(), "line 3");
  }
  try {
    parse_kitti_imu_to_velo("calib_time: x\nR: 1 0 0 0 1 0 0 0 1\nT: 0 zero 0\n", "calib.txt");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.location(), "line 3");
  }
  EXPECT_THROW(parse_kitti_imu_to_velo("R: 1 0 0 0 2 0 0 0 1\nT: 0 0 0\n", "c.txt"), InputError);
  EXPECT_THROW(parse_ros2_static_tf("ros2 run tf2_ros static_transform_publisher --x", "r.sh"), InputError);
  try {
    parse_autoware_yaml("base_link:\n  lidar:\n    x: 1\n    y: 2\n    z: [3]\n    roll: 0\n    pitch: 0\n    yaw: 0\n", "a.yaml");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.location(), "line 5");
  }
}

TEST(Formats, WriteAllFormatsWritesReadableFiles) {
  const auto dir = std::filesystem::temp_directory_path() / ("insalign_formats_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  const Iso3 T = make_transform({0.12, -0.34, 1.56}, {1.5, -2.5, 93.0});
  const auto files = write_all_formats(dir, T, {"gnss", "lidar"});
  ASSERT_EQ(files.size(), 4u);
  EXPECT_LT(max_abs_diff(parse_urdf(read_text(dir / kUrdfFile), "u").T_parent_child, T), 1e-9);
  EXPECT_LT(max_abs_diff(parse_ros2_static_tf(read_text(dir / kRos2File), "r").T_parent_child, T), 1e-9);
  EXPECT_LT(max_abs_diff(parse_autoware_yaml(read_text(dir / kAutowareFile), "a").T_parent_child, T), 1e-9);
  EXPECT_LT(max_abs_diff(parse_kitti_imu_to_velo(read_text(dir / kKittiFile), "k").T_parent_child, T), 1e-9);
  EXPECT_NE(std::filesystem::status(dir / kRos2File).permissions() & std::filesystem::perms::owner_exec,
            std::filesystem::perms::none);
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    EXPECT_EQ(entry.path().string().find(".tmp."), std::string::npos) << "leftover " << entry.path();
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace insalign::io
