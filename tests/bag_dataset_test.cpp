// Recordings to Datasets (input/bag_dataset.hpp): topic choice, every INS source type from bags
// written in-process (the vehicle drives north or east, so the heading of `ins` is known), TF
// chains, NavSatFix + Imu pairing, clock gaps, lazy loading, and the ecosystem fixtures of
// tests/data/bags (README.md there lists what they hold).
#include <gtest/gtest.h>
#include <lz4frame.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "cli_test_util.hpp"
#include "core/errors.hpp"
#include "recording/bag_writer.hpp"
#include "recording/lz4_frame.hpp"
#include "recording/message_definitions.hpp"
#include "recording/messages.hpp"
#include "recording/pointcloud2.hpp"
#include "input/bag_dataset.hpp"
#include "recording/bag_topics.hpp"
#include "inslog/attitude.hpp"
#include "core/geodesy.hpp"

namespace insalign::io {
namespace {

namespace fs = std::filesystem;
using namespace bag;

const fs::path kFixtures = fs::path(INSALIGN_TEST_DATA_DIR) / "bags";
constexpr double kT0 = 1700000000.0;
constexpr double kSpeed = 5.0;  // m/s
constexpr double kPi = 3.14159265358979323846;
const GeodeticPoint kOrigin{48.1, 11.5, 500.0};

testing::ScratchDir scratch_dir(const std::string& tag) { return {"insalign_bagds_", tag}; }

constexpr double kFirstInsS = kT0 - 0.1;  // the first INS record: the world's origin

// The vehicle (x forward, y left, z up) at t: straight at kSpeed along `heading_rad` (ENU, from
// east), from the origin at the first INS record, so that the recentred world (cartesian sources)
// and the ENU frame at the first fix (geodetic sources) are both the truth's frame.
Iso3 T_world_vehicle(double t_s, double heading_rad) {
  Iso3 T = Iso3::Identity();
  T.linear() = Eigen::AngleAxisd(heading_rad, Vec3::UnitZ()).toRotationMatrix();
  T.translation() = kSpeed * (t_s - kFirstInsS) * Vec3(std::cos(heading_rad), std::sin(heading_rad), 0.0);
  return T;
}

// NovAtel's vehicle frame (x right, y forward, z up) in the x-forward vehicle frame.
Iso3 T_vehicle_novatel() {
  Iso3 T = Iso3::Identity();
  T.linear() << 0, 1, 0, -1, 0, 0, 0, 0, 1;
  return T;
}

/// Messages collected in any order, written sorted by record time.
class BagBuilder {
 public:
  explicit BagBuilder(BagFormat format = BagFormat::kMcap)
      : format_(format), enc_(format == BagFormat::kRos1 ? MessageEncoding::kRos1 : MessageEncoding::kCdr) {}
  MessageEncoding enc() const { return enc_; }
  std::uint32_t topic(const std::string& name, const std::string& type) {
    const MessageDefinition* d = builtin_definition(type);
    const bool ros1 = enc_ == MessageEncoding::kRos1;
    topics_.push_back({name, ros1 ? d->type : d->ros2_type, enc_, ros1 ? d->ros1_text : d->ros2_text,
                       ros1 ? "ros1msg" : "ros2msg", ros1 ? d->ros1_md5 : "", 0});
    return static_cast<std::uint32_t>(topics_.size() - 1);
  }
  void add(std::uint32_t topic, double log_s, std::vector<std::uint8_t> bytes) {
    messages_.push_back({topic, std::llround(log_s * 1e9), std::move(bytes)});
  }
  std::vector<Topic>& topics_for_test() { return topics_; }
  auto& messages_for_test() { return messages_; }
  fs::path write(const fs::path& path) {
    std::stable_sort(messages_.begin(), messages_.end(), [](const auto& a, const auto& b) { return a.log_ns < b.log_ns; });
    auto w = make_bag_writer(format_, path);
    for (const Topic& t : topics_) w->add_topic(t);
    for (const auto& m : messages_) w->write(m.topic, m.log_ns, m.bytes);
    w->close();
    return path;
  }

