// load_dataset, summarize_drive and `insalign info`, on the real sample and on synthetic folders.
#include "cli_test_util.hpp"
#include "input/dataset.hpp"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <thread>

#include "core/errors.hpp"
#include "files/extrinsic_json.hpp"
#include "files/fiducials.hpp"
#include "pointcloud/pcd.hpp"
#include "files/poses.hpp"

namespace insalign::io {
namespace {

namespace fs = std::filesystem;

const fs::path kSample = fs::path(INSALIGN_SHARED_DATA_DIR) / "opencalib-sample";

fs::path temp_dir(const std::string& tag) {
  const fs::path dir = fs::temp_directory_path() / ("insalign_ds_" + tag + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "lidar");
  return dir;
}

Sweep synthetic_sweep(std::size_t n, double t_end_s, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-20.f, 20.f);
  Sweep s;
  s.t_end_s = t_end_s;
  for (std::size_t i = 0; i < n; ++i) {
    s.p_lidar.emplace_back(u(rng), u(rng), u(rng));
    s.dt_s.push_back(-0.1f * static_cast<float>(n - 1 - i) / static_cast<float>(n - 1));
  }
  return s;
}

// Runs a command line, returning (exit code, stdout + stderr).
using testing::run_command;

TEST(Dataset, RealSampleMatchesSweepsToPosesByName) {
  if (!fs::exists(kSample)) GTEST_SKIP() << "shared sample data not found at " << kSample;
  LoadReport report;
  const Dataset d = load_dataset({kSample / "top_center_lidar", kSample / "NovAtel-pose-lidar-time.txt",
                                  kSample / "gnss-to-top_center_lidar-extrinsic.json", std::nullopt},
                                 &report);
  ASSERT_EQ(d.frames.frames.size(), 5u);
  EXPECT_EQ(report.frames_total, 5u);
  EXPECT_EQ(report.frames_without_pose, 0u);
  EXPECT_EQ(report.poses_without_frame, 1076u);
  EXPECT_EQ(report.time_field, "timestamp");
  EXPECT_EQ(report.pose_format, "opencalib");
  // Names are local time (UTC+8): the PCD clock is 8 h behind them.
  EXPECT_NEAR(report.name_to_lidar_clock_s, -8 * 3600.0, 0.01);
  EXPECT_TRUE(report.warnings.empty()) << report.warnings.front();
  EXPECT_EQ(d.poses.size(), 1081u);
  EXPECT_NEAR(d.poses.t_end() - d.poses.t_begin(), 108.061, 1e-3);
  ASSERT_TRUE(d.T_ins_lidar_init.has_value());

  const PoseFile file = read_pose_file(kSample / "NovAtel-pose-lidar-time.txt");
  for (std::size_t i = 0; i < 5; ++i) {
    const FrameInfo& f = d.frames.frames[i];
    EXPECT_EQ(f.name, file.frame_names[i]);
    // The frame's own pose line is the pose at the frame time (the world is recentred).
    const Iso3 T = d.poses.T_world_ins(f.t_end_s);
    EXPECT_LT((T.translation() + d.world_origin_m - file.T_world_ins[i].translation()).norm(), 1e-9) << f.name;
    EXPECT_TRUE(T.linear().isApprox(file.T_world_ins[i].linear(), 1e-9));
    // The decoded sweep ends within a few ms of the name-derived frame time.
    const Sweep s = d.frames.load(i);
    EXPECT_EQ(s.name, f.name);
    EXPECT_NEAR(s.t_end_s, f.t_end_s, 0.005);
    if (i > 0) {
      EXPECT_NEAR(f.t_end_s - d.frames.frames[i - 1].t_end_s, 0.1, 1e-6);
    }
  }
  EXPECT_EQ(d.poses.poses().front().T_world_ins.translation(), Vec3::Zero());
}

TEST(Dataset, RealSampleDriveSummary) {
  if (!fs::exists(kSample)) GTEST_SKIP() << "shared sample data not found at " << kSample;
  const Dataset d = load_dataset({kSample / "top_center_lidar", kSample / "NovAtel-pose-lidar-time.txt"});
  const DriveSummary s = summarize_drive(d, 5);
  EXPECT_EQ(s.frames, 5u);
  EXPECT_EQ(s.poses, 1081u);
  EXPECT_NEAR(s.duration_s, 108.06, 0.01);
  EXPECT_NEAR(s.mean_points_per_frame, 80000, 2000);
  EXPECT_NEAR(s.speed_max_mps * 3.6, 15.0, 1.5);
  EXPECT_GT(s.heading_range_deg, 280.0);  // figure-8s: the heading swings through most of a turn
  const Vec3 extent = s.bbox_max_m - s.bbox_min_m;
  EXPECT_NEAR(extent.x(), 15, 3);
  EXPECT_NEAR(extent.y(), 40, 5);
  EXPECT_LT(std::max(std::abs(s.roll_min_deg), std::abs(s.roll_max_deg)), 2.0);
  EXPECT_LT(std::max(std::abs(s.pitch_min_deg), std::abs(s.pitch_max_deg)), 2.0);
}

TEST(DriveSummary, KnownCircle) {
  // 10 m radius circle at 2 m/s for one full turn: distance 2 pi r, heading 360 deg.
  std::vector<StampedPose> poses;
  const double r = 10.0, v = 2.0, period = 2 * M_PI * r / v;
  for (int i = 0; i <= 1000; ++i) {
    const double t = period * i / 1000.0, a = v * t / r;
    Iso3 T = Iso3::Identity();
    T.linear() = Eigen::AngleAxisd(a + M_PI / 2, Vec3::UnitZ()).toRotationMatrix();
    T.translation() = Vec3(r * std::cos(a), r * std::sin(a), 0.0);
    poses.push_back({100.0 + t, T});
  }
  const DriveSummary s = summarize_poses(poses);
  EXPECT_NEAR(s.distance_m, 2 * M_PI * r, 1e-3);
  EXPECT_NEAR(s.heading_change_deg, 360.0, 1e-6);
  EXPECT_NEAR(s.heading_range_deg, 360.0, 1e-6);
  EXPECT_NEAR(s.speed_min_mps, v, 1e-3);
  EXPECT_NEAR(s.speed_max_mps, v, 1e-3);
  EXPECT_NEAR(s.speed_mean_mps, v, 1e-3);
  EXPECT_NEAR(s.bbox_max_m.x() - s.bbox_min_m.x(), 2 * r, 1e-3);
}

TEST(Dataset, TumPosesRelativeTimesFiducialsAndRecentring) {
  const fs::path dir = temp_dir("tum");
  // Frames named by ns timestamps with relative "time" fields; UTM-sized world coordinates.
  const double t0 = 1700000000.0;
  std::vector<StampedPose> poses;
  const Vec3 utm(351000.0, 3456000.0, 20.0);
  for (int i = 0; i <= 40; ++i) {
    Iso3 T = Iso3::Identity();
    T.translation() = utm + Vec3(0.5 * i, 0.0, 0.0);  // 5 m/s at 10 Hz
    poses.push_back({t0 + 0.1 * i, T});
  }
  write_tum_poses(dir / "poses.tum", poses);
  for (int k = 0; k < 6; ++k) {
    const double t_end = t0 - 0.45 + 0.9 * k;  // the first and the last lie outside the poses [t0, t0 + 4]
    const std::string name = std::to_string(static_cast<long long>(std::llround(t_end * 1e9)));
    write_pcd(dir / "lidar" / (name + ".pcd"), synthetic_sweep(200, t_end, k), PcdEncoding::kBinaryCompressed,
              PcdTimeField::kRelative);
  }
  write_fiducials(dir / "fid.txt", {{"A", utm + Vec3(1, 2, -3)}});
  write_opencalib_extrinsic(dir / "init.json", make_transform(Vec3(1, 0, 2), Vec3(0, 0, 90)));
  LoadReport report;
  const Dataset d = load_dataset({dir / "lidar", dir / "poses.tum", dir / "init.json", dir / "fid.txt"}, &report);
  EXPECT_EQ(report.pose_format, "tum");
  EXPECT_EQ(report.time_field, "time");
  EXPECT_EQ(report.frames_total, 6u);
  EXPECT_EQ(report.frames_outside_poses, 2u);
  EXPECT_EQ(report.frames_without_pose, 2u);
  ASSERT_EQ(d.frames.frames.size(), 4u);
  EXPECT_NEAR(d.frames.frames.front().t_end_s, t0 + 0.45, 1e-6);
  EXPECT_EQ(d.world_origin_m, utm);
  ASSERT_EQ(d.fiducials.size(), 1u);
  EXPECT_TRUE(d.fiducials[0].p_world.isApprox(Vec3(1, 2, -3), 1e-9));
  EXPECT_NEAR(d.poses.T_world_ins(t0 + 1.05).translation().x(), 5.25, 1e-6);  // 1.7e9 s in a double: 0.24 us steps
  ASSERT_TRUE(d.T_ins_lidar_init);
  EXPECT_TRUE(d.T_ins_lidar_init->isApprox(make_transform(Vec3(1, 0, 2), Vec3(0, 0, 90)), 1e-12));
  // Lazy loads from several threads at once; relative times get the frame time.
  std::vector<Sweep> loaded(d.frames.frames.size());
  std::vector<std::thread> threads;
  for (std::size_t i = 0; i < loaded.size(); ++i) threads.emplace_back([&, i] { loaded[i] = d.frames.load(i); });
  for (auto& t : threads) t.join();
  for (std::size_t i = 0; i < loaded.size(); ++i) {
    EXPECT_EQ(loaded[i].size(), 200u);
    EXPECT_DOUBLE_EQ(loaded[i].t_end_s, d.frames.frames[i].t_end_s);
  }
  fs::remove_all(dir);
}

TEST(Dataset, FrameTimesFromPcdWhenNamesAreNotTimes) {
  const fs::path dir = temp_dir("seq");
  std::vector<std::string> names;
  std::vector<Iso3> poses;
  for (int k = 0; k < 4; ++k) {
    const std::string name = "frame" + std::to_string(k);
    // Written out of name order in time: frame3 is earliest.
    write_pcd(dir / "lidar" / (name + ".pcd"), synthetic_sweep(100, 50.0 - k, k), PcdEncoding::kBinary);
    names.push_back(name);
    Iso3 T = Iso3::Identity();
    T.translation() = Vec3(k, 0, 0);
    poses.push_back(T);
  }
  names.push_back("orphan");  // a pose without a frame and without a time: dropped and counted
  poses.push_back(Iso3::Identity());
  write_opencalib_poses(dir / "poses.txt", names, poses);
  LoadReport report;
  const Dataset d = load_dataset({dir / "lidar", dir / "poses.txt"}, &report);
  EXPECT_EQ(report.frame_time_source, "latest point timestamp of each PCD");
  EXPECT_EQ(report.poses_unplaced, 1u);
  ASSERT_EQ(d.frames.frames.size(), 4u);
  EXPECT_EQ(d.frames.frames.front().name, "frame3");
  EXPECT_NEAR(d.frames.frames.front().t_end_s, 47.0, 1e-9);
  // Pose lines were in name order, i.e. reverse time order: sorted, with a warning.
  EXPECT_FALSE(report.warnings.empty());
  EXPECT_NEAR(d.poses.T_world_ins(48.0).translation().x() + d.world_origin_m.x(), 2.0, 1e-9);
  fs::remove_all(dir);
}

TEST(InfoCommand, RealSample) {
  if (!fs::exists(kSample)) GTEST_SKIP() << "shared sample data not found at " << kSample;
  const auto [rc, out] = run_command(std::string(INSALIGN_EXE) + " info --lidar-dir " + (kSample / "top_center_lidar").string() +
                             " --poses " + (kSample / "NovAtel-pose-lidar-time.txt").string());
  EXPECT_EQ(rc, 0) << out;
  EXPECT_NE(out.find("5 used of 5 .pcd files"), std::string::npos) << out;
  EXPECT_NE(out.find("points/frame   80"), std::string::npos) << out;
  EXPECT_NE(out.find("time field     timestamp"), std::string::npos) << out;
  EXPECT_NE(out.find("poses          1081"), std::string::npos) << out;
  EXPECT_NE(out.find("time span      108.06"), std::string::npos) << out;
  EXPECT_NE(out.find("max 15."), std::string::npos) << out;
}

TEST(InfoCommand, BadPathsAndFilesExitTwoNamingTheFile) {
  const fs::path dir = temp_dir("cli");
  auto [rc, out] = run_command(std::string(INSALIGN_EXE) + " info --lidar-dir " + (dir / "missing").string() + " --poses x");
  EXPECT_EQ(rc, 2) << out;
  EXPECT_NE(out.find((dir / "missing").string()), std::string::npos) << out;
  write_pcd(dir / "lidar" / "1.0.pcd", synthetic_sweep(100, 1.0, 1));
  std::ofstream(dir / "poses.txt") << "0 0 0 0 0 0 0 1\n1 0 0 0 oops 0 0 1\n";
  std::tie(rc, out) = run_command(std::string(INSALIGN_EXE) + " info --lidar-dir " + (dir / "lidar").string() + " --poses " +
                          (dir / "poses.txt").string());
  EXPECT_EQ(rc, 2) << out;
  EXPECT_NE(out.find((dir / "poses.txt").string() + ":line 2"), std::string::npos) << out;
  std::tie(rc, out) = run_command(std::string(INSALIGN_EXE) + " info --lidar-dir " + (dir / "lidar").string());
  EXPECT_EQ(rc, 2) << out;  // missing --poses is bad usage
  fs::remove_all(dir);
}

}  // namespace
}  // namespace insalign::io
