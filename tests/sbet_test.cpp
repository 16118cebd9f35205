// POSPac SBET: records written here with fwrite from a plain struct of 17 doubles (the file's
// documented layout), read back; week inference; bad input; the writer read back.
#include <gtest/gtest.h>

#include <cstdio>

#include "core/errors.hpp"
#include "ins_log_test_util.hpp"
#include "inslog/gps_time.hpp"
#include "inslog/ins_log.hpp"
#include "inslog/ins_log_writer.hpp"
#include "inslog/sbet.hpp"

namespace insalign::io {
namespace {

// The SBET record as Applanix documents it; written with fwrite (little-endian host).
struct RawSbet {
  double time, lat, lon, alt, vx, vy, vz, roll, pitch, heading, wander, ax, ay, az, wx, wy, wz;
};

constexpr double kRad = M_PI / 180.0;
const double kHint = gps_to_unix(2290, 200000.0);  // LiDAR clock at week 2290, 200000 s

RawSbet raw_at(int i) {
  RawSbet r{};
  r.time = 200000.0 + 0.005 * i;  // 200 Hz
  r.lat = (37.5 + 1e-6 * i) * kRad;
  r.lon = -122.25 * kRad;
  r.alt = -20.0 + 0.001 * i;
  r.roll = 1.5 * kRad, r.pitch = -2.0 * kRad;
  r.heading = (120.0 + 0.1 * i) * kRad;  // platform heading
  r.wander = 30.0 * kRad;
  return r;
}

std::filesystem::path write_raw(const std::string& name, const std::vector<RawSbet>& records, std::size_t extra = 0) {
  const auto path = test::scratch_dir("sbet") / name;
  std::FILE* f = std::fopen(path.c_str(), "wb");
  std::fwrite(records.data(), sizeof(RawSbet), records.size(), f);
  for (std::size_t i = 0; i < extra; ++i) std::fputc(0, f);
  std::fclose(f);
  return path;
}

// R_enu_ins of the SBET body (x forward, y right, z down) from first principles.
Mat3 frd_rotation(double roll, double pitch, double true_heading) {
  const auto a = test::vehicle_axes(true_heading, pitch, roll);
  Mat3 R;
  R.col(0) = a.forward, R.col(1) = a.right, R.col(2) = -a.up;
  return R;
}

void expect_error(const std::filesystem::path& path, std::optional<double> hint, const std::string& location,
                  const std::string& words) {
  try {
    read_sbet(path, hint);
    FAIL() << "no error for " << words;
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), path.string());
    EXPECT_EQ(e.location(), location) << e.what();
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
  }
}

TEST(Sbet, ReadsRecordsWrittenAsAPlainStruct) {
  static_assert(sizeof(RawSbet) == 136);
  std::vector<RawSbet> raw;
  for (int i = 0; i < 400; ++i) raw.push_back(raw_at(i));
  const auto path = write_raw("sbet_mission.out", raw);
  EXPECT_EQ(detect_ins_log(path), InsLogFormat::kSbet);
  const InsTrack t = read_sbet(path, kHint + 1800.0);  // LiDAR starts half an hour into the log
  ASSERT_EQ(t.records.size(), 400u);
  for (int i = 0; i < 400; i += 37) {
    const InsRecord& r = t.records[i];
    EXPECT_NEAR(r.t_s, gps_to_unix(2290, 200000.0 + 0.005 * i), 1e-6);
    EXPECT_NEAR(r.lat_deg, 37.5 + 1e-6 * i, 1e-12);
    EXPECT_NEAR(r.lon_deg, -122.25, 1e-12);
    EXPECT_NEAR(r.height_m, -20.0 + 0.001 * i, 1e-12);
    // True heading = platform heading - wander angle.
    EXPECT_LT(test::angle_deg(r.R_world_ins, frd_rotation(1.5, -2.0, 120.0 + 0.1 * i - 30.0)), 1e-9);
    EXPECT_EQ(r.location, "byte " + std::to_string(136 * i));
  }
  EXPECT_NE(t.time_base.find("week 2290"), std::string::npos) << t.time_base;
  EXPECT_NE(t.time_base.find("inferred from the LiDAR clock"), std::string::npos);
  EXPECT_NE(t.body_frame.find("x forward, y right, z down"), std::string::npos);
  EXPECT_TRUE(t.geodetic);
}

