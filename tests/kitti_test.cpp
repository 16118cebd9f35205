// KITTI raw: oxts records and folders, velodyne sweeps with per-point time from the azimuth, the
// calibration file, a whole drive read back, bad input.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <array>
#include <cstdio>
#include <functional>

#include "core/errors.hpp"
#include "ins_log_test_util.hpp"
#include "files/formats.hpp"
#include "inslog/gps_time.hpp"
#include "inslog/ins_log.hpp"
#include "inslog/ins_log_writer.hpp"
#include "inslog/kitti.hpp"
#include "sim/simulate.hpp"

namespace insalign::io {
namespace {

// A record laid out like those of KITTI's 2011_09_26 drives (30 values; navstat 4, posmode 4).
const std::string kOxtsLine =
    "49.015003823272 8.4342971002335 116.43032836914 0.035752 0.00903 -2.6087069803847 -4.2976047060049 "
    "7.4084850217572 8.5642763419345 -0.00082016797399 0.20212478923331 -0.3012934833383 0.26014718374551 "
    "9.8098466657847 -0.13478437936707 0.5186012451007 9.8095012470745 0.0034052036053513 0.0053564669049815 "
    "-0.0048716463404524 0.0044924054924891 0.0056616099536437 -0.0040926099055543 0.41641730017593 "
    "0.25190600007803 4 10 4 4 0";

Mat3 flu_from_axes(double heading_cw_deg, double pitch_up_deg, double roll_right_down_deg) {
  const auto a = test::vehicle_axes(heading_cw_deg, pitch_up_deg, roll_right_down_deg);
  Mat3 R;
  R.col(0) = a.forward, R.col(1) = -a.right, R.col(2) = a.up;
  return R;
}

TEST(Kitti, TimestampsAreReadAsUtc) {
  const auto t = parse_kitti_time("2011-09-26 13:02:25.964389445");
  ASSERT_TRUE(t);
  EXPECT_NEAR(*t, 1317042145.964389445, 1e-6);
  EXPECT_EQ(parse_kitti_time("2011-09-26 13:02:25"), 1317042145.0);
  EXPECT_FALSE(parse_kitti_time("2011-09-26T13:02:25.9"));
  EXPECT_FALSE(parse_kitti_time("2011-13-26 13:02:25.9"));
  EXPECT_FALSE(parse_kitti_time("1317042145.96"));
}

TEST(Kitti, OxtsRecordConventions) {
  const InsRecord r = parse_kitti_oxts_record(kOxtsLine, 5.0, "0000000000.txt", "line 1");
  EXPECT_DOUBLE_EQ(r.lat_deg, 49.015003823272);
  EXPECT_DOUBLE_EQ(r.lon_deg, 8.4342971002335);
  EXPECT_DOUBLE_EQ(r.height_m, 116.43032836914);
  // yaw -2.6087 rad counter-clockwise from east; pitch positive = front down; roll positive = left up.
  const double yaw = -2.6087069803847 * 180 / M_PI, pitch = 0.00903 * 180 / M_PI, roll = 0.035752 * 180 / M_PI;
  EXPECT_LT(test::angle_deg(r.R_world_ins, flu_from_axes(90.0 - yaw, -pitch, roll)), 1e-9);
  EXPECT_EQ(r.solution, GnssSolution::kDifferential);  // posmode 4
  EXPECT_NEAR(r.position_stddev_m.x(), 0.41641730017593, 1e-12);
}

TEST(Kitti, GpsModesAndNavigationStatus) {
  EXPECT_EQ(oxts_gps_mode_solution(6), GnssSolution::kRtkFixed);
  EXPECT_EQ(oxts_gps_mode_solution(5), GnssSolution::kRtkFloat);
  EXPECT_EQ(oxts_gps_mode_solution(4), GnssSolution::kDifferential);
  EXPECT_EQ(oxts_gps_mode_solution(3), GnssSolution::kSingle);
  EXPECT_EQ(oxts_gps_mode_solution(0), GnssSolution::kInsOnly);
  EXPECT_EQ(oxts_gps_mode_solution(16), GnssSolution::kRtkFixed);  // RTK integer, post-processed
  EXPECT_EQ(oxts_gps_mode_solution(99), GnssSolution::kUnknown);
  std::string not_locked = kOxtsLine;
  not_locked.replace(not_locked.size() - 10, 1, "3");  // navstat 3: still locking
  EXPECT_EQ(parse_kitti_oxts_record(not_locked, 0, "f", "line 1").solution, GnssSolution::kInvalid);
}

void write_oxts_folder(const std::filesystem::path& dir, const std::vector<std::string>& stamps,
                       const std::vector<std::string>& lines) {
  std::string t;
  for (const auto& s : stamps) t += s + "\n";
  test::write_text(dir / "timestamps.txt", t);
  for (std::size_t i = 0; i < lines.size(); ++i) test::write_text(dir / "data" / fmt::format("{:010}.txt", i), lines[i] + "\n");
  test::write_text(dir / "dataformat.txt", "lat:   latitude of the oxts-unit (deg)\n");
}

TEST(Kitti, OxtsFolderIsDetectedAndRead) {
  const auto dir = test::scratch_dir("oxts") / "2011_09_26_drive_0001_sync";
  write_oxts_folder(dir / "oxts", {"2011-09-26 13:02:25.964389445", "2011-09-26 13:02:26.074347734"}, {kOxtsLine, kOxtsLine});
  EXPECT_EQ(detect_ins_log(dir / "oxts"), InsLogFormat::kKittiOxts);
  EXPECT_EQ(detect_ins_log(dir), InsLogFormat::kKittiOxts);  // the drive folder holding it
  const InsTrack t = read_ins_log(dir, InsLogFormat::kKittiOxts);
  ASSERT_EQ(t.records.size(), 2u);
  EXPECT_NEAR(t.records[1].t_s - t.records[0].t_s, 0.109958289, 1e-6);
  EXPECT_NE(t.body_frame.find("x forward, y left, z up"), std::string::npos);
  EXPECT_NE(t.time_base.find("UTC"), std::string::npos);
}

void expect_error(const std::function<void()>& f, const std::string& location, const std::string& words) {
  try {
    f();
    FAIL() << "no error for " << words;
  } catch (const InputError& e) {
    EXPECT_EQ(e.location(), location) << e.what();
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
  }
}

TEST(Kitti, BadOxtsInputNamesTheFileAndLine) {
  const auto dir = test::scratch_dir("oxts-bad");
  std::string lat91 = kOxtsLine;
  lat91.replace(0, 2, "91");
  expect_error([&] { parse_kitti_oxts_record(lat91, 0, "a.txt", "line 1"); }, "line 1", "latitude");
  std::string nan_roll = kOxtsLine;
  nan_roll.replace(nan_roll.find("0.035752"), 8, "nan");
  expect_error([&] { parse_kitti_oxts_record(nan_roll, 0, "a.txt", "line 1"); }, "line 1", "value 4");
  expect_error([&] { parse_kitti_oxts_record(kOxtsLine.substr(0, 200), 0, "a.txt", "line 1"); }, "line 1", "30");
  write_oxts_folder(dir / "back", {"2011-09-26 13:02:25.9", "2011-09-26 13:02:25.8"}, {kOxtsLine, kOxtsLine});
  expect_error([&] { read_kitti_oxts(dir / "back"); }, "line 2", "backwards");
  write_oxts_folder(dir / "same", {"2011-09-26 13:02:25.9", "2011-09-26 13:02:25.9"}, {kOxtsLine, kOxtsLine});
  expect_error([&] { read_kitti_oxts(dir / "same"); }, "line 2", "repeated");
  write_oxts_folder(dir / "stamp", {"2011-09-26 13:02:25.9", "yesterday"}, {kOxtsLine, kOxtsLine});
  expect_error([&] { read_kitti_oxts(dir / "stamp"); }, "line 2", "not a time");
}

std::string velodyne_bytes(const std::vector<std::array<float, 4>>& points) {
  const auto path = test::scratch_dir("velo-bytes") / "p.bin";
  std::FILE* f = std::fopen(path.c_str(), "wb");
  for (const auto& p : points) std::fwrite(p.data(), sizeof(float), 4, f);
  std::fclose(f);
  return test::read_text(path);
}

TEST(Kitti, VelodynePointTimeFromAzimuthClockwiseFromBehind) {
  const std::string bytes = velodyne_bytes({{-10.0f, 0.001f, 0.5f, 0.3f},   // behind, just left: sweep start
                                            {0.0f, 10.0f, 0.0f, 0.1f},      // left: a quarter
                                            {10.0f, 0.0f, -1.0f, 0.2f},     // ahead: mid sweep (cameras)
                                            {0.0f, -10.0f, 0.0f, 0.0f},     // right: three quarters
                                            {-10.0f, -0.001f, 0.0f, 0.9f}}); // behind, just right: the end
  const Sweep s = parse_kitti_velodyne(bytes, "0000000007", "7.bin", 100.0, 100.1);
  ASSERT_EQ(s.size(), 5u);
  EXPECT_EQ(s.name, "0000000007");
  EXPECT_DOUBLE_EQ(s.t_end_s, 100.1);
  const double expected_dt[] = {-0.1, -0.075, -0.05, -0.025, 0.0};
  for (int i = 0; i < 5; ++i) EXPECT_NEAR(s.dt_s[i], expected_dt[i], 2e-6) << i;
  EXPECT_FLOAT_EQ(s.intensity[4], 0.9f);
  EXPECT_FLOAT_EQ(s.p_lidar[2].z(), -1.0f);
  // Counter-clockwise (the readme's wording) mirrors left and right.
  const Sweep ccw = parse_kitti_velodyne(bytes, "7", "7.bin", 100.0, 100.1, VelodyneSpin::kCounterClockwise);
  EXPECT_NEAR(ccw.dt_s[1], -0.025, 2e-6);
  EXPECT_NEAR(ccw.dt_s[3], -0.075, 2e-6);
}

TEST(Kitti, VelodyneSizeNotAMultipleOf16AndNanPoints) {
  std::string bytes = velodyne_bytes({{1, 2, 3, 0}, {4, 5, 6, 0}});
  expect_error([&] { parse_kitti_velodyne(bytes + "abc", "x", "x.bin", 0, 0.1); }, "byte 32", "multiple of 16");
  const std::string with_nan = velodyne_bytes({{1, 2, 3, 0}, {std::nanf(""), 5, 6, 0}, {4, 5, 6, 0}});
  EXPECT_EQ(parse_kitti_velodyne(with_nan, "x", "x.bin", 0, 0.1).size(), 2u);
}

TEST(Kitti, CalibrationReadAndWrittenTheSameWay) {
  // KITTI's file holds T_velo_imu; the drive's initial guess is its inverse, T_ins_lidar.
  const std::string kitti_calib =
      "calib_time: 25-May-2012 16:47:16\n"
      "R: 9.999976e-01 7.553071e-04 -2.035826e-03 -7.854027e-04 9.998898e-01 -1.482298e-02 2.024406e-03 "
      "1.482454e-02 9.998881e-01\nT: -8.086759e-01 3.195559e-01 -7.997231e-01\n";
  const Iso3 T_ins_lidar = parse_kitti_imu_to_velo(kitti_calib, "calib_imu_to_velo.txt").T_parent_child;
  // KITTI prints 7 digits, so its R is orthonormal to about 1e-7 only: inverses agree to that.
  EXPECT_NEAR((T_ins_lidar.inverse().translation() - Vec3(-0.8086759, 0.3195559, -0.7997231)).norm(), 0.0, 1e-6);
  EXPECT_NEAR(T_ins_lidar.translation().x(), 0.81, 0.01);  // the LiDAR sits 0.81 m ahead of the IMU
  const Iso3 back = parse_kitti_imu_to_velo(format_kitti_imu_to_velo(T_ins_lidar), "x").T_parent_child;
  EXPECT_LT((back.matrix() - T_ins_lidar.matrix()).cwiseAbs().maxCoeff(), 1e-6);
  // An exact rotation goes through writer and reader unchanged.
  Iso3 exact = T_ins_lidar;
  exact.linear() = nearest_rotation(T_ins_lidar.linear());
  const Iso3 exact_back = parse_kitti_imu_to_velo(format_kitti_imu_to_velo(exact), "x").T_parent_child;
  EXPECT_LT((exact_back.matrix() - exact.matrix()).cwiseAbs().maxCoeff(), 1e-12);
}

// A sweep as a clockwise spinning sensor sees a ring of points around it.
Sweep ring_sweep(const std::string& name, double t_end_s, double period_s) {
  Sweep s;
  s.name = name;
  s.t_end_s = t_end_s;
  const int n = 720;
  for (int j = 0; j < n; ++j) {
    const double az = M_PI - (j + 0.5) * 2 * M_PI / n;  // clockwise from behind
    s.p_lidar.emplace_back(static_cast<float>(10 * std::cos(az)), static_cast<float>(10 * std::sin(az)), -1.5f);
    s.dt_s.push_back(static_cast<float>(-period_s + (j + 0.5) * period_s / n));
    s.intensity.push_back(static_cast<float>(j % 256));
  }
  return s;
}

TEST(Kitti, DriveWrittenAndReadBack) {
  const auto date_dir = test::scratch_dir("drive") / "2011_09_26";
  const auto drive = date_dir / "2011_09_26_drive_0099_sync";
  const auto poses = test::synthetic_drive(1317042145.0, 12.0, 100.0);
  std::vector<Sweep> sweeps;
  for (int k = 0; k < 10; ++k) sweeps.push_back(ring_sweep("s", 1317042146.0 + 0.1 * k, 0.1));
  InsLogWriteOptions options;
  options.origin = {49.011, 8.424, 160.0};
  const Iso3 T_ins_lidar = make_transform({0.81, -0.32, 0.80}, {0.8, -0.1, 0.05});
  write_kitti_drive(drive, sweeps, poses, {}, T_ins_lidar, options);

  const KittiDrive d = read_kitti_drive(drive);
  ASSERT_EQ(d.frames.size(), 10u);
  ASSERT_TRUE(d.T_ins_lidar_init);
  EXPECT_LT((d.T_ins_lidar_init->matrix() - T_ins_lidar.matrix()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_TRUE(d.warnings.empty());
  const test::PoseDiff pd = test::compare(to_world(d.ins, options.origin).poses, poses);
  EXPECT_LT(pd.max_m, 1e-3);
  EXPECT_LT(pd.max_deg, 1e-3);
  EXPECT_LT(pd.max_dt_s, 1e-6);

  const FrameSource source = kitti_frame_source(d);
  ASSERT_EQ(source.frames.size(), 10u);
  EXPECT_NEAR(source.frames[3].t_end_s, sweeps[3].t_end_s, 1e-6);
  const Sweep s = source.load(3);
  ASSERT_EQ(s.size(), sweeps[3].size());
  for (std::size_t i = 0; i < s.size(); i += 50) {
    EXPECT_NEAR(s.t_end_s + s.dt_s[i], sweeps[3].t_end_s + sweeps[3].dt_s[i], 2e-6) << i;  // point times reproduced
    EXPECT_EQ(s.p_lidar[i], sweeps[3].p_lidar[i]);
  }
  EXPECT_NEAR(d.frames[3].t_forward_s, sweeps[3].t_end_s - 0.05, 1e-6);
}

TEST(Kitti, DriveWithoutCalibrationOrSomeSweeps) {
  const auto drive = test::scratch_dir("drive2") / "d" / "x_sync";
  std::vector<Sweep> sweeps = {ring_sweep("a", 1317042146.0, 0.1), ring_sweep("b", 1317042146.1, 0.1)};
  InsLogWriteOptions options;
  options.origin = {49.0, 8.4, 100.0};
  write_kitti_drive(drive, sweeps, test::synthetic_drive(1317042145.0, 3.0, 100.0), {}, Iso3::Identity(), options);
  std::filesystem::remove(drive.parent_path() / "calib_imu_to_velo.txt");
  std::filesystem::remove(drive / "velodyne_points" / "data" / "0000000001.bin");
  const KittiDrive d = read_kitti_drive(drive.string() + "/");
  EXPECT_EQ(d.frames.size(), 1u);
  EXPECT_FALSE(d.T_ins_lidar_init);
  EXPECT_EQ(d.warnings.size(), 2u);
  expect_error([&] { read_kitti_drive(drive / "oxts"); }, "", "velodyne_points/ and oxts/");
}

TEST(Kitti, SimulatedSweepsWriteAndReadBackWithTheirPointTimes) {
  // The simulator spins clockwise from behind, as the HDL-64E: its point times survive the trip
  // through a .bin without times (derived from the azimuth on reading).
  sim::SimConfig c;
  c.lidar_model = "vlp16";
  c.azimuth_step_deg = 1.0;
  c.duration_s = 2.0;
  const sim::World world = sim::build_world(c);
  std::vector<Sweep> sweeps;
  for (std::size_t k = 0; k < 3; ++k) sweeps.push_back(sim::render_sweep(world, k));
  InsLogWriteOptions options;
  options.origin = {49.011, 8.424, 160.0};
  const auto drive = test::scratch_dir("sim-drive") / "2023_11_14" / "sim_sync";
  write_kitti_drive(drive, sweeps, sim::dense_reported_poses(world, 100.0), {}, world.T_ins_lidar_init, options);
  const KittiDrive d = read_kitti_drive(drive);
  ASSERT_EQ(d.frames.size(), 3u);
  const FrameSource source = kitti_frame_source(d);
  for (std::size_t k = 0; k < 3; ++k) {
    const Sweep s = source.load(k);
    ASSERT_EQ(s.size(), sweeps[k].size());
    double worst = 0.0;
    for (std::size_t i = 0; i < s.size(); ++i) {
      worst = std::max(worst, std::abs((s.t_end_s + s.dt_s[i]) - (sweeps[k].t_end_s + sweeps[k].dt_s[i])));
    }
    EXPECT_LT(worst, 1e-5) << k;  // float dt and float coordinates
  }
  EXPECT_LT((d.T_ins_lidar_init->matrix() - world.T_ins_lidar_init.matrix()).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(Kitti, WriterRefusesSweepsThatAreNotClockwiseSpins) {
  Sweep s = ring_sweep("ccw", 10.0, 0.1);
  for (auto& p : s.p_lidar) p.y() = -p.y();  // mirrored: a counter-clockwise spin
  InsLogWriteOptions options;
  options.origin = {49.0, 8.4, 100.0};
  EXPECT_THROW(write_kitti_drive(test::scratch_dir("ccw") / "d", {s}, test::synthetic_drive(9.0, 2.0), {}, Iso3::Identity(), options),
               std::invalid_argument);
}

}  // namespace
}  // namespace insalign::io