 private:
  struct Msg {
    std::uint32_t topic;
    std::int64_t log_ns;
    std::vector<std::uint8_t> bytes;
  };
  BagFormat format_;
  MessageEncoding enc_;
  std::vector<Topic> topics_;
  std::vector<Msg> messages_;
};

Header header_at(double t_s, const std::string& frame) { return {0, Stamp::from_seconds(t_s), frame}; }

// A small cloud ending at t_end: 60 points over 0.1 s.
Sweep small_sweep(double t_end_s) {
  Sweep s;
  s.t_end_s = t_end_s;
  for (int i = 0; i < 60; ++i) {
    s.p_lidar.emplace_back(10.0f + 0.25f * i, std::sin(0.1f * i), -1.5f);
    s.dt_s.push_back(-0.1f + 0.1f * static_cast<float>(i) / 59.0f);
    s.intensity.push_back(static_cast<float>(i));
    s.ring.push_back(static_cast<std::uint16_t>(i % 16));
  }
  return s;
}

void add_clouds(BagBuilder& b, const std::string& topic, int frames, DriverLayout layout = DriverLayout::kHesai,
                double t0_s = kT0) {
  const std::uint32_t id = b.topic(topic, "sensor_msgs/PointCloud2");
  for (int k = 0; k < frames; ++k) {
    const double t_end = t0_s + 0.1 * (k + 1);
    b.add(id, t_end + 0.005, encode_message(make_pointcloud2(small_sweep(t_end), layout, "lidar"), b.enc()));
  }
}

// INS of `kind` at 50 Hz over [kT0 - 0.1, kT0 + span] along `heading`, stamps + stamp_shift_s,
// recorded 2 ms after the unshifted stamp (the recorder's clock is the LiDAR's).
void add_ins(BagBuilder& b, InsSourceKind kind, double heading, double span_s, double stamp_shift_s = 0.0) {
  const LocalEnu enu(kOrigin);
  std::uint32_t a = 0, c = 0;
  switch (kind) {
    case InsSourceKind::kInspvax: a = b.topic("/novatel/oem7/inspvax", "novatel_oem7_msgs/INSPVAX"); break;
    case InsSourceKind::kInspva: a = b.topic("/novatel/oem7/inspva", "novatel_oem7_msgs/INSPVA"); break;
    case InsSourceKind::kNavSatFixImu:
      a = b.topic("/gps/fix", "sensor_msgs/NavSatFix"), c = b.topic("/imu/data", "sensor_msgs/Imu");
      break;
    case InsSourceKind::kOdometry: a = b.topic("/odom", "nav_msgs/Odometry"); break;
    case InsSourceKind::kPoseWithCovariance: a = b.topic("/pose_cov", "geometry_msgs/PoseWithCovarianceStamped"); break;
    case InsSourceKind::kPose: a = b.topic("/pose", "geometry_msgs/PoseStamped"); break;
    case InsSourceKind::kTf: a = b.topic("/tf", "tf2_msgs/TFMessage"); break;
  }
  const MessageEncoding enc = b.enc();
  for (int i = 0; kT0 - 0.1 + 0.02 * i <= kT0 + span_s + 1e-9; ++i) {
    const double t = kT0 - 0.1 + 0.02 * i, stamp = t + stamp_shift_s, log = t + 0.002;
    const Iso3 T_veh = T_world_vehicle(t, heading);
    const Iso3 T_nov = T_veh * T_vehicle_novatel();
    // Geodetic messages: position by the ENU frame at the origin, attitude in the ENU at the point.
    const GeodeticPoint p = enu.geodetic(T_veh.translation());
    const Mat3 R_enu_p = enu.rotation_at(p).transpose();
    const Header h = header_at(stamp, "ins");
    if (kind == InsSourceKind::kInspvax || kind == InsSourceKind::kInspva) {
      const AttitudeDeg ang = novatel_angles(R_enu_p * T_nov.linear());
      const NovatelAttitude pva{kSpeed * std::sin(heading), kSpeed * std::cos(heading), 0.0, ang.roll_deg, ang.pitch_deg, ang.heading_deg};
      Oem7Header nov;
      nov.layout = builtin_oem7_layout(enc);
      if (kind == InsSourceKind::kInspvax) {
        Oem7Inspvax m;
        m.header = h, m.nov_header = nov, m.ins_status = 3, m.pos_type = 56;
        m.latitude = p.lat_deg, m.longitude = p.lon_deg, m.undulation = 47.5f, m.height = p.height_m - 47.5;
        m.pva = pva, m.latitude_stdev = m.longitude_stdev = 0.02f, m.height_stdev = 0.03f;
        b.add(a, log, encode_message(m, enc));
      } else {
        Oem7Inspva m;
        m.header = h, m.nov_header = nov, m.status = 3;
        m.latitude = p.lat_deg, m.longitude = p.lon_deg, m.height = p.height_m, m.pva = pva;
        b.add(a, log, encode_message(m, enc));
      }
    } else if (kind == InsSourceKind::kNavSatFixImu) {
      NavSatFix f;
      f.header = h, f.status = NavSatFix::kGbasFix, f.latitude = p.lat_deg, f.longitude = p.lon_deg, f.altitude = p.height_m;
      Imu imu;
      imu.header = h, imu.orientation = quaternion_from(R_enu_p * T_veh.linear());
      b.add(a, log, encode_message(f, enc));
      b.add(c, log, encode_message(imu, enc));
    } else if (kind == InsSourceKind::kTf) {
      TFMessage m{{{header_at(stamp, "odom"), "base_link", T_veh.translation(), quaternion_from(T_veh.linear())}}};
      b.add(a, log, encode_message(m, enc));
    } else {
      const Pose pose{T_veh.translation(), quaternion_from(T_veh.linear())};
      Header hw = header_at(stamp, "odom");
      if (kind == InsSourceKind::kOdometry) {
        Odometry m;
        m.header = hw, m.child_frame_id = "base_link", m.pose.pose = pose;
        b.add(a, log, encode_message(m, enc));
      } else if (kind == InsSourceKind::kPoseWithCovariance) {
        b.add(a, log, encode_message(PoseWithCovarianceStamped{hw, {pose, {}}}, enc));
      } else {
        b.add(a, log, encode_message(PoseStamped{hw, pose}, enc));
      }
    }
  }
}

BagOptions options_for(const fs::path& path) {
  BagOptions o;
  o.path = path;
  return o;
}

void expect_near(const Iso3& a, const Iso3& b, double tol, const std::string& what) {
  EXPECT_LT((a.translation() - b.translation()).norm(), tol) << what;
  EXPECT_LT((a.linear() - b.linear()).norm(), tol) << what;
}

const auto& error_of = testing::input_error_of;

// ------------------------------------------------------------------------------------- topics

TEST(BagDataset, OneLidarTopicIsChosenSeveralNeedLidarTopic) {
  const testing::ScratchDir scratch = scratch_dir("topics");
  const fs::path dir = scratch.path();
  BagBuilder b;
  add_clouds(b, "/a/points", 20);
  add_clouds(b, "/b", 15);
  add_ins(b, InsSourceKind::kOdometry, 0.0, 2.5);
  const fs::path bag = b.write(dir / "two.mcap");
  const std::string e = error_of([&] { load_bag(options_for(bag)); });
  EXPECT_NE(e.find(bag.string()), std::string::npos) << e;
  EXPECT_NE(e.find("/a/points (20 msgs), /b (15 msgs)"), std::string::npos) << e;
  EXPECT_NE(e.find("--lidar-topic"), std::string::npos) << e;

  BagOptions o = options_for(bag);
  o.lidar_topics = {"/b"};
  const BagDatasets one = load_bag(o);
  ASSERT_EQ(one.lidars.size(), 1u);
  EXPECT_EQ(one.lidar_names, std::vector<std::string>{"b"});
  EXPECT_EQ(one.lidars[0].frames.frames.size(), 15u);

  o.lidar_topics = {"/a/points", "/b"};  // a rig: names as CONVENTIONS "Rigs"
  const BagDatasets rig = load_bag(o);
  EXPECT_EQ(rig.lidar_names, (std::vector<std::string>{"a_points", "b"}));
  ASSERT_EQ(rig.lidars.size(), 2u);
  EXPECT_EQ(rig.lidars[0].poses.size(), rig.lidars[1].poses.size());

  o.lidar_topics = {"/odom"};
  EXPECT_NE(error_of([&] { load_bag(o); }).find("not sensor_msgs/PointCloud2"), std::string::npos);
  o.lidar_topics = {"/nope"};
  EXPECT_NE(error_of([&] { load_bag(o); }).find("no such topic"), std::string::npos);

  BagBuilder single;
  add_clouds(single, "/only", 12);
  add_ins(single, InsSourceKind::kOdometry, 0.0, 1.5);
  const BagDatasets d = load_bag(options_for(single.write(dir / "one.mcap")));
  EXPECT_EQ(d.lidar_names, std::vector<std::string>{"only"});
  EXPECT_EQ(d.lidars[0].frames.frames.size(), 12u);
}

TEST(BagDataset, CloudWithoutXyzIsAnInputErrorNamingTheTopic) {
  const testing::ScratchDir scratch = scratch_dir("noxyz");
  const fs::path dir = scratch.path();
  BagBuilder b;
  const std::uint32_t id = b.topic("/broken", "sensor_msgs/PointCloud2");
  for (int k = 0; k < 8; ++k) {
    PointCloud2 c = make_pointcloud2(small_sweep(kT0 + 0.1 * (k + 1)), DriverLayout::kHesai, "lidar");
    c.fields[1].name = "why";  // no 'y'
    b.add(id, kT0 + 0.1 * (k + 1), encode_message(c, b.enc()));
  }
  add_ins(b, InsSourceKind::kOdometry, 0.0, 1.0);
  const std::string e = error_of([&] { load_bag(options_for(b.write(dir / "b.mcap"))); });
  EXPECT_NE(e.find("/broken"), std::string::npos) << e;
  EXPECT_NE(e.find("no 'y' field"), std::string::npos) << e;
}

TEST(BagDataset, TwoInsTopicsOfTheBestKindAreAmbiguous) {
  const testing::ScratchDir scratch = scratch_dir("ins_ambiguous");
  const fs::path dir = scratch.path();
  BagBuilder b;
  add_clouds(b, "/points", 10);
  add_ins(b, InsSourceKind::kOdometry, 0.0, 1.2);
  const std::uint32_t other = b.topic("/odometry/filtered", "nav_msgs/Odometry");
  for (int i = 0; i < 60; ++i) {
    Odometry m;
    m.header = header_at(kT0 - 0.1 + 0.02 * i, "map");
    m.child_frame_id = "base_link";
    b.add(other, kT0 - 0.1 + 0.02 * i + 0.002, encode_message(m, b.enc()));
  }
  add_ins(b, InsSourceKind::kPose, 0.0, 1.2);  // a lower kind: not ambiguous with it
  const fs::path bag = b.write(dir / "b.mcap");
  const std::string e = error_of([&] { load_bag(options_for(bag)); });
  EXPECT_NE(e.find("/odom ("), std::string::npos) << e;
  EXPECT_NE(e.find("/odometry/filtered ("), std::string::npos) << e;
  EXPECT_NE(e.find("--ins-topic"), std::string::npos) << e;
  BagOptions o = options_for(bag);
  o.ins_topic = "/odom";
  const BagDatasets d = load_bag(o);
  EXPECT_EQ(d.report.ins.topics, std::vector<std::string>{"/odom"});
  EXPECT_EQ(d.report.ins.not_used.size(), 2u);
  o.ins_topic = "/pose";
  EXPECT_EQ(load_bag(o).report.ins.kind, "PoseStamped");
}

// ---------------------------------------------------------------------------- INS source types

struct InsCase {
  InsSourceKind kind;
  bool novatel_frame;  ///< ins = NovAtel's x right, y forward
  const char* expected_kind;
};

TEST(BagDataset, EveryInsSourceGivesTheTrajectoryInItsInsFrame) {
  const testing::ScratchDir scratch = scratch_dir("ins_types");
  const fs::path dir = scratch.path();
  const InsCase cases[] = {{InsSourceKind::kInspvax, true, "NovAtel INSPVAX"},
                           {InsSourceKind::kInspva, true, "NovAtel INSPVA"},
                           {InsSourceKind::kNavSatFixImu, false, "NavSatFix + Imu"},
                           {InsSourceKind::kOdometry, false, "Odometry"},
                           {InsSourceKind::kPoseWithCovariance, false, "PoseWithCovarianceStamped"},
                           {InsSourceKind::kPose, false, "PoseStamped"},
                           {InsSourceKind::kTf, false, "TF"}};
  for (const InsCase& c : cases) {
    for (const double heading : {kPi / 2, 0.0}) {  // north, east
      for (const BagFormat format : {BagFormat::kRos1, BagFormat::kMcap}) {
        const std::string what = std::string(c.expected_kind) + (heading > 0 ? " north" : " east") +
                                 (format == BagFormat::kRos1 ? " ros1" : " mcap");
        SCOPED_TRACE(what);
        BagBuilder b(format);
        add_clouds(b, "/points", 20);
        add_ins(b, c.kind, heading, 2.2);
        const BagDatasets d = load_bag(options_for(b.write(dir / (format == BagFormat::kRos1 ? "i.bag" : "i.mcap"))));
        EXPECT_EQ(d.report.ins.kind, c.expected_kind);
        const Dataset& ds = d.lidars[0];
        ASSERT_EQ(ds.frames.frames.size(), 20u);
        const Iso3 T_ins = c.novatel_frame ? T_vehicle_novatel() : Iso3::Identity();
        for (const double t : {kT0, kT0 + 1.0, kT0 + 2.0}) {
          expect_near(ds.poses.T_world_ins(t), T_world_vehicle(t, heading) * T_ins, 1e-6, what);
        }
        // The heading, independently of the helpers: the forward axis points where the car drives.
        const Vec3 forward = ds.poses.T_world_ins(kT0 + 1.0).linear().col(c.novatel_frame ? 1 : 0);
        EXPECT_NEAR(forward.dot(Vec3(std::cos(heading), std::sin(heading), 0.0)), 1.0, 1e-9);
        EXPECT_EQ(d.enu.has_value(), c.kind == InsSourceKind::kInspvax || c.kind == InsSourceKind::kInspva ||
                                         c.kind == InsSourceKind::kNavSatFixImu);
      }
    }
  }
}

TEST(BagDataset, InspvaxQualityAndReportFields) {
  const testing::ScratchDir scratch = scratch_dir("quality");
  const fs::path dir = scratch.path();
  BagBuilder b;
  add_clouds(b, "/points", 10);
  add_ins(b, InsSourceKind::kInspvax, kPi / 2, 1.2);
  const BagDatasets d = load_bag(options_for(b.write(dir / "q.mcap")));
  const Dataset& ds = d.lidars[0];
  ASSERT_EQ(ds.ins_quality.size(), ds.poses.size());
  EXPECT_EQ(ds.ins_quality[3].solution, GnssSolution::kRtkFixed);
  EXPECT_NEAR(ds.ins_quality[3].horizontal_stddev_m, std::hypot(0.02, 0.02), 1e-6);
  EXPECT_NEAR(ds.ins_quality[3].vertical_stddev_m, 0.03, 1e-6);
  const InsReport& r = d.report.ins;
  EXPECT_NEAR(r.rate_hz, 50.0, 1e-4);
  ASSERT_EQ(r.solution_fractions.size(), 1u);
  EXPECT_EQ(r.solution_fractions[0].first, "RTK fixed");
  EXPECT_EQ(r.status_counts[0].first, "INS_SOLUTION_GOOD / INS_RTKFIXED");
  ASSERT_TRUE(r.enu_origin.has_value());
  EXPECT_NEAR(r.enu_origin->lat_deg, kOrigin.lat_deg, 1e-12);
  EXPECT_NE(r.height_datum.find("undulation"), std::string::npos);
  const LoadReport lr = to_load_report(d.report);
  EXPECT_EQ(lr.frames_total, 10u);
  EXPECT_EQ(lr.frames_used, 10u);
  EXPECT_EQ(lr.time_field, "timestamp");
  EXPECT_NE(lr.pose_format.find("INSPVAX"), std::string::npos);
  const std::string text = describe_bag(d.report);
  for (const char* s : {"/points", "'timestamp' float64: absolute seconds", "INSPVAX", "x right, y forward", "RTK fixed 100.0%"})
    EXPECT_NE(text.find(s), std::string::npos) << s << "\n" << text;
}

// ----------------------------------------------------------------------------------------- TF

TEST(BagDataset, TfChainWithAndWithoutFrames) {
  const testing::ScratchDir scratch = scratch_dir("tf");
  const fs::path dir = scratch.path();
  BagBuilder b;
  add_clouds(b, "/points", 20);
  const std::uint32_t tf = b.topic("/tf", "tf2_msgs/TFMessage"), tf_static = b.topic("/tf_static", "tf2_msgs/TFMessage");
  const Iso3 T_map_odom = make_transform(Vec3(100, 200, 0), Vec3(0, 0, 5));
  const Iso3 T_base_gnss = make_transform(Vec3(0.45, -0.1, 1.35), Vec3(0, 0, -90));
  b.add(tf_static, kT0 - 0.1, encode_message(TFMessage{{{header_at(kT0 - 0.1, "base_link"), "gnss", T_base_gnss.translation(),
                                                         quaternion_from(T_base_gnss.linear())}}},
                                             b.enc()));
  for (int i = 0; i <= 120; ++i) {
    const double t = kT0 - 0.1 + 0.02 * i;
    const Iso3 T_odom_base = T_world_vehicle(t, 0.3);
    TFMessage m{{{header_at(t, "map"), "odom", T_map_odom.translation(), quaternion_from(T_map_odom.linear())},
                 {header_at(t, "/odom"), "base_link", T_odom_base.translation(), quaternion_from(T_odom_base.linear())}}};
    b.add(tf, t + 0.001, encode_message(m, b.enc()));
  }
  const fs::path bag = b.write(dir / "tf.mcap");
  const auto pose_at = [](const BagDatasets& d, double t) {
    Iso3 T = d.lidars[0].poses.T_world_ins(t);
    T.translation() += d.lidars[0].world_origin_m;
    return T;
  };
  const BagDatasets automatic = load_bag(options_for(bag));  // the obvious chain: map -> odom -> base_link
  EXPECT_EQ(automatic.report.ins.ins_frame_id, "base_link");
  EXPECT_EQ(automatic.report.ins.world_frame_id, "map");
  expect_near(pose_at(automatic, kT0 + 1.0), T_map_odom * T_world_vehicle(kT0 + 1.0, 0.3), 1e-9, "auto");

  BagOptions o = options_for(bag);
  o.ins_frame = "gnss";
  expect_near(pose_at(load_bag(o), kT0 + 1.0), T_map_odom * T_world_vehicle(kT0 + 1.0, 0.3) * T_base_gnss, 1e-9, "gnss");
  o.world_frame = "odom";
  o.ins_frame = "base_link";
  expect_near(pose_at(load_bag(o), kT0 + 1.5), T_world_vehicle(kT0 + 1.5, 0.3), 1e-9, "odom");
  o.world_frame = "gnss";  // upwards through the tree
  o.ins_frame = "odom";
  expect_near(pose_at(load_bag(o), kT0 + 1.5), (T_world_vehicle(kT0 + 1.5, 0.3) * T_base_gnss).inverse(), 1e-9, "inverse");
  o.world_frame = "earth";
  EXPECT_NE(error_of([&] { load_bag(o); }).find("--world-frame 'earth' is not a frame"), std::string::npos);
}

TEST(BagDataset, TfWithTwoMovingEndsIsAmbiguous) {
  const testing::ScratchDir scratch = scratch_dir("tf_ambiguous");
  const fs::path dir = scratch.path();
  BagBuilder b;
  add_clouds(b, "/points", 10);
  const std::uint32_t tf = b.topic("/tf", "tf2_msgs/TFMessage");
  for (int i = 0; i <= 70; ++i) {
    const double t = kT0 - 0.1 + 0.02 * i;
    const Iso3 T = T_world_vehicle(t, 0.0);
    TFMessage m{{{header_at(t, "odom"), "base_link", T.translation(), quaternion_from(T.linear())},
                 {header_at(t, "base_link"), "wheel", Vec3::Zero(), quaternion_from(Mat3::Identity())},
                 {header_at(t, "odom"), "trailer", Vec3(1, 0, 0), quaternion_from(Mat3::Identity())}}};
    b.add(tf, t, encode_message(m, b.enc()));
  }
  const fs::path bag = b.write(dir / "tf.mcap");
  const std::string e = error_of([&] { load_bag(options_for(bag)); });
  EXPECT_NE(e.find("trailer"), std::string::npos) << e;
  EXPECT_NE(e.find("wheel"), std::string::npos) << e;
  EXPECT_NE(e.find("--ins-frame"), std::string::npos) << e;
  BagOptions o = options_for(bag);
  o.ins_frame = "base_link";
  EXPECT_EQ(load_bag(o).report.ins.world_frame_id, "odom");
}

// ------------------------------------------------------------------------------ NavSatFix + Imu

TEST(BagDataset, NavSatFixAndImuArePairedByStamp) {
  const testing::ScratchDir scratch = scratch_dir("pairing");
  const fs::path dir = scratch.path();
  const double yaw_rate = 0.2;  // rad/s: slerp between Imu samples is exact for a constant rate
  const auto R_true = [&](double t) { return Mat3(Eigen::AngleAxisd(yaw_rate * (t - kT0), Vec3::UnitZ())); };
  for (const bool same_stamps : {true, false}) {
    BagBuilder b;
    add_clouds(b, "/points", 15);
    const std::uint32_t fix = b.topic("/fix", "sensor_msgs/NavSatFix"), imu = b.topic("/imu", "sensor_msgs/Imu");
    for (int i = 0; i <= 20; ++i) {  // 10 Hz fixes, one past the Imu's end
      const double t = kT0 - 0.1 + 0.1 * i;
      NavSatFix f;
      f.header = header_at(t, "gps");
      f.status = NavSatFix::kFix, f.latitude = kOrigin.lat_deg, f.longitude = kOrigin.lon_deg, f.altitude = kOrigin.height_m;
      b.add(fix, t + 0.002, encode_message(f, b.enc()));
    }
    for (int i = -1; i < 96; ++i) {  // 50 Hz orientations around the fixes, shifted 7 ms unless same_stamps
      const double t = kT0 - 0.1 + 0.02 * i + (same_stamps ? 0.0 : 0.007);
      Imu m;
      m.header = header_at(t, "imu_link");
      m.orientation = quaternion_from(R_true(t));  // standing at the origin, yawing
      b.add(imu, t + 0.001, encode_message(m, b.enc()));
    }
    const BagDatasets d = load_bag(options_for(b.write(dir / "p.mcap")));
    SCOPED_TRACE(same_stamps ? "same stamps" : "interpolated");
    EXPECT_EQ(d.report.ins.ins_frame_id, "imu_link");
    EXPECT_EQ(d.report.ins.records, 20u);  // the fix after the last Imu sample is dropped
    EXPECT_EQ(d.report.ins.records_skipped, 1u);
    const auto& poses = d.lidars[0].poses.poses();
    for (const StampedPose& p : poses) EXPECT_LT((p.T_world_ins.linear() - R_true(p.t_s)).norm(), 1e-9) << p.t_s;
    EXPECT_NE(describe_bag(d.report).find("the fix is of frame 'gps', the orientation of 'imu_link'"), std::string::npos);
  }
}

// -------------------------------------------------------------------------------------- clocks

TEST(BagDataset, ExplainsWholeSecondClockGaps) {
  EXPECT_EQ(explain_clock_gap(18.004)->whole_s, 18.0);
  EXPECT_NE(explain_clock_gap(-18.0)->meaning.find("GPS - UTC"), std::string::npos);
  EXPECT_EQ(explain_clock_gap(-18.0)->whole_s, -18.0);
  EXPECT_NE(explain_clock_gap(37.0)->meaning.find("TAI - UTC"), std::string::npos);
  EXPECT_NE(explain_clock_gap(19.01)->meaning.find("TAI - GPS"), std::string::npos);
  EXPECT_NE(explain_clock_gap(7200.0)->meaning.find("2:00"), std::string::npos);
  EXPECT_NE(explain_clock_gap(-19800.0)->meaning.find("5:30"), std::string::npos);
  EXPECT_NE(explain_clock_gap(3618.0)->meaning.find("plus GPS - UTC"), std::string::npos);
  EXPECT_NE(explain_clock_gap(315964818.0)->meaning.find("GPS seconds"), std::string::npos);
  EXPECT_FALSE(explain_clock_gap(1000.5).has_value());
  EXPECT_FALSE(explain_clock_gap(17.8).has_value());
  EXPECT_FALSE(explain_clock_gap(0.003).has_value());
}

TEST(BagDataset, ClockGapsAreInputErrorsWithBothRanges) {
  const testing::ScratchDir scratch = scratch_dir("clock");
  const fs::path dir = scratch.path();
  for (const double shift : {18.0, 1000.5}) {
    BagBuilder b;
    add_clouds(b, "/points", 30);
    add_ins(b, InsSourceKind::kOdometry, 0.0, 3.2, shift);
    const fs::path bag = b.write(dir / "c.mcap");
    SCOPED_TRACE(shift);
    try {
      load_bag(options_for(bag));
      ADD_FAILURE() << "no error";
    } catch (const ClockGapError& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find(bag.string()), std::string::npos) << m;
      EXPECT_NE(m.find("LiDAR frames 1700000000.100 .. 1700000003.000 s"), std::string::npos) << m;
      EXPECT_NE(m.find(fmt::format("INS {:.3f} .. {:.3f} s", kT0 - 0.1 + shift, kT0 + 3.2 + shift)), std::string::npos) << m;
      EXPECT_FALSE(e.clock().consistent);
      EXPECT_NEAR(e.clock().stamp_gap_s, shift + 0.003, 1e-6);  // INS 2 ms after stamp, clouds 5 ms
      if (shift == 18.0) {
        ASSERT_TRUE(e.clock().explanation.has_value());
        EXPECT_EQ(e.clock().explanation->whole_s, 18.0);
        EXPECT_NE(m.find("GPS - UTC"), std::string::npos) << m;
      } else {
        EXPECT_FALSE(e.clock().explanation.has_value());
        EXPECT_NE(m.find("not a whole number of seconds"), std::string::npos) << m;
      }
      const InputError& as_input = e;  // the command line's exit 2
      EXPECT_EQ(as_input.file(), bag.string());
    }
    // A known offset given back makes the same bag load.
    BagOptions o = options_for(bag);
    o.ins_time_shift_s = -shift;
    EXPECT_EQ(load_bag(o).lidars[0].frames.frames.size(), 30u);
  }
}

// When the record times are copies of the stamps (converted data sets), only the ranges can tell.
TEST(BagDataset, ClockGapFromTheRangesWhenRecordTimesAreTheStamps) {
  const testing::ScratchDir scratch = scratch_dir("clock_copied");
  const fs::path dir = scratch.path();
  BagBuilder b;
  const std::uint32_t points = b.topic("/points", "sensor_msgs/PointCloud2"), odom = b.topic("/odom", "nav_msgs/Odometry");
  for (int k = 0; k < 30; ++k) {
    const double t_end = kT0 + 0.1 * (k + 1);  // Velodyne: the stamp is the sweep end, as the record time
    b.add(points, t_end, encode_message(make_pointcloud2(small_sweep(t_end), DriverLayout::kVelodyne, "lidar"), b.enc()));
  }
  for (int i = 0; i <= 165; ++i) {
    Odometry m;
    m.header = header_at(kFirstInsS + 0.02 * i + 18.0, "odom");
    b.add(odom, m.header.stamp.seconds(), encode_message(m, b.enc()));
  }
  const fs::path bag = b.write(dir / "c.mcap");
  try {
    load_bag(options_for(bag));
    ADD_FAILURE() << "no error";
  } catch (const ClockGapError& e) {
    EXPECT_FALSE(std::isfinite(e.clock().stamp_gap_s));
    ASSERT_TRUE(e.clock().explanation.has_value());
    EXPECT_NEAR(e.clock().explanation->gap_s, 18.0, 1e-6);  // the middles of [0.1, 3.0] and [17.9, 21.2] s
    EXPECT_NE(std::string(e.what()).find("between the middles of the two ranges), close to 18 s: GPS - UTC"), std::string::npos)
        << e.what();
  }
}

TEST(BagDataset, AnInsThatStopsEarlyIsNotAClockError) {
  const testing::ScratchDir scratch = scratch_dir("ins_short");
  const fs::path dir = scratch.path();
  BagBuilder b;
  add_clouds(b, "/points", 30);
  add_ins(b, InsSourceKind::kOdometry, 0.0, 0.85);  // covers 8 of 30 frames; the clocks agree
  const fs::path bag = b.write(dir / "s.mcap");
  const BagDatasets d = load_bag(options_for(bag));
  EXPECT_TRUE(d.report.clock.consistent);
  EXPECT_EQ(d.report.lidars[0].frames_used, 8u);
  BagBuilder none;  // no frame inside at all, clocks still agreeing: an InputError, not a clock error
  add_clouds(none, "/points", 10, DriverLayout::kHesai, kT0 + 5.0);
  add_ins(none, InsSourceKind::kOdometry, 0.0, 2.0);
  const std::string e = error_of([&] { load_bag(options_for(none.write(dir / "n.mcap"))); });
  EXPECT_NE(e.find("no frame of /points (1700000005.100 .. 1700000006.000 s) lies inside the INS time range"),
            std::string::npos) << e;
}

TEST(BagDataset, FramesHangingOverTheInsEndsAreSkippedNotFatal) {
  const testing::ScratchDir scratch = scratch_dir("overhang");
  const fs::path dir = scratch.path();
  BagBuilder b;
  add_clouds(b, "/points", 30);               // 0.1 .. 3.0 s
  add_ins(b, InsSourceKind::kOdometry, 0.0, 2.5);  // -0.1 .. 2.5 s
  const BagDatasets d = load_bag(options_for(b.write(dir / "o.mcap")));
  EXPECT_EQ(d.report.lidars[0].frames_used, 25u);
  EXPECT_EQ(d.report.lidars[0].frames_outside_ins, 5u);
  EXPECT_TRUE(d.report.clock.consistent);
  EXPECT_NEAR(d.report.clock.stamp_gap_s, 0.003, 1e-6);
}

// ------------------------------------------------------------------------------- lazy loading

// Counts whole reads and prefix reads of one topic.
class CountingReader final : public BagReader {
 public:
  CountingReader(std::unique_ptr<BagReader> inner, std::string topic) : inner_(std::move(inner)), topic_(std::move(topic)) {}
  const std::vector<Topic>& topics() const override { return inner_->topics(); }
  std::vector<MessageRef> messages(std::uint32_t t) const override { return inner_->messages(t); }
  std::vector<std::uint8_t> read(const MessageRef& ref) const override {
    if (topics()[ref.topic].name == topic_) ++whole;
    return inner_->read(ref);
  }
  std::vector<std::uint8_t> read_prefix(const MessageRef& ref, std::size_t n) const override {
    if (topics()[ref.topic].name == topic_) ++prefix;
    return inner_->read_prefix(ref, n);
  }
  std::string describe() const override { return inner_->describe(); }
  const std::vector<std::string>& warnings() const override { return inner_->warnings(); }
  std::int64_t start_time_ns() const override { return inner_->start_time_ns(); }
  std::int64_t end_time_ns() const override { return inner_->end_time_ns(); }
  const fs::path& path() const override { return inner_->path(); }
  mutable std::atomic<std::size_t> whole{0}, prefix{0};