TEST(Sbet, WeekIsTheOneNearestTheLidarClock) {
  const auto path = write_raw("week.out", {raw_at(0), raw_at(1)});
  EXPECT_NEAR(read_sbet(path, kHint - 2.5 * 86400).records[0].t_s, gps_to_unix(2290, 200000.0), 1e-6);
  EXPECT_NEAR(read_sbet(path, kHint + 3.0 * 86400).records[0].t_s, gps_to_unix(2290, 200000.0), 1e-6);
  EXPECT_NEAR(read_sbet(path, kHint + 7.0 * 86400).records[0].t_s, gps_to_unix(2291, 200000.0), 1e-6);
  EXPECT_TRUE(read_sbet(path, kHint + 3600.0).warnings.empty());
  EXPECT_EQ(read_sbet(path, kHint + 3.0 * 86400).warnings.size(), 1u);  // 3 days off: seconds of day?
  expect_error(path, std::nullopt, "", "LiDAR");
}

TEST(Sbet, SizeNotAMultipleOf136IsAnInputErrorAtTheCutRecord) {
  const auto path = write_raw("cut.out", {raw_at(0), raw_at(1), raw_at(2)}, 50);
  EXPECT_EQ(detect_ins_log(path), InsLogFormat::kSbet);  // plausible first records, wrong size
  expect_error(path, kHint, "byte 408", "not a multiple of 136");
  // A binary file named .sbet that is not an SBET at all is still taken as one, and the size named.
  const auto junk = test::scratch_dir("sbet-junk") / "x.sbet";
  test::write_text(junk, std::string("\x01\x02\x03\x00\x05", 5));
  EXPECT_EQ(detect_ins_log(junk), InsLogFormat::kSbet);
  expect_error(junk, kHint, "byte 0", "not a multiple of 136");
}

TEST(Sbet, OutOfRangeAndNonFiniteValuesNameTheByte) {
  RawSbet bad = raw_at(1);
  bad.lat = 91.0 * kRad;
  expect_error(write_raw("lat.out", {raw_at(0), bad}), kHint, "byte 136", "latitude");
  bad = raw_at(2);
  bad.roll = std::nan("");
  expect_error(write_raw("nan.out", {raw_at(0), raw_at(1), bad}), kHint, "byte 272", "not a finite number");
  bad = raw_at(0);
  bad.heading = 400.0;  // degrees written where radians belong
  expect_error(write_raw("deg.out", {raw_at(0), bad}), kHint, "byte 136", "radians");
}

TEST(Sbet, TimeThatDoesNotIncreaseIsAnInputError) {
  expect_error(write_raw("back.out", {raw_at(0), raw_at(2), raw_at(1)}), kHint, "byte 272", "time goes backwards");
  expect_error(write_raw("equal.out", {raw_at(0), raw_at(1), raw_at(1)}), kHint, "byte 272", "repeated time");
}

TEST(Sbet, TextIsNotAnSbet) {
  EXPECT_FALSE(looks_like_sbet(std::string(272, 'a')));
  EXPECT_FALSE(looks_like_sbet(std::string(272, '\0')));  // zeros: latitude and longitude 0 is no drive
  std::vector<RawSbet> raw = {raw_at(0), raw_at(1)};
  EXPECT_TRUE(looks_like_sbet(std::string(reinterpret_cast<const char*>(raw.data()), 272)));
}

TEST(Sbet, WriterReadsBackToThePoses) {
  const auto poses = test::synthetic_drive();
  InsLogWriteOptions options;
  options.origin = {-33.86, 151.2, 40.0};
  const auto path = test::scratch_dir("sbet-writer") / "sbet.out";
  write_sbet(path, poses, options);
  EXPECT_EQ(std::filesystem::file_size(path), 136 * poses.size());
  ASSERT_EQ(detect_ins_log(path), InsLogFormat::kSbet);
  InsLogOptions read_options;
  read_options.lidar_time_hint_unix_s = poses.front().t_s + 0.3;
  const InsTrack track = read_ins_log(path, InsLogFormat::kSbet, read_options);
  const test::PoseDiff d = test::compare(to_world(track, options.origin).poses, poses);
  EXPECT_LT(d.max_m, 1e-3);
  EXPECT_LT(d.max_deg, 1e-3);
  EXPECT_LT(d.max_dt_s, 1e-6);
  // The wander angle is in the file and honoured: the raw platform heading differs from the truth by it.
  const std::string bytes = test::read_text(path);
  const SbetRecord r0 = sbet_record_at(bytes, 0);
  EXPECT_NEAR(r0.wander_rad, 5.0 * kRad, 1e-15);
}

}  // namespace
}  // namespace insalign::io
