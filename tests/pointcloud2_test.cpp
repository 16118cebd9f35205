// sensor_msgs/PointCloud2 -> Sweep: every driver's time convention on synthetic clouds with known
// times, odd layouts (padding, count 3, height 2 with row padding, other datatypes), the errors,
// speed, and the clouds of tests/data/bags written by python3-rosbag and @mcap/core.
#include "recording/pointcloud2.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <random>

#include "cli_test_util.hpp"
#include "core/errors.hpp"
#include "recording/mcap.hpp"
#include "recording/message_definitions.hpp"
#include "recording/ros1_bag.hpp"

namespace insalign::io::bag {
namespace {

namespace fs = std::filesystem;
using F = PointField;
constexpr MessageEncoding kRos1 = MessageEncoding::kRos1;
constexpr MessageEncoding kCdr = MessageEncoding::kCdr;
constexpr double kT0 = 1700000000.0;

// A cloud filled field by field.
struct CloudBuilder {
  PointCloud2 cloud;

  CloudBuilder(std::vector<PointField> fields, std::uint32_t point_step, std::uint32_t width, std::uint32_t height = 1,
               std::uint32_t row_padding = 0) {
    cloud.header.stamp = Stamp::from_seconds(kT0);
    cloud.header.frame_id = "lidar";
    cloud.fields = std::move(fields);
    cloud.point_step = point_step;
    cloud.width = width, cloud.height = height;
    cloud.row_step = width * point_step + row_padding;
    cloud.data.assign(static_cast<std::size_t>(cloud.row_step) * height, 0xcd);  // padding is garbage
  }
  template <typename T>
  void set(std::size_t point, const std::string& field, T value, std::size_t element = 0) {
    const PointField* f = nullptr;
    for (const PointField& c : cloud.fields) f = c.name == field ? &c : f;
    ASSERT_NE(f, nullptr) << field;
    ASSERT_EQ(point_field_size(f->datatype), sizeof(T)) << field;
    const std::size_t row = point / cloud.width, col = point % cloud.width;
    std::memcpy(cloud.data.data() + row * cloud.row_step + col * cloud.point_step + f->offset + element * sizeof(T),
                &value, sizeof(T));
  }
  void xyz(std::size_t point, float x, float y, float z) {
    set(point, "x", x), set(point, "y", y), set(point, "z", z);
  }
  Sweep decode(MessageEncoding enc, PointCloudInfo* info) const {
    return decode_sweep(encode_message(cloud, enc), enc, "test cloud", info);
  }
};

std::vector<PointField> xyz_fields() { return {{"x", 0, F::kFloat32, 1}, {"y", 4, F::kFloat32, 1}, {"z", 8, F::kFloat32, 1}}; }

const auto& error_of = testing::input_error_of;

Sweep random_sweep(std::size_t n, double t_end_s, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> coord(-50 * 256, 50 * 256);  // multiples of 1/256: exact in float32
  std::uniform_real_distribution<float> dt(-0.1f, 0.0f);
  Sweep s;
  s.t_end_s = t_end_s;
  for (std::size_t i = 0; i < n; ++i) {
    s.p_lidar.emplace_back(coord(rng) / 256.f, coord(rng) / 256.f, coord(rng) / 256.f);
    s.intensity.push_back(static_cast<float>(i % 200));
    s.ring.push_back(static_cast<std::uint16_t>(i % 32));
    s.dt_s.push_back(i == n / 3 ? 0.0f : i == n / 2 ? -0.1f : dt(rng));  // the end is not the last point
  }
  return s;
}

// ------------------------------------------------------------------ every driver, both encodings

struct DriverCase {
  DriverLayout layout;
  PointTimeConvention convention;
  const char* name;
};

class DriverLayouts : public ::testing::TestWithParam<std::tuple<DriverCase, MessageEncoding>> {};

TEST_P(DriverLayouts, KnownTimesComeBack) {
  const auto [driver, enc] = GetParam();
  const Sweep in = random_sweep(1000, kT0 + 0.123456, 7);
  const PointCloud2 cloud = make_pointcloud2(in, driver.layout, "lidar");
  PointCloudInfo info;
  const Sweep out = decode_sweep(encode_message(cloud, enc), enc, "m", &info);
  EXPECT_EQ(info.time_convention, driver.convention) << info.time_description;
  ASSERT_EQ(out.size(), in.size());
  EXPECT_EQ(out.p_lidar, in.p_lidar);
  EXPECT_EQ(out.intensity, in.intensity);
  if (driver.layout == DriverLayout::kNoTime) {
    EXPECT_FALSE(out.has_time());
    EXPECT_NEAR(out.t_end_s, in.t_end_s, 1e-6);
    EXPECT_TRUE(out.ring.empty());
    return;
  }
  EXPECT_EQ(out.ring, in.ring);
  EXPECT_NEAR(out.t_end_s, in.t_end_s, 1e-6);  // the latest point, not the last one stored
  ASSERT_EQ(out.dt_s.size(), in.dt_s.size());
  double worst = 0.0;
  for (std::size_t i = 0; i < in.size(); ++i) worst = std::max(worst, std::abs(double(out.dt_s[i]) - in.dt_s[i]));
  EXPECT_LT(worst, 1e-6);
  EXPECT_EQ(*std::max_element(out.dt_s.begin(), out.dt_s.end()), 0.0f);
}

INSTANTIATE_TEST_SUITE_P(
    AllDrivers, DriverLayouts,
    ::testing::Combine(::testing::Values(DriverCase{DriverLayout::kHesai, PointTimeConvention::kAbsoluteSeconds, "Hesai"},
                                         DriverCase{DriverLayout::kVelodyne, PointTimeConvention::kRelativeSeconds, "Velodyne"},
                                         DriverCase{DriverLayout::kOuster, PointTimeConvention::kRelativeNanoseconds, "Ouster"},
                                         DriverCase{DriverLayout::kLivox, PointTimeConvention::kAbsoluteNanoseconds, "Livox"},
                                         DriverCase{DriverLayout::kNoTime, PointTimeConvention::kNone, "NoTime"}),
                       ::testing::Values(kRos1, kCdr)),
    [](const auto& info) {
      return std::string(std::get<0>(info.param).name) + (std::get<1>(info.param) == kRos1 ? "Ros1" : "Cdr");
    });

// ------------------------------------------------------------------- conventions, hand-built

TEST(PointCloud2, VelodyneNegativeTimesWhenTheStampIsTheSweepEnd) {
  CloudBuilder b(
      {{"x", 0, F::kFloat32, 1}, {"y", 4, F::kFloat32, 1}, {"z", 8, F::kFloat32, 1}, {"intensity", 12, F::kFloat32, 1},
       {"ring", 16, F::kUint16, 1}, {"time", 18, F::kFloat32, 1}},
      22, 3);
  const float times[] = {-0.1f, -0.05f, -0.002f};
  for (int i = 0; i < 3; ++i) b.xyz(i, 1.f + i, 2, 3), b.set(i, "time", times[i]), b.set<std::uint16_t>(i, "ring", 5);
  PointCloudInfo info;
  const Sweep s = b.decode(kRos1, &info);
  EXPECT_EQ(info.time_convention, PointTimeConvention::kRelativeSeconds);
  EXPECT_EQ(info.time_field, "time");
  EXPECT_NE(info.time_description.find("Velodyne"), std::string::npos) << info.time_description;
  EXPECT_NEAR(s.t_end_s, kT0 - 0.002, 1e-7);
  EXPECT_NEAR(s.dt_s[0], -0.098, 1e-7);
  EXPECT_EQ(s.dt_s[2], 0.0f);
  EXPECT_EQ(s.ring, (std::vector<std::uint16_t>{5, 5, 5}));
}

TEST(PointCloud2, OusterOrganizedCloudWithRowPadding) {
  // height 2, width 3, 48-byte points, 16 bytes of padding after each row; t in nanoseconds.
  CloudBuilder b({{"x", 0, F::kFloat32, 1}, {"y", 4, F::kFloat32, 1}, {"z", 8, F::kFloat32, 1},
                  {"intensity", 16, F::kFloat32, 1}, {"t", 20, F::kUint32, 1}, {"reflectivity", 24, F::kUint16, 1},
                  {"ring", 26, F::kUint16, 1}, {"range", 32, F::kUint32, 1}},
                 48, 3, 2, 16);
  const std::uint32_t t_ns[] = {0, 50'000'000, 99'000'000, 1'000'000, 51'000'000, 100'000'000};
  for (int i = 0; i < 6; ++i) {
    b.xyz(i, float(i), float(-i), 0.5f);
    b.set(i, "t", t_ns[i]);
    b.set<std::uint16_t>(i, "ring", static_cast<std::uint16_t>(i / 3));
    b.set(i, "intensity", 10.f * i);
  }
  b.cloud.header.stamp = {1700000000, 20'000'000};
  PointCloudInfo info;
  const Sweep s = b.decode(kCdr, &info);
  ASSERT_EQ(s.size(), 6u);
  EXPECT_EQ(info.time_convention, PointTimeConvention::kRelativeNanoseconds);
  EXPECT_NE(info.time_description.find("Ouster"), std::string::npos);
  EXPECT_NEAR(s.t_end_s, kT0 + 0.12, 1e-7);  // the last point of row 1 is the latest
  EXPECT_NEAR(s.dt_s[2], -0.001, 1e-7);
  EXPECT_NEAR(s.dt_s[3], -0.099, 1e-7);
  EXPECT_EQ(s.p_lidar[4], Vec3f(4, -4, 0.5f));  // row 1 read past the row padding
  EXPECT_EQ(s.ring[4], 1);
  EXPECT_EQ(s.intensity[5], 50.f);
}

TEST(PointCloud2, OtherTimeConventionsByNameTypeAndValue) {
  struct Case {
    const char* name;
    std::uint8_t datatype;
    std::array<double, 3> values;  // written in the field's type
    PointTimeConvention convention;
    double t_end_s;
  };
  const double abs_s = kT0 + 0.25;
  const std::vector<Case> cases = {
      {"timestamp", F::kFloat64, {abs_s - 0.1, abs_s, abs_s - 0.05}, PointTimeConvention::kAbsoluteSeconds, abs_s},
      {"timestamp", F::kFloat64, {abs_s * 1e9 - 1e8, abs_s * 1e9, abs_s * 1e9 - 5e7},
       PointTimeConvention::kAbsoluteNanoseconds, abs_s},
      // relative float64 seconds named timestamp, and float t as seconds
      {"timestamp", F::kFloat64, {0.0, 0.1, 0.05}, PointTimeConvention::kRelativeSeconds, kT0 + 0.1},
      {"t", F::kFloat32, {0.0, 0.1, 0.05}, PointTimeConvention::kRelativeSeconds, kT0 + 0.1},
      // Livox CustomMsg converted: offset_time uint32 ns after the stamp
      {"offset_time", F::kUint32, {0, 1e8, 5e7}, PointTimeConvention::kRelativeNanoseconds, kT0 + 0.1},
      // an absolute clock of the LiDAR's own (seconds since power-on), far from the stamp
      {"timestamp", F::kFloat64, {5000.0, 5000.1, 5000.05}, PointTimeConvention::kAbsoluteSeconds, 5000.1},
  };
  for (const Case& c : cases) {
    const PointField field{c.name, 12, c.datatype, 1};
    CloudBuilder b({xyz_fields()[0], xyz_fields()[1], xyz_fields()[2], field}, 24, 3);
    for (int i = 0; i < 3; ++i) {
      b.xyz(i, 1, 2, 3);
      switch (c.datatype) {
        case F::kFloat64: b.set(i, c.name, c.values[i]); break;
        case F::kFloat32: b.set(i, c.name, static_cast<float>(c.values[i])); break;
        default: b.set(i, c.name, static_cast<std::uint32_t>(c.values[i])); break;
      }
    }
    PointCloudInfo info;
    const Sweep s = b.decode(kRos1, &info);
    EXPECT_EQ(info.time_convention, c.convention) << info.time_description;
    EXPECT_NEAR(s.t_end_s, c.t_end_s, 1e-6) << info.time_description;
    ASSERT_EQ(s.dt_s.size(), 3u);
    EXPECT_NEAR(s.dt_s[0], -0.1, 1e-6) << info.time_description;
  }
}

TEST(PointCloud2, SimulationClocksThatStartAtZero) {
  // A bag recorded with sim time: header.stamp = 3 s. Relative times stay relative, absolute ones
  // (close to the stamp) stay absolute.
  for (const bool relative : {true, false}) {
    CloudBuilder b({xyz_fields()[0], xyz_fields()[1], xyz_fields()[2], {"time", 12, F::kFloat32, 1}}, 16, 2);
    b.cloud.header.stamp = {3, 0};
    b.xyz(0, 1, 2, 3), b.xyz(1, 4, 5, 6);
    b.set(0, "time", relative ? -0.1f : 2.9f), b.set(1, "time", relative ? 0.0f : 3.0f);
    PointCloudInfo info;
    const Sweep s = b.decode(kCdr, &info);
    EXPECT_EQ(info.time_convention, relative ? PointTimeConvention::kRelativeSeconds : PointTimeConvention::kAbsoluteSeconds);
    EXPECT_NEAR(s.t_end_s, 3.0, 1e-6);
    EXPECT_NEAR(s.dt_s[0], -0.1, 1e-6);
  }
}

TEST(PointCloud2, NoTimeFieldMeansHeaderStampAndNoDeskew) {
  CloudBuilder b(xyz_fields(), 12, 2);
  b.xyz(0, 1, 2, 3), b.xyz(1, 4, 5, 6);
  PointCloudInfo info;
  const Sweep s = b.decode(kCdr, &info);
  EXPECT_FALSE(s.has_time());
  EXPECT_DOUBLE_EQ(s.t_end_s, kT0);
  EXPECT_EQ(info.time_convention, PointTimeConvention::kNone);
  EXPECT_NE(info.time_description.find("header.stamp"), std::string::npos);
  EXPECT_TRUE(s.intensity.empty());
}

TEST(PointCloud2, Float32AbsoluteTimesAreIgnoredNotTrusted) {
  CloudBuilder b({xyz_fields()[0], xyz_fields()[1], xyz_fields()[2], {"timestamp", 12, F::kFloat32, 1}}, 16, 2);
  b.xyz(0, 1, 2, 3), b.xyz(1, 4, 5, 6);
  b.set(0, "timestamp", static_cast<float>(kT0)), b.set(1, "timestamp", static_cast<float>(kT0 + 0.1));
  PointCloudInfo info;
  const Sweep s = b.decode(kRos1, &info);
  EXPECT_EQ(info.time_convention, PointTimeConvention::kNone);
  EXPECT_NE(info.time_description.find("float32 cannot"), std::string::npos) << info.time_description;
  EXPECT_FALSE(s.has_time());
  EXPECT_DOUBLE_EQ(s.t_end_s, kT0);
}

// ----------------------------------------------------------------------------------- layouts

TEST(PointCloud2, PaddingAFieldOfCountThreeAndOtherDatatypes) {
  // x y z float64, normal float32[3] (skipped), reflectivity uint8 (intensity fallback), channel
  // uint8 (ring fallback), 8 bytes of padding at the end of each point.
  CloudBuilder b({{"x", 0, F::kFloat64, 1}, {"y", 8, F::kFloat64, 1}, {"z", 16, F::kFloat64, 1},
                  {"normal", 24, F::kFloat32, 3}, {"reflectivity", 36, F::kUint8, 1}, {"channel", 37, F::kUint8, 1}},
                 46, 2);
  for (int i = 0; i < 2; ++i) {
    b.set(i, "x", 1.5 + i), b.set(i, "y", -2.25), b.set(i, "z", 0.125);
    for (std::size_t k = 0; k < 3; ++k) b.set(i, "normal", 9.f, k);
    b.set<std::uint8_t>(i, "reflectivity", static_cast<std::uint8_t>(200 + i));
    b.set<std::uint8_t>(i, "channel", static_cast<std::uint8_t>(7 + i));
  }
  PointCloudInfo info;
  const Sweep s = b.decode(kCdr, &info);
  ASSERT_EQ(s.size(), 2u);
  EXPECT_EQ(s.p_lidar[1], Vec3f(2.5f, -2.25f, 0.125f));
  EXPECT_EQ(s.intensity, (std::vector<float>{200.f, 201.f}));
  EXPECT_EQ(s.ring, (std::vector<std::uint16_t>{7, 8}));
  EXPECT_EQ(info.intensity_field, "reflectivity");
  EXPECT_EQ(info.ring_field, "channel");
  EXPECT_NE(std::find(info.fields.begin(), info.fields.end(), "normal float32[3]"), info.fields.end());

  // int16 coordinates and a Livox `line` ring.
  CloudBuilder c({{"x", 0, F::kInt16, 1}, {"y", 2, F::kInt16, 1}, {"z", 4, F::kInt16, 1}, {"line", 6, F::kUint8, 1},
                  {"intensity", 7, F::kUint8, 1}},
                 8, 1);
  c.set<std::int16_t>(0, "x", -3), c.set<std::int16_t>(0, "y", 4), c.set<std::int16_t>(0, "z", 5);
  c.set<std::uint8_t>(0, "line", 3), c.set<std::uint8_t>(0, "intensity", 99);
  const Sweep t = c.decode(kRos1, nullptr);
  EXPECT_EQ(t.p_lidar[0], Vec3f(-3, 4, 5));
  EXPECT_EQ(t.ring[0], 3);
  EXPECT_EQ(t.intensity[0], 99.f);
}

TEST(PointCloud2, NonFiniteAndOutOfSweepPointsAreDroppedAndCounted) {
  CloudBuilder b({xyz_fields()[0], xyz_fields()[1], xyz_fields()[2], {"timestamp", 16, F::kFloat64, 1},
                  {"intensity", 12, F::kFloat32, 1}},
                 24, 5);
  const double ts[] = {kT0, kT0 + 0.05, 0.0, kT0 + 0.1, kT0 + 0.02};  // a zero time on an invalid return
  for (int i = 0; i < 5; ++i) b.xyz(i, float(i), 0, 0), b.set(i, "timestamp", ts[i]), b.set(i, "intensity", float(i));
  b.set(1, "y", std::numeric_limits<float>::quiet_NaN());
  b.set(4, "timestamp", std::numeric_limits<double>::infinity());
  PointCloudInfo info;
  const Sweep s = b.decode(kRos1, &info);
  EXPECT_EQ(info.points, 5u);
  EXPECT_EQ(info.dropped_nonfinite, 2u);
  EXPECT_EQ(info.dropped_time_outside, 1u);
  ASSERT_EQ(s.size(), 2u);
  EXPECT_EQ(s.intensity, (std::vector<float>{0.f, 3.f}));
  EXPECT_NEAR(s.t_end_s, kT0 + 0.1, 1e-6);
  EXPECT_NEAR(s.dt_s[0], -0.1, 1e-6);
}

TEST(PointCloud2, DoublesBeyondFloatRangeAreInfiniteSoThePointIsDropped) {
  // A float64 coordinate of 1e300 must not go through an (undefined) narrowing cast.
  CloudBuilder b({{"x", 0, F::kFloat64, 1}, {"y", 8, F::kFloat64, 1}, {"z", 16, F::kFloat64, 1},
                  {"intensity", 24, F::kFloat64, 1}},
                 32, 2);
  b.set(0, "x", 1e300), b.set(0, "y", 0.0), b.set(0, "z", 0.0), b.set(0, "intensity", 1.0);
  b.set(1, "x", 1.0), b.set(1, "y", 2.0), b.set(1, "z", 3.0), b.set(1, "intensity", -1e300);
  PointCloudInfo info;
  const Sweep s = b.decode(kRos1, &info);
  EXPECT_EQ(info.dropped_nonfinite, 1u);
  ASSERT_EQ(s.size(), 1u);
  EXPECT_EQ(s.intensity[0], -std::numeric_limits<float>::infinity());
}

TEST(PointCloud2, ErrorsNameWhatIsWrong) {
  CloudBuilder ok(xyz_fields(), 12, 2);
  ok.cloud.is_bigendian = true;
  EXPECT_NE(error_of([&] { ok.decode(kRos1, nullptr); }).find("big-endian point clouds are not supported"),
            std::string::npos);

  CloudBuilder no_z({xyz_fields()[0], xyz_fields()[1], {"intensity", 8, F::kFloat32, 1}}, 12, 1);
  const std::string e = error_of([&] { no_z.decode(kCdr, nullptr); });
  EXPECT_NE(e.find("no 'z' field; the cloud has: x, y, intensity"), std::string::npos) << e;
  EXPECT_NE(e.find("test cloud"), std::string::npos) << e;

  CloudBuilder short_data(xyz_fields(), 12, 4);
  short_data.cloud.data.resize(40);
  EXPECT_NE(error_of([&] { short_data.decode(kRos1, nullptr); }).find("data has 40 bytes"), std::string::npos);

  CloudBuilder outside({xyz_fields()[0], xyz_fields()[1], {"z", 10, F::kFloat32, 1}}, 12, 1);
  EXPECT_NE(error_of([&] { outside.decode(kRos1, nullptr); }).find("does not fit in point_step 12"), std::string::npos);

  CloudBuilder bad_type({xyz_fields()[0], xyz_fields()[1], {"z", 8, 9, 1}}, 12, 1);
  EXPECT_NE(error_of([&] { bad_type.decode(kRos1, nullptr); }).find("datatype 9"), std::string::npos);

  CloudBuilder zero_step(xyz_fields(), 12, 1);
  zero_step.cloud.point_step = 0;
  EXPECT_NE(error_of([&] { zero_step.decode(kRos1, nullptr); }).find("point_step is 0"), std::string::npos);

  CloudBuilder rows(xyz_fields(), 12, 2, 2);
  rows.cloud.row_step = 20;
  EXPECT_NE(error_of([&] { rows.decode(kRos1, nullptr); }).find("row_step 20 is less than"), std::string::npos);

  // An empty cloud is not an error, nor slow (found by fuzzing: width 0, height 4e9).
  CloudBuilder empty(xyz_fields(), 12, 0);
  EXPECT_EQ(empty.decode(kCdr, nullptr).size(), 0u);
  empty.cloud.height = 4'000'000'000u;
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(empty.decode(kRos1, nullptr).size(), 0u);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 0.1);
}

// --------------------------------------------------------------------------------------- speed

TEST(PointCloud2, DecodesA120kPointCloudInWellUnder5Ms) {
  const Sweep in = random_sweep(120'000, kT0, 3);
  for (const DriverLayout layout : {DriverLayout::kOuster, DriverLayout::kHesai, DriverLayout::kVelodyne}) {
    const std::vector<std::uint8_t> bytes = encode_message(make_pointcloud2(in, layout, "lidar"), kCdr);
    double best_ms = 1e9;
    for (int run = 0; run < 15; ++run) {
      const auto t0 = std::chrono::steady_clock::now();
      const Sweep s = decode_sweep(bytes, kCdr, "m");
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      best_ms = std::min(best_ms, ms);
      ASSERT_EQ(s.size(), in.size());
    }
    std::printf("120k points, layout %d (%zu bytes): best %.2f ms\n", static_cast<int>(layout), bytes.size(), best_ms);
    EXPECT_LT(best_ms, 5.0);
  }
}

// ------------------------------------------------------------ clouds written by other writers

const fs::path kFixtures = fs::path(INSALIGN_TEST_DATA_DIR) / "bags";

struct SweepFacts {
  std::size_t points;
  Vec3f first;
  double t_end_s;
  PointTimeConvention convention;
};

// The first sweep of each layout as tests/data/bags/README.md lists it.
const std::map<std::string, SweepFacts> kFirstSweeps = {
    {"/hesai/pandar", {800, {20.95703125f, 6.48046875f, -5.87890625f}, 1700000000.098, PointTimeConvention::kAbsoluteSeconds}},
    {"/velodyne_points", {800, {4.0f, 1.23828125f, -1.12109375f}, 1700000000.108, PointTimeConvention::kRelativeSeconds}},
    {"/ouster/points",
     {768, {14.73046875f, 4.5546875f, -4.1328125f}, 1700000000.117916651, PointTimeConvention::kRelativeNanoseconds}},
    {"/livox/lidar",
     {600, {26.98046875f, 5.08984375f, 2.69140625f}, 1700000000.129832934, PointTimeConvention::kAbsoluteNanoseconds}},
    {"/points_no_time", {500, {9.03125f, -1.55078125f, 0.9609375f}, 1700000000.140, PointTimeConvention::kNone}},
};

void check_first_sweeps(const BagReader& bag, std::size_t expected_topics) {
  std::size_t seen = 0;
  for (std::uint32_t i = 0; i < bag.topics().size(); ++i) {
    const Topic& topic = bag.topics()[i];
    const auto facts = kFirstSweeps.find(topic.name);
    if (facts == kFirstSweeps.end()) continue;
    ++seen;
    EXPECT_TRUE(check_definition(topic, bag.path().string()).checked) << topic.name;
    const auto refs = bag.messages(i);
    ASSERT_EQ(refs.size(), 3u) << topic.name;
    PointCloudInfo info;
    const Sweep s = decode_sweep(bag.read(refs[0]), topic.encoding, topic.name, &info);
    EXPECT_EQ(s.size(), facts->second.points) << topic.name;
    EXPECT_EQ(s.p_lidar[0], facts->second.first) << topic.name;
    EXPECT_NEAR(s.t_end_s, facts->second.t_end_s, 1e-6) << topic.name;
    EXPECT_EQ(info.time_convention, facts->second.convention) << topic.name << ": " << info.time_description;
    if (s.has_time()) {
      EXPECT_EQ(*std::max_element(s.dt_s.begin(), s.dt_s.end()), 0.0f);
    }
  }
  EXPECT_EQ(seen, expected_topics);
}

TEST(PointCloud2Fixtures, Ros1BagsWrittenByPythonRosbag) {
  if (!fs::exists(kFixtures / "ros1_hesai_inspva.bag")) GTEST_SKIP() << "fixtures not found at " << kFixtures;
  check_first_sweeps(*open_ros1_bag(kFixtures / "ros1_hesai_inspva.bag"), 1);
  check_first_sweeps(*open_ros1_bag(kFixtures / "ros1_velodyne_navsat_bz2.bag"), 2);
  check_first_sweeps(*open_ros1_bag(kFixtures / "ros1_ouster_livox_tf_lz4.bag"), 2);
}

TEST(PointCloud2Fixtures, McapWrittenByFoxgloveCdr) {
  if (!fs::exists(kFixtures / "mcap_hesai_ouster_zstd.mcap")) GTEST_SKIP() << "fixtures not found at " << kFixtures;
  check_first_sweeps(*open_mcap(kFixtures / "mcap_hesai_ouster_zstd.mcap"), 2);
  check_first_sweeps(*open_mcap(kFixtures / "mcap_hesai_ouster_lz4.mcap"), 2);  // Ouster legacy: uint8 ring
}

}  // namespace
}  // namespace insalign::io::bag