 private:
  std::unique_ptr<BagReader> inner_;
  std::string topic_;
};

TEST(BagDataset, CloudsAreDecodedOnlyWhenLoaded) {
  const testing::ScratchDir scratch = scratch_dir("lazy");
  const fs::path dir = scratch.path();
  for (const BagFormat format : {BagFormat::kRos1, BagFormat::kMcap, BagFormat::kDb3}) {
    BagBuilder b(format);
    add_clouds(b, "/points", 40, DriverLayout::kOuster);
    add_ins(b, InsSourceKind::kOdometry, 0.0, 4.2);
    const fs::path bag = b.write(dir / (format == BagFormat::kRos1 ? "l.bag" : format == BagFormat::kMcap ? "l.mcap" : "l"));
    auto reader = std::make_shared<CountingReader>(open_bag(bag), "/points");
    const BagDatasets d = load_bag(reader, options_for(bag));
    EXPECT_EQ(d.report.lidars[0].frames_sampled, 5u);
    EXPECT_EQ(d.counters->clouds_decoded.load(), 5u);
    EXPECT_EQ(reader->whole.load(), 5u);    // the sampled clouds only
    EXPECT_EQ(reader->prefix.load(), 40u);  // every stamp
    const Sweep s = d.lidars[0].frames.load(17);
    EXPECT_EQ(d.counters->clouds_decoded.load(), 6u);
    EXPECT_EQ(reader->whole.load(), 6u);
    EXPECT_EQ(s.name, d.lidars[0].frames.frames[17].name);
    EXPECT_NEAR(s.t_end_s, d.lidars[0].frames.frames[17].t_end_s, 1e-6);
    EXPECT_NEAR(s.t_end_s, kT0 + 1.8, 1e-6);
    EXPECT_EQ(s.size(), 60u);
    EXPECT_EQ(d.report.lidars[0].time_convention, PointTimeConvention::kRelativeNanoseconds);
  }
}

// ROS 1 lz4 chunks are decompressed only as far as a read needs (the INS messages before a cloud):
// every read and prefix, in any order, gives the bytes a read of the whole chunk gives.
TEST(BagDataset, Ros1PartialChunkReadsGiveTheSameBytes) {
  const testing::ScratchDir scratch = scratch_dir("ros1_partial");
  const fs::path dir = scratch.path();
  for (const std::size_t chunk_bytes : {std::size_t{768 * 1024}, std::size_t{2048}}) {
    BagBuilder b(BagFormat::kRos1);
    const std::uint32_t cloud = b.topic("/points", "sensor_msgs/PointCloud2"), odom = b.topic("/odom", "nav_msgs/Odometry");
    for (int k = 0; k < 6; ++k) {
      Sweep s;  // 40k points: 1.9 MB clouds, several LZ4 blocks
      s.t_end_s = kT0 + 0.1 * (k + 1);
      for (int i = 0; i < 40000; ++i) {
        s.p_lidar.emplace_back(std::sin(0.001f * i) * 20.0f, static_cast<float>(i % 97), 0.5f * k);
        s.dt_s.push_back(-0.1f * static_cast<float>(40000 - i) / 40000.0f);
      }
      for (int j = 0; j < 10; ++j) {
        Odometry m;
        m.header = header_at(s.t_end_s - 0.1 + 0.01 * j, "odom");
        m.pose.pose.position = Vec3(j, k, 0.25 * j);
        b.add(odom, s.t_end_s - 0.1 + 0.01 * j + 0.001, encode_message(m, b.enc()));
      }
      b.add(cloud, s.t_end_s + 0.005, encode_message(make_pointcloud2(s, DriverLayout::kHesai, "lidar"), b.enc()));
    }
    const fs::path path = dir / "p.bag";
    {
      std::stable_sort(b.messages_for_test().begin(), b.messages_for_test().end(),
                       [](const auto& x, const auto& y) { return x.log_ns < y.log_ns; });
      WriterOptions wo;
      wo.compression = Compression::kLz4;
      wo.chunk_bytes = chunk_bytes;
      auto w = make_bag_writer(BagFormat::kRos1, path, wo);
      for (const Topic& t : b.topics_for_test()) w->add_topic(t);
      for (const auto& m : b.messages_for_test()) w->write(m.topic, m.log_ns, m.bytes);
      w->close();
    }
    const auto truth = open_bag(path);  // whole messages, in file order
    std::vector<std::pair<MessageRef, std::vector<std::uint8_t>>> all;
    for (std::uint32_t t = 0; t < truth->topics().size(); ++t) {
      for (const MessageRef& ref : truth->messages(t)) all.emplace_back(ref, truth->read(ref));
    }
    const auto partial = open_bag(path);  // prefixes first, then whole messages backwards
    for (const auto& [ref, bytes] : all) {
      const std::vector<std::uint8_t> p = partial->read_prefix(ref, 64);
      ASSERT_EQ(p, std::vector<std::uint8_t>(bytes.begin(), bytes.begin() + std::min<std::size_t>(64, bytes.size())));
    }
    for (auto it = all.rbegin(); it != all.rend(); ++it) ASSERT_EQ(partial->read(it->first), it->second);
    const auto odom_first = open_bag(path);  // INS first (partial chunks), then the clouds
    for (const auto& [ref, bytes] : all) {
      if (odom_first->topics()[ref.topic].name == "/odom") {
        ASSERT_EQ(odom_first->read(ref), bytes);
      }
    }
    for (const auto& [ref, bytes] : all) ASSERT_EQ(odom_first->read(ref), bytes);
  }
}

// The partial LZ4 decoder on frames as liblz4 writes them with small linked blocks and checksums.
TEST(BagDataset, Lz4PrefixesOfLinkedMultiBlockFrames) {
  std::vector<std::uint8_t> content(300000);
  std::uint32_t x = 12345;
  for (std::size_t i = 0; i < content.size(); ++i) {
    x = x * 1664525u + 1013904223u;
    content[i] = static_cast<std::uint8_t>((i % 251 < 200) ? (i / 7) & 0xFF : x >> 24);  // repeats and noise
  }
  LZ4F_preferences_t prefs{};
  prefs.frameInfo.blockSizeID = LZ4F_max64KB;
  prefs.frameInfo.blockMode = LZ4F_blockLinked;
  prefs.frameInfo.contentChecksumFlag = LZ4F_contentChecksumEnabled;
  prefs.frameInfo.blockChecksumFlag = LZ4F_blockChecksumEnabled;
  std::vector<std::uint8_t> frame(LZ4F_compressFrameBound(content.size(), &prefs));
  frame.resize(LZ4F_compressFrame(frame.data(), frame.size(), content.data(), content.size(), &prefs));
  for (const std::size_t wanted : {0, 1, 1000, 65535, 65536, 65537, 200000, 299999, 300000, 400000}) {
    SCOPED_TRACE(wanted);
    const std::size_t n = std::min(wanted, content.size());
    const ByteBuffer expected(content.begin(), content.begin() + static_cast<std::ptrdiff_t>(n));
    EXPECT_EQ(lz4_frame_decompress_prefix(frame.data(), frame.size(), wanted, "f", 0), expected);
    const std::size_t part = std::min(frame.size(), wanted + wanted / 128 + 4096);  // as the ROS 1 reader reads
    EXPECT_EQ(lz4_frame_decompress_prefix(frame.data(), part, wanted, "f", 0), expected);
  }
  std::vector<std::uint8_t> corrupt = frame;
  corrupt[0] ^= 1;
  EXPECT_THROW(lz4_frame_decompress_prefix(corrupt.data(), corrupt.size(), 1000, "f", 7), InputError);
}

// --------------------------------------------------------------------------- geodetic fiducials

TEST(BagDataset, GeodeticFiducialsGoThroughTheInsEnuFrame) {
  const testing::ScratchDir scratch = scratch_dir("fiducials");
  const fs::path dir = scratch.path();
  BagBuilder b;
  add_clouds(b, "/points", 10);
  add_ins(b, InsSourceKind::kInspva, kPi / 2, 1.2);
  const fs::path bag = b.write(dir / "f.mcap");
  const GeodeticPoint f1 = LocalEnu(kOrigin).geodetic(Vec3(12.5, -3.25, -1.5));
  {
    std::ofstream out(dir / "fid.txt");
    out << "# WGS84\n# id lat lon h\nF1 " << fmt::format("{} {} {}", f1.lat_deg, f1.lon_deg, f1.height_m) << "\n";
  }
  BagOptions o = options_for(bag);
  o.fiducials = dir / "fid.txt";
  const BagDatasets d = load_bag(o);
  ASSERT_EQ(d.lidars[0].fiducials.size(), 1u);
  EXPECT_LT((d.lidars[0].fiducials[0].p_world - Vec3(12.5, -3.25, -1.5)).norm(), 1e-6);
  {
    std::ofstream out(dir / "bad.txt");
    out << "# wgs84\nF1 95.0 11.5 5\n";
  }
  o.fiducials = dir / "bad.txt";
  EXPECT_NE(error_of([&] { load_bag(o); }).find("bad.txt:line 2"), std::string::npos);

  BagBuilder cart;  // a cartesian INS cannot place geodetic fiducials
  add_clouds(cart, "/points", 10);
  add_ins(cart, InsSourceKind::kOdometry, 0.0, 1.2);
  BagOptions oc = options_for(cart.write(dir / "c.mcap"));
  oc.fiducials = dir / "fid.txt";
  EXPECT_NE(error_of([&] { load_bag(oc); }).find("need a geodetic INS source"), std::string::npos);
}

TEST(BagDataset, NovatelGpsMsgsNamesReadAsTheOem7Ones) {
  const testing::ScratchDir scratch = scratch_dir("novatel_gps");
  const fs::path dir = scratch.path();
  for (const bool inspvax : {true, false}) {
    BagBuilder b(BagFormat::kRos1);
    add_clouds(b, "/points", 10);
    const std::uint32_t id = b.topic(inspvax ? "/novatel/inspvax" : "/novatel/inspva",
                                     inspvax ? "novatel_gps_msgs/Inspvax" : "novatel_gps_msgs/Inspva");
    const LocalEnu enu(kOrigin);
    for (int i = 0; i <= 70; ++i) {
      const double t = kFirstInsS + 0.02 * i;
      const Iso3 T = T_world_vehicle(t, 0.0) * T_vehicle_novatel();  // driving east: azimuth 90
      const GeodeticPoint p = enu.geodetic(T.translation());
      const AttitudeDeg a = novatel_angles(enu.rotation_at(p).transpose() * T.linear());
      const NovatelAttitude pva{0.0, kSpeed, 0.0, a.roll_deg, a.pitch_deg, a.heading_deg};
      if (inspvax) {
        NovatelGpsInspvax m;
        m.header = header_at(t, "gps");
        m.ins_status = "INS_SOLUTION_GOOD", m.position_type = "INS_RTKFLOAT";
        m.latitude = p.lat_deg, m.longitude = p.lon_deg, m.undulation = 47.5f, m.altitude = p.height_m - 47.5;
        m.pva = pva, m.latitude_std = m.longitude_std = 0.1f, m.altitude_std = 0.2f;
        b.add(id, t + 0.002, encode_message(m, b.enc()));
      } else {
        NovatelGpsInspva m;
        m.header = header_at(t, "gps");
        m.status = "INS_SOLUTION_GOOD";
        m.latitude = p.lat_deg, m.longitude = p.lon_deg, m.height = p.height_m, m.pva = pva;
        b.add(id, t + 0.002, encode_message(m, b.enc()));
      }
    }
    const BagDatasets d = load_bag(options_for(b.write(dir / "g.bag")));
    SCOPED_TRACE(inspvax ? "Inspvax" : "Inspva");
    EXPECT_EQ(d.report.ins.kind, inspvax ? "NovAtel INSPVAX" : "NovAtel INSPVA");
    EXPECT_NEAR(std::abs(d.report.ins.solution_fractions.empty() ? 0.0 : 1.0), inspvax ? 1.0 : 0.0, 1e-12);
    const Iso3 got = d.lidars[0].poses.T_world_ins(kT0 + 1.0);
    expect_near(got, T_world_vehicle(kT0 + 1.0, 0.0) * T_vehicle_novatel(), 1e-6, "novatel_gps_msgs");
    EXPECT_NEAR(got.linear().col(1).x(), 1.0, 1e-9);  // y forward = east
    if (inspvax) {
      EXPECT_EQ(d.lidars[0].ins_quality[5].solution, GnssSolution::kRtkFloat);
    }
  }
}

// ------------------------------------------------------------- recordings the ROS tools wrote

#ifdef INSALIGN_SHARED_DATA_DIR
const fs::path kShared = fs::path(INSALIGN_SHARED_DATA_DIR) / "bags";
#else
const fs::path kShared;
#endif

TEST(BagDataset, RealOdometryBagGivesItsFirstAndLastPoses) {
  const fs::path bag = kShared / "rosbag2" / "autoware-odometry-db3";
  if (kShared.empty() || !fs::exists(bag)) GTEST_SKIP() << "no shared data at " << bag;
  const BagTrajectory t = load_bag_trajectory(options_for(bag));  // no LiDAR topic: the trajectory alone
  EXPECT_EQ(t.report.kind, "Odometry");
  EXPECT_EQ(t.report.records, 2130u);
  EXPECT_EQ(t.report.world_frame_id, "map");
  EXPECT_EQ(t.report.ins_frame_id, "base_link");
  const auto& p = t.poses.poses();
  // The README's times are the record times; header.stamp comes 0.2 ms before each.
  EXPECT_NEAR(p.front().t_s, 1746721937.5996, 1e-3);
  EXPECT_NEAR(p.back().t_s, 1746721990.8246, 1e-3);
  EXPECT_NEAR(t.report.stamp_minus_record_s, -0.0002, 0.0001);
  EXPECT_LT((t.world_origin_m - Vec3(966.5026, 1036.0884, 100.0)).norm(), 1e-4);
  EXPECT_LT((p.back().T_world_ins.translation() + t.world_origin_m - Vec3(1091.8456, 1090.6974, 100.0)).norm(), 1e-4);
  const Eigen::Quaterniond q0(p.front().T_world_ins.linear()), q1(p.back().T_world_ins.linear());
  EXPECT_NEAR(std::abs(q0.dot(Eigen::Quaterniond(0.9999700, 0, 0, 0.0077518))), 1.0, 1e-7);  // 7 digits listed
  EXPECT_NEAR(std::abs(q1.dot(Eigen::Quaterniond(0.7125796, 0, 0, 0.7015913))), 1.0, 1e-7);
  EXPECT_NEAR(t.report.rate_hz, 40.0, 0.1);
  const std::string text = describe_trajectory(t);
  EXPECT_NE(text.find("orientation (x y z w) 0.0000000 0.0000000 0.0077518 0.9999700"), std::string::npos) << text;
  EXPECT_NE(text.find("position 1091.8456 1090.6974 100.0000 m"), std::string::npos) << text;
  EXPECT_NE(error_of([&] { load_bag(options_for(bag)); }).find("no sensor_msgs/PointCloud2"), std::string::npos);
}

TEST(BagDataset, RealTurtlesimTfNeedsTheInsFrame) {
  const fs::path bag = kShared / "ros1" / "example-lz4.bag";
  if (kShared.empty() || !fs::exists(bag)) GTEST_SKIP() << "no shared data at " << bag;
  const std::string e = error_of([&] { load_bag_trajectory(options_for(bag)); });
  EXPECT_NE(e.find("turtle1"), std::string::npos) << e;
  EXPECT_NE(e.find("turtle2"), std::string::npos) << e;
  EXPECT_NE(e.find("--ins-frame"), std::string::npos) << e;
  BagOptions o = options_for(bag);
  o.ins_frame = "turtle1";
  const BagTrajectory t = load_bag_trajectory(o);
  EXPECT_EQ(t.report.kind, "TF");
  EXPECT_EQ(t.report.world_frame_id, "world");
  EXPECT_GT(t.report.records, 1000u);
  const std::string topics = describe_recording(*open_bag(bag));
  for (const char* line : {"/tf  tf/tfMessage  2688 msgs  (INS: TF)", "/turtle1/pose  turtlesim/Pose  1344 msgs  (not read)",
                           "/rosout  rosgraph_msgs/Log  10 msgs  (not read)"}) {
    EXPECT_NE(topics.find(line), std::string::npos) << line << "\n" << topics;
  }
}

// ---------------------------------------------------------------- fixtures the ecosystem wrote

struct FixtureCase {
  const char* file;
  std::vector<std::string> lidar_topics;
  std::vector<std::size_t> frames;               ///< used, per topic
  std::vector<PointTimeConvention> conventions;  ///< per topic
  const char* ins_kind;
  std::size_t ins_records;
};

TEST(BagDataset, EcosystemFixturesLoadAsDatasets) {
  using C = PointTimeConvention;
  const FixtureCase cases[] = {
      {"ros1_hesai_inspva.bag", {}, {3}, {C::kAbsoluteSeconds}, "NovAtel INSPVAX", 36},
      {"ros1_velodyne_navsat_bz2.bag", {"/velodyne_points", "/points_no_time"}, {3, 2}, {C::kRelativeSeconds, C::kNone}, "NavSatFix + Imu", 36},
      {"ros1_ouster_livox_tf_lz4.bag", {"/ouster/points", "/livox/lidar"}, {3, 3}, {C::kRelativeNanoseconds, C::kAbsoluteNanoseconds}, "Odometry", 36},
      {"ros1_killed_recording.bag", {}, {2}, {C::kAbsoluteSeconds}, "NovAtel INSPVAX", 26},
      {"mcap_hesai_ouster_zstd.mcap", {"/hesai/pandar", "/ouster/points"}, {3, 3}, {C::kAbsoluteSeconds, C::kRelativeNanoseconds}, "NovAtel INSPVAX", 36},
      {"mcap_hesai_ouster_lz4.mcap", {"/hesai/pandar", "/ouster/points"}, {3, 3}, {C::kAbsoluteSeconds, C::kRelativeNanoseconds}, "NovAtel INSPVAX", 36},
      {"mcap_truncated.mcap", {"/hesai/pandar"}, {2}, {C::kAbsoluteSeconds}, "NovAtel INSPVAX", 23},
      {"rosbag2_velodyne_split", {}, {4}, {C::kRelativeSeconds}, "NavSatFix + Imu", 46},
      {"rosbag2_humble_no_metadata", {}, {3}, {C::kRelativeSeconds}, "Odometry", 36},
  };
  for (const FixtureCase& c : cases) {
    SCOPED_TRACE(c.file);
    BagOptions o = options_for(kFixtures / c.file);
    o.lidar_topics = c.lidar_topics;
    o.read_cut_off = true;  // ros1_killed_recording.bag ends inside a chunk
    const BagDatasets d = load_bag(o);
    EXPECT_EQ(d.report.ins.kind, c.ins_kind);
    EXPECT_EQ(d.report.ins.records, c.ins_records);
    ASSERT_EQ(d.lidars.size(), c.frames.size());
    for (std::size_t i = 0; i < c.frames.size(); ++i) {
      EXPECT_EQ(d.lidars[i].frames.frames.size(), c.frames[i]) << i;
      EXPECT_EQ(d.report.lidars[i].time_convention, c.conventions[i]) << i;
      // The index times are the sweeps' own (the sampled offset is exact on these fixtures).
      for (std::size_t k = 0; k < d.lidars[i].frames.frames.size(); ++k) {
        EXPECT_NEAR(d.lidars[i].frames.load(k).t_end_s, d.lidars[i].frames.frames[k].t_end_s, 1e-6) << i << " " << k;
      }
    }
    EXPECT_TRUE(d.report.clock.consistent);
    EXPECT_NEAR(d.report.clock.stamp_gap_s, 0.003, 0.0015);  // INS recorded 2 ms after its stamp, clouds 5 ms
  }
}

TEST(BagDataset, FixtureValuesAsTheReadmeLists) {
  BagOptions o = options_for(kFixtures / "ros1_ouster_livox_tf_lz4.bag");
  o.lidar_topics = {"/ouster/points"};
  const BagDatasets odom = load_bag(o);  // Odometry odom -> base_link: first and last positions
  const auto& poses = odom.lidars[0].poses.poses();
  EXPECT_LT((odom.lidars[0].world_origin_m - Vec3(9.94, 19.92, 0.499)).norm(), 1e-9);
  EXPECT_LT((poses.back().T_world_ins.translation() - Vec3(10.99 - 9.94, 21.32 - 19.92, 0.5165 - 0.499)).norm(), 1e-9);
  EXPECT_NEAR(poses.front().t_s, 1699999999.98, 1e-6);
  EXPECT_NEAR(poses.back().t_s, 1700000000.33, 1e-6);
  EXPECT_EQ(odom.report.ins.ins_frame_id, "base_link");
  EXPECT_EQ(odom.report.ins.world_frame_id, "odom");

  // /pose holds base_link in map (README): the obvious TF chain map -> odom -> base_link; with
  // --ins-frame gnss the chain goes on through /tf_static's base_link -> gnss.
  o.ins_topic = "/pose";
  const BagDatasets pose = load_bag(o);
  o.ins_topic = "/tf";
  const BagDatasets tf = load_bag(o);
  o.ins_frame = "gnss";
  const BagDatasets gnss = load_bag(o);
  const Iso3 T_base_gnss = make_transform(Vec3(0.45, -0.1, 1.35), Vec3(0, 0, -90));
  const auto at = [](const BagDatasets& d, double t) {
    Iso3 T = d.lidars[0].poses.T_world_ins(t);
    T.translation() += d.lidars[0].world_origin_m;
    return T;
  };
  for (const double t : {1700000000.0, 1700000000.2, 1700000000.33}) {
    expect_near(at(tf, t), at(pose, t), 1e-6, "tf vs pose");
    expect_near(at(gnss, t), at(pose, t) * T_base_gnss, 1e-6, "tf to gnss vs pose");
  }
  EXPECT_EQ(tf.report.ins.world_frame_id, "map");
  EXPECT_NE(describe_bag(gnss.report).find("map -> odom -> base_link -> gnss (static)"), std::string::npos);

  BagOptions co = options_for(kFixtures / "mcap_corrupt_chunk.mcap");
  co.lidar_topics = {"/ouster/points"};
  const std::string corrupt = error_of([&] { load_bag(co); });
  EXPECT_NE(corrupt.find("mcap_corrupt_chunk.mcap:byte 24136"), std::string::npos) << corrupt;
  EXPECT_NE(corrupt.find("CRC"), std::string::npos) << corrupt;

  BagOptions killed = options_for(kFixtures / "ros1_killed_recording.bag");
  const std::string cut = error_of([&] { load_bag(killed); });
  EXPECT_NE(cut.find("ros1_killed_recording.bag:byte 100305: cut off mid-chunk"), std::string::npos) << cut;
  killed.read_cut_off = true;
  const BagDatasets k = load_bag(killed);
  EXPECT_NE(k.report.warnings.front().find("101690"), std::string::npos) << k.report.warnings.front();
}

}  // namespace
}  // namespace insalign::io
