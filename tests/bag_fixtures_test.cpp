// Recordings that insalign did not write: tests/data/bags, made by ROS's own writers (python3-rosbag,
// @mcap/core with Foxglove's CDR serializer, sql.js) with the scripts in tests/fixtures/bags. Every
// expected value here is listed in tests/data/bags/README.md.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <regex>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "core/errors.hpp"
#include "recording/bag_reader.hpp"
#include "recording/message_definitions.hpp"
#include "recording/messages.hpp"
#include "recording/pointcloud2.hpp"

namespace insalign::io::bag {
namespace {

namespace fs = std::filesystem;

// The fixtures live beside this file, in the source tree (no data outside the repository).
const fs::path kDir = fs::path(INSALIGN_TEST_DATA_DIR) / "bags";

constexpr std::int64_t kT0Ns = 1'700'000'000'000'000'000;
constexpr double kXyzTol = 1e-6, kTimeTol = 1e-6, kDegTol = 1e-9, kMetreTol = 1e-6, kQuatTol = 1e-12;

struct TopicFact {
  std::string name, type;  ///< type as stored
  std::uint64_t count;
};

std::uint32_t topic_index(const BagReader& bag, const std::string& name) {
  const auto& topics = bag.topics();
  for (std::uint32_t i = 0; i < topics.size(); ++i) {
    if (topics[i].name == name) return i;
  }
  ADD_FAILURE() << bag.path() << ": no topic " << name;
  return 0;
}

/// The topics exactly (no more, no fewer), their types and counts, in the index too, and the
/// recorder's time range.
void expect_bag(const BagReader& bag, const std::vector<TopicFact>& facts, std::int64_t start_ns, std::int64_t end_ns) {
  SCOPED_TRACE(bag.path().string());
  std::map<std::string, const Topic*> by_name;
  for (const Topic& t : bag.topics()) by_name[t.name] = &t;
  EXPECT_EQ(by_name.size(), facts.size());
  for (const TopicFact& f : facts) {
    SCOPED_TRACE(f.name);
    ASSERT_TRUE(by_name.count(f.name));
    EXPECT_EQ(by_name[f.name]->type, f.type);
    EXPECT_EQ(by_name[f.name]->message_count, f.count);
    const auto refs = bag.messages(topic_index(bag, f.name));
    EXPECT_EQ(refs.size(), f.count);
    EXPECT_TRUE(std::is_sorted(refs.begin(), refs.end(),
                               [](const MessageRef& a, const MessageRef& b) { return a.log_time_ns < b.log_time_ns; }));
  }
  EXPECT_EQ(bag.start_time_ns(), start_ns);
  EXPECT_EQ(bag.end_time_ns(), end_ns);
}

std::vector<std::uint8_t> read_nth(const BagReader& bag, const std::string& topic, std::size_t n) {
  const auto refs = bag.messages(topic_index(bag, topic));
  EXPECT_LT(n, refs.size());
  return bag.read(refs.at(std::min(n, refs.size() - 1)));
}
std::vector<std::uint8_t> read_first(const BagReader& bag, const std::string& topic) { return read_nth(bag, topic, 0); }
std::vector<std::uint8_t> read_last(const BagReader& bag, const std::string& topic) {
  return read_nth(bag, topic, bag.messages(topic_index(bag, topic)).size() - 1);
}

const Topic& topic_of(const BagReader& bag, const std::string& name) { return bag.topics()[topic_index(bag, name)]; }

// ------------------------------------------------------------------------ the INS drive (README)

/// INS message i of the drive: header.stamp = T0 - 20 ms + i * 10 ms.
std::int64_t ins_stamp_ns(int i) { return kT0Ns + (i - 2) * 10'000'000LL; }

struct DriveSample {
  double lat_deg, lon_deg, h_ell_m, roll_deg, pitch_deg, azimuth_deg;
  Quaternion q_enu_base;  ///< Imu orientation, Odometry and odom->base_link rotation
  Vec3 p_odom_m;          ///< Odometry position
};
const DriveSample kFirst{48.13715328134778, 11.5761231923438, 520.249, 1.49, -0.755, 36.66989764584402,
                         {0.008662695686408279, 0.011722330794761426, 0.44864975137000507, 0.8935888009928367},
                         {9.94, 19.92, 0.499}};
const DriveSample kLast{48.13716585776175, 11.576137326327299, 520.2665, 1.665, -0.6675, 40.16989764584402,
                        {0.010723269388471096, 0.011403069027850288, 0.4211457009614962, 0.9068579161434379},
                        {10.99, 21.32, 0.5165}};
// The last of 46 samples (the split rosbag2 bag).
const DriveSample kLast46{48.13716945102289, 11.576141364608299, 520.2715, 0, 0, 0,
                          {0.011309832267808548, 0.011290732761556595, 0.41321445174998345, 0.910493505694984},
                          {0, 0, 0}};
constexpr double kUndulationM = 47.5;

void expect_quat(const Quaternion& q, const Quaternion& want) {
  EXPECT_NEAR(q.x, want.x, kQuatTol);
  EXPECT_NEAR(q.y, want.y, kQuatTol);
  EXPECT_NEAR(q.z, want.z, kQuatTol);
  EXPECT_NEAR(q.w, want.w, kQuatTol);
}
void expect_vec(const Vec3& v, const Vec3& want, double tol) {
  EXPECT_NEAR(v.x(), want.x(), tol);
  EXPECT_NEAR(v.y(), want.y(), tol);
  EXPECT_NEAR(v.z(), want.z(), tol);
}

void expect_attitude(const NovatelAttitude& a, const DriveSample& s) {
  EXPECT_NEAR(a.roll, s.roll_deg, kDegTol);
  EXPECT_NEAR(a.pitch, s.pitch_deg, kDegTol);
  EXPECT_NEAR(a.azimuth, s.azimuth_deg, kDegTol);
  EXPECT_DOUBLE_EQ(a.north_velocity, 4.0);
  EXPECT_DOUBLE_EQ(a.east_velocity, 3.0);
  EXPECT_DOUBLE_EQ(a.up_velocity, 0.05);
}

void expect_inspva(const std::vector<std::uint8_t>& bytes, MessageEncoding enc, int i, const DriveSample& s,
                   std::optional<Oem7Header::Layout> layout) {
  const Oem7Inspva m = decode_oem7_inspva(bytes, enc, "inspva", layout);
  EXPECT_EQ(m.header.stamp.nanoseconds(), ins_stamp_ns(i));
  EXPECT_EQ(m.header.frame_id, "novatel");
  EXPECT_EQ(m.nov_header.message_name, "INSPVA");
  EXPECT_EQ(m.nov_header.sequence_number, static_cast<std::uint32_t>(i));
  EXPECT_NEAR(m.latitude, s.lat_deg, kDegTol);
  EXPECT_NEAR(m.longitude, s.lon_deg, kDegTol);
  EXPECT_NEAR(m.height, s.h_ell_m, kMetreTol);
  expect_attitude(m.pva, s);
  EXPECT_EQ(m.status, 3u);  // INS_SOLUTION_GOOD
  const NovatelRecord r = to_ins_record(m);
  EXPECT_NEAR(r.record.t_s, static_cast<double>(ins_stamp_ns(i)) * 1e-9, kTimeTol);
  EXPECT_NEAR(r.record.height_m, s.h_ell_m, kMetreTol);
  EXPECT_TRUE(r.ins_status_good);
}

void expect_inspvax(const std::vector<std::uint8_t>& bytes, MessageEncoding enc, int i, const DriveSample& s,
                    std::optional<Oem7Header::Layout> layout, Oem7Header::Layout want_layout) {
  const Oem7Inspvax m = decode_oem7_inspvax(bytes, enc, "inspvax", layout);
  EXPECT_EQ(m.nov_header.layout, want_layout);
  EXPECT_EQ(m.header.stamp.nanoseconds(), ins_stamp_ns(i));
  EXPECT_EQ(m.nov_header.message_name, "INSPVAX");
  EXPECT_EQ(m.nov_header.sequence_number, static_cast<std::uint32_t>(i));
  EXPECT_EQ(m.ins_status, 3u);
  EXPECT_EQ(m.pos_type, 56u);  // INS_RTKFIXED
  EXPECT_NEAR(m.latitude, s.lat_deg, kDegTol);
  EXPECT_NEAR(m.longitude, s.lon_deg, kDegTol);
  EXPECT_NEAR(m.height, s.h_ell_m - kUndulationM, kMetreTol);  // mean sea level
  EXPECT_FLOAT_EQ(m.undulation, 47.5f);
  expect_attitude(m.pva, s);
  EXPECT_FLOAT_EQ(m.latitude_stdev, 0.02f);
  EXPECT_FLOAT_EQ(m.height_stdev, 0.03f);
  EXPECT_FLOAT_EQ(m.azimuth_stdev, 0.02f);
  EXPECT_EQ(m.ext_sol_status, 1u | 16777216u | 33554432u);
  const NovatelRecord r = to_ins_record(m);
  EXPECT_NEAR(r.record.height_m, s.h_ell_m, kMetreTol);  // ellipsoidal: + undulation
  EXPECT_NEAR(r.record.lat_deg, s.lat_deg, kDegTol);
  EXPECT_EQ(r.record.solution, GnssSolution::kRtkFixed);
  EXPECT_TRUE(r.ins_status_good);
}

void expect_navsatfix(const std::vector<std::uint8_t>& bytes, MessageEncoding enc, int i, const DriveSample& s) {
  const NavSatFix m = decode_navsatfix(bytes, enc, "navsatfix");
  EXPECT_EQ(m.header.stamp.nanoseconds(), ins_stamp_ns(i));
  EXPECT_EQ(m.header.frame_id, "gnss_link");
  EXPECT_EQ(m.status, NavSatFix::kGbasFix);
  EXPECT_EQ(m.service, 1u);
  EXPECT_NEAR(m.latitude, s.lat_deg, kDegTol);
  EXPECT_NEAR(m.longitude, s.lon_deg, kDegTol);
  EXPECT_NEAR(m.altitude, s.h_ell_m, kMetreTol);
  EXPECT_DOUBLE_EQ(m.position_covariance[8], 0.0009);
  EXPECT_EQ(m.position_covariance_type, NavSatFix::kDiagonalKnown);
  const InsRecord r = to_ins_record(m);
  EXPECT_NEAR(r.height_m, s.h_ell_m, kMetreTol);
  EXPECT_NEAR(r.position_stddev_m.z(), 0.03, 1e-12);
}

void expect_imu(const std::vector<std::uint8_t>& bytes, MessageEncoding enc, int i, const DriveSample& s) {
  const Imu m = decode_imu(bytes, enc, "imu");
  EXPECT_EQ(m.header.stamp.nanoseconds(), ins_stamp_ns(i));
  EXPECT_EQ(m.header.frame_id, "imu_link");
  expect_quat(m.orientation, s.q_enu_base);
  EXPECT_TRUE(m.has_orientation());
  EXPECT_DOUBLE_EQ(m.angular_velocity.z(), -0.17453292519943295);
  EXPECT_DOUBLE_EQ(m.linear_acceleration.z(), 9.80665);
}

void expect_odometry(const std::vector<std::uint8_t>& bytes, MessageEncoding enc, int i, const DriveSample& s) {
  const Odometry m = decode_odometry(bytes, enc, "odometry");
  EXPECT_EQ(m.header.stamp.nanoseconds(), ins_stamp_ns(i));
  EXPECT_EQ(m.header.frame_id, "odom");
  EXPECT_EQ(m.child_frame_id, "base_link");
  expect_vec(m.pose.pose.position, s.p_odom_m, kMetreTol);
  expect_quat(m.pose.pose.orientation, s.q_enu_base);
  EXPECT_DOUBLE_EQ(m.pose.covariance[0], 0.01);
  EXPECT_DOUBLE_EQ(m.pose.covariance[35], 0.01);
  EXPECT_DOUBLE_EQ(m.twist.linear.x(), 5.0);
  EXPECT_DOUBLE_EQ(m.twist.angular.z(), -0.17453292519943295);
  const InsRecord r = to_ins_record(m, "odometry");
  expect_vec(r.p_world_m, s.p_odom_m, kMetreTol);
  EXPECT_NEAR(r.t_s, static_cast<double>(ins_stamp_ns(i)) * 1e-9, kTimeTol);
}


// ---------------------------------------------------------------------------- the sweeps (README)

struct SweepFact {
  std::int64_t stamp_ns;
  std::size_t points;
  Vec3 first_xyz;
  float first_intensity;
  double first_t_s, t_end_s;
};
struct LayoutFact {
  PointTimeConvention convention;
  std::string time_field, ring_field;
  std::uint16_t last_ring;  ///< ring of the last point in storage order
  std::vector<SweepFact> sweeps;
};

const LayoutFact kHesai{PointTimeConvention::kAbsoluteSeconds, "timestamp", "ring", 15,
                        {{1'700'000'000'000'000'000, 800, {20.95703125, 6.48046875, -5.87890625}, 250, 1700000000.000, 1700000000.098},
                         {1'700'000'000'100'000'000, 800, {20.8984375, 6.6953125, -5.87890625}, 18, 1700000000.100, 1700000000.198},
                         {1'700'000'000'200'000'000, 800, {20.84375, 6.90625, -5.8828125}, 41, 1700000000.200, 1700000000.298}}};
// Velodyne and Velodyne-PCL: the same points in two layouts; the split rosbag2 bag has a 4th sweep.
const LayoutFact kVelodyne{PointTimeConvention::kRelativeSeconds, "time", "ring", 15,
                           {{1'700'000'000'110'000'000, 800, {4.0, 1.23828125, -1.12109375}, 174, 1700000000.010, 1700000000.108},
                            {1'700'000'000'210'000'000, 800, {4.0, 1.28125, -1.125}, 198, 1700000000.110, 1700000000.208},
                            {1'700'000'000'310'000'000, 800, {3.99609375, 1.32421875, -1.12890625}, 221, 1700000000.210, 1700000000.308},
                            {1'700'000'000'410'000'000, 800, {3.9921875, 1.3671875, -1.1328125}, 244, 1700000000.310, 1700000000.408}}};
const LayoutFact kOuster{PointTimeConvention::kRelativeNanoseconds, "t", "ring", 15,
                         {{1'700'000'000'020'000'000, 768, {14.73046875, 4.5546875, -4.1328125}, 99, 1700000000.020, 1700000000.117916651},
                          {1'700'000'000'120'000'000, 768, {14.6953125, 4.70703125, -4.1328125}, 122, 1700000000.120, 1700000000.217916651},
                          {1'700'000'000'220'000'000, 768, {14.65625, 4.85546875, -4.13671875}, 145, 1700000000.220, 1700000000.317916651}}};
const LayoutFact kLivox{PointTimeConvention::kAbsoluteNanoseconds, "timestamp", "line", 3,
                        {{1'700'000'000'030'000'000, 600, {26.98046875, 5.08984375, 2.69140625}, 23, 1700000000.030, 1700000000.129832934},
                         {1'700'000'000'130'000'000, 600, {26.8828125, -5.4140625, 3.1171875}, 47, 1700000000.130, 1700000000.229832934},
                         {1'700'000'000'230'000'000, 600, {22.84375, -15.09765625, 3.546875}, 70, 1700000000.230, 1700000000.329832934}}};
const LayoutFact kNoTime{PointTimeConvention::kNone, "", "", 0,
                         {{1'700'000'000'140'000'000, 500, {9.03125, -1.55078125, 0.9609375}, 203, 1700000000.140, 1700000000.140},
                          {1'700'000'000'240'000'000, 500, {7.78515625, -4.828125, 1.10546875}, 226, 1700000000.240, 1700000000.240},
                          {1'700'000'000'340'000'000, 500, {8.79296875, 2.54296875, 1.25}, 249, 1700000000.340, 1700000000.340}}};

/// Every cloud of `topic` through decode_sweep: the detected time convention, point count, the
/// first point (storage order) with its time, and t_end_s = the latest point time.
/// `missing`: points per cloud with NaN coordinates (dropped by the decoder).
void expect_sweeps(const BagReader& bag, const std::string& topic, const LayoutFact& layout, std::size_t n_sweeps,
                   const std::string& frame_id, std::size_t missing = 0) {
  const auto refs = bag.messages(topic_index(bag, topic));
  ASSERT_EQ(refs.size(), n_sweeps);
  const MessageEncoding enc = topic_of(bag, topic).encoding;
  for (std::size_t k = 0; k < n_sweeps; ++k) {
    SCOPED_TRACE(bag.path().filename().string() + " " + topic + " sweep " + std::to_string(k));
    const SweepFact& f = layout.sweeps.at(k);
    const std::vector<std::uint8_t> bytes = bag.read(refs[k]);
    PointCloudInfo info;
    const Sweep s = decode_sweep(bytes, enc, topic, &info);
    EXPECT_EQ(info.time_convention, layout.convention) << info.time_description;
    EXPECT_EQ(info.time_field, layout.time_field);
    EXPECT_EQ(info.ring_field, layout.ring_field);
    EXPECT_EQ(info.intensity_field, "intensity");
    EXPECT_EQ(info.frame_id, frame_id);
    EXPECT_NEAR(info.header_stamp_s, static_cast<double>(f.stamp_ns) * 1e-9, kTimeTol);
    EXPECT_EQ(info.points, f.points);
    EXPECT_EQ(info.dropped_nonfinite, missing);
    EXPECT_EQ(info.dropped_time_outside, 0u);
    const std::size_t n = f.points - missing;
    ASSERT_EQ(s.size(), n);
    EXPECT_NEAR(s.p_lidar[0].x(), f.first_xyz.x(), kXyzTol);
    EXPECT_NEAR(s.p_lidar[0].y(), f.first_xyz.y(), kXyzTol);
    EXPECT_NEAR(s.p_lidar[0].z(), f.first_xyz.z(), kXyzTol);
    ASSERT_EQ(s.intensity.size(), n);
    EXPECT_EQ(s.intensity[0], f.first_intensity);
    EXPECT_NEAR(s.t_end_s, f.t_end_s, kTimeTol);
    if (layout.convention == PointTimeConvention::kNone) {
      EXPECT_FALSE(s.has_time());
    } else {
      ASSERT_EQ(s.dt_s.size(), n);
      EXPECT_NEAR(s.t_end_s + s.dt_s[0], f.first_t_s, kTimeTol);
      EXPECT_EQ(*std::max_element(s.dt_s.begin(), s.dt_s.end()), 0.0f);  // t_end is a point's time
      EXPECT_NEAR(*std::min_element(s.dt_s.begin(), s.dt_s.end()), f.first_t_s - f.t_end_s, kTimeTol);
    }
    if (layout.ring_field.empty()) {
      EXPECT_TRUE(s.ring.empty());
    } else {
      ASSERT_EQ(s.ring.size(), n);
      EXPECT_EQ(s.ring.front(), 0);
      EXPECT_EQ(s.ring.back(), layout.last_ring);
    }
  }
}


/// /tf (map -> odom, odom -> base_link; first and last) and /tf_static (base_link -> gnss).
void expect_tf(const BagReader& bag, MessageEncoding enc) {
  const Quaternion q_map_odom{0.0, 0.0, 0.043619387365336, 0.9990482215818578};
  for (auto [n, sample] : {std::pair{0, kFirst}, std::pair{35, kLast}}) {
    const TFMessage tf = decode_tf_message(read_nth(bag, "/tf", n), enc, "tf");
    ASSERT_EQ(tf.transforms.size(), 2u);
    EXPECT_EQ(tf.transforms[0].header.frame_id, "map");
    EXPECT_EQ(tf.transforms[0].child_frame_id, "odom");
    EXPECT_EQ(tf.transforms[0].header.stamp.nanoseconds(), ins_stamp_ns(n));
    expect_vec(tf.transforms[0].translation, {100.0, 200.0, 0.0}, kMetreTol);
    expect_quat(tf.transforms[0].rotation, q_map_odom);
    EXPECT_EQ(tf.transforms[1].header.frame_id, "odom");
    EXPECT_EQ(tf.transforms[1].child_frame_id, "base_link");
    expect_vec(tf.transforms[1].translation, sample.p_odom_m, kMetreTol);
    expect_quat(tf.transforms[1].rotation, sample.q_enu_base);
  }
  const TFMessage st = decode_tf_message(read_first(bag, "/tf_static"), enc, "tf_static");
  ASSERT_EQ(st.transforms.size(), 1u);
  EXPECT_EQ(st.transforms[0].header.frame_id, "base_link");
  EXPECT_EQ(st.transforms[0].child_frame_id, "gnss");
  EXPECT_EQ(st.transforms[0].header.stamp.nanoseconds(), ins_stamp_ns(0));
  expect_vec(st.transforms[0].translation, {0.45, -0.1, 1.35}, kMetreTol);
  expect_quat(st.transforms[0].rotation, {0.0, 0.0, -0.7071067811865475, 0.7071067811865476});

}

// ------------------------------------------------------------------------------------ ROS 1

TEST(BagFixtures, Ros1HesaiInspvaUncompressed) {
  const auto bag = open_bag(kDir / "ros1_hesai_inspva.bag");
  expect_bag(*bag,
             {{"/hesai/pandar", "sensor_msgs/PointCloud2", 3},
              {"/novatel/oem7/inspva", "novatel_oem7_msgs/INSPVA", 36},
              {"/novatel/oem7/inspvax", "novatel_oem7_msgs/INSPVAX", 36}},
             1'699'999'999'982'000'000, 1'700'000'000'332'000'000);
  EXPECT_EQ(topic_of(*bag, "/hesai/pandar").md5sum, "1158d486dd51d683ce2f1be655c3c181");
  EXPECT_EQ(topic_of(*bag, "/novatel/oem7/inspva").md5sum, "29f9ba1f809b13b4f0eed8681b50004b");
  EXPECT_EQ(topic_of(*bag, "/novatel/oem7/inspvax").md5sum, "ed91b0a9b45cec79c5555245c5db0a4e");
  for (const Topic& t : bag->topics()) {
    EXPECT_EQ(t.encoding, MessageEncoding::kRos1);
    EXPECT_EQ(t.definition_encoding, "ros1msg");
    // insalign's md5 of the stored text equals genmsg's, which rosbag stored.
    EXPECT_EQ(ros1_md5sum(t.type, t.definition, t.name), t.md5sum) << t.name;
  }
  for (const char* name : {"/novatel/oem7/inspva", "/novatel/oem7/inspvax"}) {
    const DefinitionCheck check = check_definition(topic_of(*bag, name));
    EXPECT_TRUE(check.checked) << name;
    EXPECT_EQ(check.oem7_layout, Oem7Header::Layout::kBase) << name;
  }
  expect_sweeps(*bag, "/hesai/pandar", kHesai, 3, "hesai_lidar");
  const auto enc = MessageEncoding::kRos1;
  for (auto layout : {std::optional<Oem7Header::Layout>{}, std::optional{Oem7Header::Layout::kBase}}) {
    expect_inspva(read_first(*bag, "/novatel/oem7/inspva"), enc, 0, kFirst, layout);
    expect_inspva(read_last(*bag, "/novatel/oem7/inspva"), enc, 35, kLast, layout);
    expect_inspvax(read_first(*bag, "/novatel/oem7/inspvax"), enc, 0, kFirst, layout, Oem7Header::Layout::kBase);
    expect_inspvax(read_last(*bag, "/novatel/oem7/inspvax"), enc, 35, kLast, layout, Oem7Header::Layout::kBase);
  }
}

TEST(BagFixtures, Ros1VelodyneNavSatBz2) {
  const auto bag = open_bag(kDir / "ros1_velodyne_navsat_bz2.bag");
  expect_bag(*bag,
             {{"/velodyne_points", "sensor_msgs/PointCloud2", 3},
              {"/points_no_time", "sensor_msgs/PointCloud2", 3},
              {"/gps/fix", "sensor_msgs/NavSatFix", 36},
              {"/imu/data", "sensor_msgs/Imu", 36}},
             1'699'999'999'982'000'000, 1'700'000'000'344'800'000);
  expect_sweeps(*bag, "/velodyne_points", kVelodyne, 3, "velodyne");
  expect_sweeps(*bag, "/points_no_time", kNoTime, 3, "lidar");
  const auto enc = MessageEncoding::kRos1;
  expect_navsatfix(read_first(*bag, "/gps/fix"), enc, 0, kFirst);
  expect_navsatfix(read_last(*bag, "/gps/fix"), enc, 35, kLast);
  expect_imu(read_first(*bag, "/imu/data"), enc, 0, kFirst);
  expect_imu(read_last(*bag, "/imu/data"), enc, 35, kLast);
  for (const Topic& t : bag->topics()) EXPECT_TRUE(check_definition(t).checked) << t.name;
}

TEST(BagFixtures, Ros1OusterLivoxTfLz4) {
  const auto bag = open_bag(kDir / "ros1_ouster_livox_tf_lz4.bag");
  expect_bag(*bag,
             {{"/ouster/points", "sensor_msgs/PointCloud2", 3},
              {"/livox/lidar", "sensor_msgs/PointCloud2", 3},
              {"/odom", "nav_msgs/Odometry", 36},
              {"/pose", "geometry_msgs/PoseStamped", 36},
              {"/tf", "tf2_msgs/TFMessage", 36},
              {"/tf_static", "tf2_msgs/TFMessage", 1}},
             1'699'999'999'981'000'000, 1'700'000'000'334'832'934);
  expect_sweeps(*bag, "/ouster/points", kOuster, 3, "os_sensor");
  expect_sweeps(*bag, "/livox/lidar", kLivox, 3, "livox_frame");
  const auto enc = MessageEncoding::kRos1;
  expect_odometry(read_first(*bag, "/odom"), enc, 0, kFirst);
  expect_odometry(read_last(*bag, "/odom"), enc, 35, kLast);

  const PoseStamped p0 = decode_pose_stamped(read_first(*bag, "/pose"), enc, "pose");
  EXPECT_EQ(p0.header.stamp.nanoseconds(), ins_stamp_ns(0));
  EXPECT_EQ(p0.header.frame_id, "map");
  expect_vec(p0.pose.position, {108.1660329034986, 220.7105264688993, 0.499}, kMetreTol);
  expect_quat(p0.pose.orientation, {0.008143129831849718, 0.012089035212074117, 0.4872005322751789, 0.8731684751609882});
  const PoseStamped p1 = decode_pose_stamped(read_last(*bag, "/pose"), enc, "pose");
  EXPECT_EQ(p1.header.stamp.nanoseconds(), ins_stamp_ns(35));
  expect_vec(p1.pose.position, {109.09001929664821, 222.19671257611276, 0.5165}, kMetreTol);
  expect_quat(p1.pose.orientation, {0.010215668327015755, 0.011859958274127565, 0.4603014503020097, 0.8876246708830456});

  expect_tf(*bag, enc);
  // The chain map -> odom -> base_link -> gnss at the first stamp: the gnss origin in map.
  const TFMessage st = decode_tf_message(read_first(*bag, "/tf_static"), enc, "tf_static");
  const TFMessage tf0 = decode_tf_message(read_first(*bag, "/tf"), enc, "tf");
  const Iso3 T_map_gnss = transform_from(tf0.transforms[0], "tf") * transform_from(tf0.transforms[1], "tf") *
                          transform_from(st.transforms[0], "tf_static");
  const Iso3 T_map_base = transform_from(tf0.transforms[0], "tf") * transform_from(tf0.transforms[1], "tf");
  expect_vec(T_map_gnss.translation(), T_map_base * Vec3(0.45, -0.1, 1.35), 1e-12);
  // PoseStamped holds base_link in map: the same as the TF chain's map -> base_link.
  expect_vec(T_map_base.translation(), p0.pose.position, 1e-9);
}

TEST(BagFixtures, Ros1KilledRecordingIsScannedUpToItsLastWholeMessage) {
  // rosbag's own bytes of a recording killed mid-write: no index (index_pos 0), the last chunk
  // still open (sizes 0) with 7 whole messages, the file ending inside the 8th. The file ends
  // inside a chunk: an error naming it unless input.read_cut_off.
  try {
    (void)open_bag(kDir / "ros1_killed_recording.bag");
    ADD_FAILURE() << "a bag ending inside a chunk opened without input.read_cut_off";
  } catch (const InputError& e) {
    EXPECT_EQ(e.location(), "byte 100305") << e.what();
    EXPECT_NE(std::string(e.what()).find("reads the 2 whole chunks before it"), std::string::npos) << e.what();
  }
  const auto bag = open_bag(kDir / "ros1_killed_recording.bag", OpenOptions{true});
  ASSERT_FALSE(bag->warnings().empty());
  bool names_offset = false;
  for (const std::string& w : bag->warnings()) names_offset |= w.find("byte 101690") != std::string::npos;
  EXPECT_TRUE(names_offset) << "no warning names byte 101690 (the end of the last whole record): "
                            << bag->warnings().front();
  expect_bag(*bag,
             {{"/hesai/pandar", "sensor_msgs/PointCloud2", 2},
              {"/novatel/oem7/inspva", "novatel_oem7_msgs/INSPVA", 27},
              {"/novatel/oem7/inspvax", "novatel_oem7_msgs/INSPVAX", 26}},
             1'699'999'999'982'000'000, 1'700'000'000'242'000'000);
  expect_sweeps(*bag, "/hesai/pandar", kHesai, 2, "hesai_lidar");
  // The last whole messages lie in the open chunk.
  const Oem7Inspva last = decode_oem7_inspva(read_last(*bag, "/novatel/oem7/inspva"), MessageEncoding::kRos1, "inspva");
  EXPECT_EQ(last.header.stamp.nanoseconds(), ins_stamp_ns(26));
  const Oem7Inspvax lastx = decode_oem7_inspvax(read_last(*bag, "/novatel/oem7/inspvax"), MessageEncoding::kRos1, "inspvax");
  EXPECT_EQ(lastx.header.stamp.nanoseconds(), ins_stamp_ns(25));
  EXPECT_EQ(lastx.nov_header.sequence_number, 25u);
}

// ------------------------------------------------------------------------------------- MCAP

void expect_mcap(const BagReader& bag, Oem7Header::Layout oem7_layout) {
  expect_bag(bag,
             {{"/hesai/pandar", "sensor_msgs/msg/PointCloud2", 3},
              {"/ouster/points", "sensor_msgs/msg/PointCloud2", 3},
              {"/novatel/oem7/inspvax", "novatel_oem7_msgs/msg/INSPVAX", 36},
              {"/odom", "nav_msgs/msg/Odometry", 36}},
             1'699'999'999'982'000'000, 1'700'000'000'332'000'000);
  for (const Topic& t : bag.topics()) {
    EXPECT_EQ(t.encoding, MessageEncoding::kCdr);
    EXPECT_EQ(t.definition_encoding, "ros2msg");
    EXPECT_TRUE(check_definition(t).checked) << t.name;
  }
  expect_sweeps(bag, "/hesai/pandar", kHesai, 3, "hesai_lidar");
  expect_sweeps(bag, "/ouster/points", kOuster, 3, "os_sensor");  // lz4 file: the uint8 ring layout
  const DefinitionCheck check = check_definition(topic_of(bag, "/novatel/oem7/inspvax"));
  EXPECT_EQ(check.oem7_layout, oem7_layout);
  const auto enc = MessageEncoding::kCdr;
  for (auto layout : {std::optional<Oem7Header::Layout>{}, check.oem7_layout}) {
    expect_inspvax(read_first(bag, "/novatel/oem7/inspvax"), enc, 0, kFirst, layout, oem7_layout);
    expect_inspvax(read_last(bag, "/novatel/oem7/inspvax"), enc, 35, kLast, layout, oem7_layout);
  }
  expect_odometry(read_first(bag, "/odom"), enc, 0, kFirst);
  expect_odometry(read_last(bag, "/odom"), enc, 35, kLast);
}

TEST(BagFixtures, McapZstd) {
  const auto bag = open_bag(kDir / "mcap_hesai_ouster_zstd.mcap");
  EXPECT_TRUE(bag->warnings().empty()) << bag->warnings().front();
  expect_mcap(*bag, Oem7Header::Layout::kIdleTime);
}

TEST(BagFixtures, McapLz4) {
  const auto bag = open_bag(kDir / "mcap_hesai_ouster_lz4.mcap");
  EXPECT_TRUE(bag->warnings().empty()) << bag->warnings().front();
  expect_mcap(*bag, Oem7Header::Layout::kIdleTime);
}

TEST(BagFixtures, McapCutOffIsStreamedWithAWarningNamingTheByte) {
  const auto bag = open_bag(kDir / "mcap_truncated.mcap");
  ASSERT_FALSE(bag->warnings().empty());
  bool names_offset = false;
  for (const std::string& w : bag->warnings()) names_offset |= w.find("byte 46523") != std::string::npos;
  EXPECT_TRUE(names_offset) << "no warning names byte 46523 (the end of the last whole record): "
                            << bag->warnings().front();
  // Everything before the cut chunk: 2 + 1 sweeps, 23 + 23 INS messages.
  expect_bag(*bag,
             {{"/hesai/pandar", "sensor_msgs/msg/PointCloud2", 2},
              {"/ouster/points", "sensor_msgs/msg/PointCloud2", 1},
              {"/novatel/oem7/inspvax", "novatel_oem7_msgs/msg/INSPVAX", 23},
              {"/odom", "nav_msgs/msg/Odometry", 23}},
             1'699'999'999'982'000'000, 1'700'000'000'203'000'000);
  expect_sweeps(*bag, "/hesai/pandar", kHesai, 2, "hesai_lidar");
  expect_sweeps(*bag, "/ouster/points", kOuster, 1, "os_sensor");
  // The last whole message: Odometry 22 (stamp T0 + 0.2 s, position 10.6, 20.8, 0.51).
  const Odometry last = decode_odometry(read_last(*bag, "/odom"), MessageEncoding::kCdr, "odometry");
  EXPECT_EQ(last.header.stamp.nanoseconds(), ins_stamp_ns(22));
  expect_vec(last.pose.pose.position, {10.6, 20.8, 0.51}, kMetreTol);
}

TEST(BagFixtures, McapCorruptChunkFailsNamingTheChunk) {
  const auto bag = open_bag(kDir / "mcap_corrupt_chunk.mcap");
  // The summary is intact: the index opens. Reading every message hits the bad chunk.
  std::string location, what;
  try {
    for (std::uint32_t t = 0; t < bag->topics().size(); ++t) {
      for (const MessageRef& ref : bag->messages(t)) bag->read(ref);
    }
  } catch (const InputError& e) {
    location = e.location();
    what = e.what();
  }
  ASSERT_FALSE(location.empty()) << "reading the corrupt chunk did not fail";
  std::smatch m;
  ASSERT_TRUE(std::regex_match(location, m, std::regex("byte ([0-9]+)"))) << location;
  // The corrupt chunk's record spans bytes 24136 .. 48887.
  const long offset = std::stol(m[1]);
  EXPECT_GE(offset, 24136);
  EXPECT_LT(offset, 24136 + 24751);
  EXPECT_NE(what.find("mcap_corrupt_chunk.mcap"), std::string::npos) << what;
  EXPECT_NE(what.find("CRC"), std::string::npos) << what;
}

TEST(BagFixtures, McapUncompressedMoreDrivers) {
  const auto bag = open_bag(kDir / "mcap_more_drivers_none.mcap");
  EXPECT_TRUE(bag->warnings().empty()) << bag->warnings().front();
  expect_bag(*bag,
             {{"/hesai/points", "sensor_msgs/msg/PointCloud2", 3},
              {"/velodyne_points", "sensor_msgs/msg/PointCloud2", 3},
              {"/pose_cov", "geometry_msgs/msg/PoseWithCovarianceStamped", 36},
              {"/tf", "tf2_msgs/msg/TFMessage", 36},
              {"/tf_static", "tf2_msgs/msg/TFMessage", 1}},
             1'699'999'999'981'000'000, 1'700'000'000'332'000'000);
  for (const Topic& t : bag->topics()) EXPECT_TRUE(check_definition(t).checked) << t.name;
  // HesaiLidar_ROS_2.0's packed layout: the Hesai points with `timestamp` unaligned at byte 18.
  expect_sweeps(*bag, "/hesai/points", kHesai, 3, "hesai_lidar");
  // An organized Velodyne cloud (16 x 50, ring-major) with 22 missing returns (NaN) per sweep.
  expect_sweeps(*bag, "/velodyne_points", kVelodyne, 3, "velodyne", 22);
  const auto enc = MessageEncoding::kCdr;
  for (auto [n, p, q] : {std::tuple{0, Vec3{108.1660329034986, 220.7105264688993, 0.499},
                                    Quaternion{0.008143129831849718, 0.012089035212074117, 0.4872005322751789, 0.8731684751609882}},
                         std::tuple{35, Vec3{109.09001929664821, 222.19671257611276, 0.5165},
                                    Quaternion{0.010215668327015755, 0.011859958274127565, 0.4603014503020097, 0.8876246708830456}}}) {
    const PoseWithCovarianceStamped m = decode_pose_with_covariance_stamped(read_nth(*bag, "/pose_cov", n), enc, "pose_cov");
    EXPECT_EQ(m.header.stamp.nanoseconds(), ins_stamp_ns(n));
    EXPECT_EQ(m.header.frame_id, "map");
    expect_vec(m.pose.pose.position, p, kMetreTol);
    expect_quat(m.pose.pose.orientation, q);
    EXPECT_DOUBLE_EQ(m.pose.covariance[0], 0.0025);
    const InsRecord r = to_ins_record(m, "pose_cov");
    expect_vec(r.p_world_m, p, kMetreTol);
    EXPECT_NEAR(r.position_stddev_m.x(), 0.05, 1e-12);
  }
  expect_tf(*bag, enc);
}

// ---------------------------------------------------------------------------------- rosbag2

TEST(BagFixtures, Rosbag2SplitJazzyWithMetadata) {
  const auto bag = open_bag(kDir / "rosbag2_velodyne_split");
  expect_bag(*bag,
             {{"/velodyne_points", "sensor_msgs/msg/PointCloud2", 4},
              {"/gps/fix", "sensor_msgs/msg/NavSatFix", 46},
              {"/imu/data", "sensor_msgs/msg/Imu", 46}},
             1'699'999'999'982'000'000, 1'700'000'000'432'000'000);
  for (const Topic& t : bag->topics()) {
    EXPECT_EQ(t.encoding, MessageEncoding::kCdr);
    EXPECT_EQ(t.definition_encoding, "ros2msg");
    EXPECT_TRUE(check_definition(t).checked) << t.name;
  }
  expect_sweeps(*bag, "/velodyne_points", kVelodyne, 4, "velodyne");  // Velodyne-PCL layout
  const auto enc = MessageEncoding::kCdr;
  expect_navsatfix(read_first(*bag, "/gps/fix"), enc, 0, kFirst);
  expect_navsatfix(read_last(*bag, "/gps/fix"), enc, 45, kLast46);
  expect_imu(read_first(*bag, "/imu/data"), enc, 0, kFirst);
  expect_imu(read_last(*bag, "/imu/data"), enc, 45, kLast46);
  // Message 35 lies in the second file.
  expect_navsatfix(read_nth(*bag, "/gps/fix", 35), enc, 35, kLast);

  // One file of the split bag alone.
  const auto part = open_bag(kDir / "rosbag2_velodyne_split" / "rosbag2_velodyne_split_1.db3");
  expect_bag(*part,
             {{"/velodyne_points", "sensor_msgs/msg/PointCloud2", 2},
              {"/gps/fix", "sensor_msgs/msg/NavSatFix", 12},
              {"/imu/data", "sensor_msgs/msg/Imu", 12}},
             1'700'000'000'313'000'000, 1'700'000'000'432'000'000);
}

TEST(BagFixtures, Rosbag2HumbleWithoutDefinitionsOrMetadata) {
  for (const fs::path& path : {kDir / "rosbag2_humble_no_metadata",
                               kDir / "rosbag2_humble_no_metadata" / "rosbag2_humble_no_metadata_0.db3"}) {
    const auto bag = open_bag(path);
    expect_bag(*bag, {{"/velodyne_points", "sensor_msgs/msg/PointCloud2", 3}, {"/odom", "nav_msgs/msg/Odometry", 36}},
               1'699'999'999'982'000'000, 1'700'000'000'332'000'000);
    for (const Topic& t : bag->topics()) {
      EXPECT_EQ(t.encoding, MessageEncoding::kCdr);
      EXPECT_TRUE(t.definition.empty()) << t.name;
      EXPECT_EQ(t.definition_encoding, "");
    }
    expect_sweeps(*bag, "/velodyne_points", kVelodyne, 3, "velodyne");
    expect_odometry(read_first(*bag, "/odom"), MessageEncoding::kCdr, 0, kFirst);
    expect_odometry(read_last(*bag, "/odom"), MessageEncoding::kCdr, 35, kLast);
  }
}

// --------------------------------------------------------------------------------- threading

TEST(BagFixtures, ParallelReadsReturnTheBytesOfSerialReads) {
  // read() is thread-safe (stages load sweeps in parallel): 4 threads reading every message of a
  // compressed bag, in different orders, through one reader and its chunk cache.
  for (const char* name : {"ros1_velodyne_navsat_bz2.bag", "ros1_ouster_livox_tf_lz4.bag", "mcap_hesai_ouster_zstd.mcap",
                           "mcap_hesai_ouster_lz4.mcap", "rosbag2_velodyne_split"}) {
    SCOPED_TRACE(name);
    const auto bag = open_bag(kDir / name);
    std::vector<MessageRef> refs;
    for (std::uint32_t t = 0; t < bag->topics().size(); ++t) {
      for (const MessageRef& r : bag->messages(t)) refs.push_back(r);
    }
    std::vector<std::vector<std::uint8_t>> serial;
    for (const MessageRef& r : refs) serial.push_back(bag->read(r));
    constexpr int kThreads = 4;
    std::vector<int> mismatches(kThreads, 0);
    std::vector<std::thread> threads;
    for (int k = 0; k < kThreads; ++k) {
      threads.emplace_back([&, k] {
        for (int pass = 0; pass < 3; ++pass) {
          for (std::size_t j = 0; j < refs.size(); ++j) {
            const std::size_t i = (k % 2 == 0) ? (j * 7 + k) % refs.size() : refs.size() - 1 - j;
            if (bag->read(refs[i]) != serial[i]) ++mismatches[k];
          }
        }
      });
    }
    for (std::thread& t : threads) t.join();
    for (int k = 0; k < kThreads; ++k) EXPECT_EQ(mismatches[k], 0) << "thread " << k;
  }
}

}  // namespace
}  // namespace insalign::io::bag
