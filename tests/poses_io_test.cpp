// Pose files (OpenCalib and TUM), frame-name times and fiducial files.
#include "files/poses.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <random>

#include "core/errors.hpp"
#include "files/fiducials.hpp"

namespace insalign::io {
namespace {

namespace fs = std::filesystem;

const fs::path kNovatel = fs::path(INSALIGN_SHARED_DATA_DIR) / "opencalib-sample" / "NovAtel-pose-lidar-time.txt";

fs::path temp_file(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("insalign_poses_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir / name;
}

std::vector<Iso3> random_poses(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  std::vector<Iso3> out;
  for (std::size_t i = 0; i < n; ++i) {
    out.push_back(make_transform(Vec3(u(rng) * 100, u(rng) * 100, u(rng)), Vec3(u(rng), u(rng), u(rng) * 60)));
  }
  return out;
}

TEST(FrameNameTime, Formats) {
  EXPECT_DOUBLE_EQ(*time_from_frame_name("1635236489.468"), 1635236489.468);
  EXPECT_NEAR(*time_from_frame_name("1635236489468123456"), 1635236489.468123456, 1e-6);
  EXPECT_NEAR(*time_from_frame_name("1635236489468123"), 1635236489.468123, 1e-6);
  EXPECT_NEAR(*time_from_frame_name("1635236489468"), 1635236489.468, 1e-6);
  EXPECT_DOUBLE_EQ(*time_from_frame_name("1635236489"), 1635236489.0);
  // 2021-10-26 16:21:29.468 read as UTC.
  EXPECT_NEAR(*time_from_frame_name("2021-10-26-16-21-29-468"), 1635265289.468, 1e-6);
  EXPECT_NEAR(*time_from_frame_name("1970-01-01-00-00-00"), 0.0, 1e-9);
  EXPECT_NEAR(*time_from_frame_name("2000-03-01_00_00_01_5"), 951868801.5, 1e-9);
  EXPECT_FALSE(time_from_frame_name("000123"));
  EXPECT_FALSE(time_from_frame_name("frame_12"));
  EXPECT_FALSE(time_from_frame_name(""));
  EXPECT_FALSE(time_from_frame_name("2021-13-26-16-21-29-468"));
  EXPECT_FALSE(time_from_frame_name("1.2.3"));
}

TEST(PoseFileIo, RealNovatelFile) {
  if (!fs::exists(kNovatel)) GTEST_SKIP() << "shared sample data not found at " << kNovatel;
  const PoseFile f = read_pose_file(kNovatel);
  EXPECT_EQ(f.format, PoseFormat::kOpenCalib);
  ASSERT_EQ(f.T_world_ins.size(), 1081u);
  EXPECT_EQ(f.frame_names.front(), "2021-10-26-16-21-29-468");
  EXPECT_EQ(f.frame_names.back(), "2021-10-26-16-23-17-529");
  EXPECT_NEAR(f.t_s.back() - f.t_s.front(), 108.061, 1e-6);
  EXPECT_LT(f.T_world_ins.front().translation().norm(), 1e-3);  // first pose close to identity
  EXPECT_EQ(f.reorthonormalised, 0u);  // 9 decimals: only print rounding
  EXPECT_NEAR(f.T_world_ins.back().translation().x(), -2.373168269, 1e-9);
}

TEST(PoseFileIo, OpenCalibLeadingSpaceCommentsAndRoundTrip) {
  const fs::path p = temp_file("oc.txt");
  std::vector<std::string> names = {"a", "1635236489.5", "frame-3"};
  const std::vector<Iso3> poses = random_poses(3, 4);
  write_opencalib_poses(p, names, poses);
  const PoseFile f = read_pose_file(p);
  ASSERT_EQ(f.T_world_ins.size(), 3u);
  EXPECT_EQ(f.frame_names, names);
  EXPECT_TRUE(std::isnan(f.t_s[0]));
  EXPECT_DOUBLE_EQ(f.t_s[1], 1635236489.5);
  for (std::size_t i = 0; i < 3; ++i) EXPECT_TRUE(f.T_world_ins[i].isApprox(poses[i], 1e-14));

  std::ofstream(p) << " f1 1 0 0 1.5 0 1 0 2 0 0 1 3   # first line starts with a space\n\n# comment\nf2 1 0 0 0 0 1 0 0 0 0 1 0\n";
  const PoseFile g = read_pose_file(p);
  ASSERT_EQ(g.T_world_ins.size(), 2u);
  EXPECT_EQ(g.frame_names[0], "f1");
  EXPECT_EQ(g.T_world_ins[0].translation(), Vec3(1.5, 2, 3));
  EXPECT_EQ(g.line[1], 4u);
  fs::remove_all(p.parent_path());
}

TEST(PoseFileIo, TumRoundTrip) {
  const fs::path p = temp_file("tum.txt");
  const std::vector<Iso3> T = random_poses(50, 5);
  std::vector<StampedPose> in;
  for (std::size_t i = 0; i < T.size(); ++i) in.push_back({1635236489.0 + 0.01 * static_cast<double>(i), T[i]});
  write_tum_poses(p, in);
  const PoseFile f = read_pose_file(p);
  EXPECT_EQ(f.format, PoseFormat::kTum);
  EXPECT_TRUE(f.frame_names.empty());
  ASSERT_EQ(f.T_world_ins.size(), in.size());
  for (std::size_t i = 0; i < in.size(); ++i) {
    EXPECT_EQ(f.t_s[i], in[i].t_s);
    EXPECT_TRUE(f.T_world_ins[i].isApprox(in[i].T_world_ins, 1e-12));
  }
  fs::remove_all(p.parent_path());
}

TEST(FiducialIo, RoundTripAndComments) {
  const fs::path p = temp_file("fid.txt");
  const std::vector<Fiducial> in = {{"gcp1", Vec3(351234.125, 3456789.5, 12.25)}, {"2", Vec3(-1.0 / 3, 0, 1e-9)}};
  write_fiducials(p, in);
  const std::vector<Fiducial> out = read_fiducials(p);
  ASSERT_EQ(out.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(out[i].id, in[i].id);
    EXPECT_EQ(out[i].p_world, in[i].p_world);
  }
  std::ofstream(p) << "# surveyed\n  A 1 2 3  # corner\n\nB -1e2 +2 3.5\n";
  const std::vector<Fiducial> g = read_fiducials(p);
  ASSERT_EQ(g.size(), 2u);
  EXPECT_EQ(g[1].p_world, Vec3(-100, 2, 3.5));
  fs::remove_all(p.parent_path());
}

}  // namespace
}  // namespace insalign::io
