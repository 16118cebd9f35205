#include "sim/export/sim_bag_export.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <limits>
#include <stdexcept>
#include <thread>
#include <tuple>
#include <utility>

#include "core/errors.hpp"
#include "files/atomic_file.hpp"
#include "recording/message_definitions.hpp"
#include "recording/messages.hpp"
#include "recording/pointcloud2.hpp"
#include "recording/bag_topics.hpp"
#include "files/extrinsic_json.hpp"
#include "files/fiducials.hpp"
#include "inslog/attitude.hpp"
#include "inslog/gps_time.hpp"

namespace insalign::cli {

namespace {

namespace fs = std::filesystem;
using namespace io::bag;

constexpr std::int64_t kInsLatencyNs = 2'000'000;    // record time = INS stamp + 2 ms
constexpr std::int64_t kCloudLatencyNs = 5'000'000;  // record time = sweep end + 5 ms
constexpr float kUndulationM = 47.5f;                 // INSPVAX: height above mean sea level + this

std::int64_t to_ns(double t_s) { return std::llround(t_s * 1e9); }

Topic make_topic(const std::string& name, const std::string& type, MessageEncoding enc) {
  const MessageDefinition* def = builtin_definition(type);
  if (def == nullptr) throw std::logic_error("no built-in definition of " + type);
  const bool ros1 = enc == MessageEncoding::kRos1;
  return {name, ros1 ? def->type : def->ros2_type, enc, ros1 ? def->ros1_text : def->ros2_text,
          ros1 ? "ros1msg" : "ros2msg", ros1 ? def->ros1_md5 : "", 0};
}

// Stamp::from_seconds splits off the whole seconds first: the stamp reads back as the same double
// (t * 1e9 near 1.7e18 would round to 256 ns).
Header header_at(double t_s, const std::string& frame_id, std::uint32_t seq = 0) {
  return {seq, Stamp::from_seconds(t_s), frame_id};
}

DriverLayout driver_layout(LidarConvention c) {
  switch (c) {
    case LidarConvention::kHesai: return DriverLayout::kHesai;
    case LidarConvention::kVelodyne: return DriverLayout::kVelodyne;
    case LidarConvention::kOuster: return DriverLayout::kOuster;
    case LidarConvention::kNone: return DriverLayout::kNoTime;
  }
  return DriverLayout::kNoTime;
}

const char* driver_topic(LidarConvention c) {
  switch (c) {
    case LidarConvention::kHesai: return "/hesai/pandar";
    case LidarConvention::kVelodyne: return "/velodyne_points";
    case LidarConvention::kOuster: return "/ouster/points";
    case LidarConvention::kNone: return "/points";
  }
  return "/points";
}

// A cloud as the driver publishes it. With absolute or no per-point times the stamp only dates the
// frame: set exactly (make_pointcloud2 rounds it through nanoseconds near 1.7e18).
PointCloud2 driver_cloud(const Sweep& sweep, LidarConvention c, const std::string& frame_id) {
  PointCloud2 cloud = make_pointcloud2(sweep, driver_layout(c), frame_id);
  if (c == LidarConvention::kHesai && sweep.has_time()) {
    cloud.header.stamp = Stamp::from_seconds(sweep.t_end_s + *std::min_element(sweep.dt_s.begin(), sweep.dt_s.end()));
  } else if (c == LidarConvention::kNone) {
    cloud.header.stamp = Stamp::from_seconds(sweep.t_end_s);
  }
  return cloud;
}

std::uint32_t novatel_pos_type(GnssSolution s) {
  switch (s) {
    case GnssSolution::kRtkFixed: return 56;      // INS_RTKFIXED
    case GnssSolution::kRtkFloat: return 55;      // INS_RTKFLOAT
    case GnssSolution::kDifferential: return 54;  // INS_PSRDIFF
    case GnssSolution::kSingle: return 53;        // INS_PSRSP
    case GnssSolution::kInsOnly: return 19;       // PROPAGATED
    case GnssSolution::kInvalid: return 0;        // NONE
    case GnssSolution::kUnknown: break;
  }
  return 70;  // OPERATIONAL: no accuracy class
}

std::int8_t navsat_status(GnssSolution s) {
  switch (s) {
    case GnssSolution::kRtkFixed:
    case GnssSolution::kRtkFloat:
    case GnssSolution::kDifferential: return NavSatFix::kGbasFix;
    case GnssSolution::kInvalid: return NavSatFix::kNoFix;
    default: return NavSatFix::kFix;
  }
}

/// One INS sample as every message type needs it.
struct InsSample {
  double t_s = 0.0;
  Iso3 T_world_ins = Iso3::Identity();  ///< the message's ins frame in the simulator's world
  Vec3 v_world_mps = Vec3::Zero();
  InsQuality quality;
};

struct Message {
  std::uint32_t topic = 0;
  std::int64_t log_ns = 0;
  std::vector<std::uint8_t> bytes;
};

// The INS topics of a message kind, added to the bag: their ids (the second 0 when there is one).
std::pair<std::uint32_t, std::uint32_t> add_ins_topics(BagWriter& w, InsMessage kind, MessageEncoding enc) {
  const auto add = [&](const char* topic, const char* type) { return w.add_topic(make_topic(topic, type, enc)); };
  switch (kind) {
    case InsMessage::kInspva:
      return {add("/novatel/oem7/inspva", "novatel_oem7_msgs/INSPVA"), add("/novatel/oem7/inspvax", "novatel_oem7_msgs/INSPVAX")};
    case InsMessage::kNavSatFixImu: return {add("/gps/fix", "sensor_msgs/NavSatFix"), add("/imu/data", "sensor_msgs/Imu")};
    case InsMessage::kOdometry: return {add("/odom", "nav_msgs/Odometry"), 0};
    case InsMessage::kTf: return {add("/tf", "tf2_msgs/TFMessage"), add("/tf_static", "tf2_msgs/TFMessage")};
  }
  return {0, 0};
}

// Writes the INS topics; geodetic messages through `enu` (tangent at the first pose).
class InsWriter {
 public:
  InsWriter(BagWriter& w, InsMessage kind, MessageEncoding enc, const insalign::LocalEnu& enu, const Vec3& p_first)
      : kind_(kind), enc_(enc), enu_(enu), p_first_(p_first) {
    std::tie(a_, b_) = add_ins_topics(w, kind, enc);
  }

  std::vector<Message> messages(const InsSample& s, std::uint32_t seq) const {
    const std::int64_t log = to_ns(s.t_s) + kInsLatencyNs;
    switch (kind_) {
      case InsMessage::kInspva: return novatel(s, seq, log);
      case InsMessage::kNavSatFixImu: return navsat(s, seq, log);
      case InsMessage::kOdometry: return {{a_, log, encode_message(odometry(s, seq), enc_)}};
      case InsMessage::kTf: return tf(s, seq, log);
    }
    return {};
  }
  std::size_t per_sample() const { return kind_ == InsMessage::kOdometry || kind_ == InsMessage::kTf ? 1 : 2; }

 private:
  static constexpr const char* kWorld = "map";
  static Iso3 T_map_odom() { return make_transform(Vec3(100.0, 200.0, 0.0), Vec3(0.0, 0.0, 5.0)); }

  // Position and orientation as geodetic messages carry them (orientation in the ENU frame at the
  // sample's own position).
  std::pair<insalign::GeodeticPoint, Mat3> geodetic(const InsSample& s) const {
    const insalign::GeodeticPoint p = enu_.geodetic(s.T_world_ins.translation() - p_first_);
    return {p, enu_.rotation_at(p).transpose() * s.T_world_ins.linear()};
  }

  std::vector<Message> novatel(const InsSample& s, std::uint32_t seq, std::int64_t log) const {
    const auto [p, R_enu_ins] = geodetic(s);
    const io::AttitudeDeg a = io::novatel_angles(R_enu_ins);
    const io::GpsWeekSeconds gps = io::unix_to_gps(s.t_s);
    Oem7Header nov;
    nov.sequence_number = seq;
    nov.gps_week_number = static_cast<std::uint16_t>(gps.week);
    nov.gps_week_milliseconds = static_cast<std::uint32_t>(std::llround(gps.seconds_of_week * 1e3));
    nov.time_status = 180;  // FINESTEERING
    nov.layout = builtin_oem7_layout(enc_);
    const NovatelAttitude pva{s.v_world_mps.y(), s.v_world_mps.x(), s.v_world_mps.z(), a.roll_deg, a.pitch_deg, a.heading_deg};
    Oem7Inspva inspva;
    inspva.header = header_at(s.t_s, "novatel", seq);
    inspva.nov_header = nov;
    inspva.nov_header.message_name = "INSPVA";
    inspva.latitude = p.lat_deg, inspva.longitude = p.lon_deg, inspva.height = p.height_m;
    inspva.pva = pva;
    inspva.status = 3;  // INS_SOLUTION_GOOD
    Oem7Inspvax x;
    x.header = inspva.header;
    x.nov_header = nov;
    x.nov_header.message_name = "INSPVAX";
    x.ins_status = 3;
    x.pos_type = novatel_pos_type(s.quality.solution);
    x.latitude = p.lat_deg, x.longitude = p.lon_deg, x.height = p.height_m - static_cast<double>(kUndulationM);
    x.undulation = kUndulationM;
    x.pva = pva;
    const float h = static_cast<float>(s.quality.horizontal_stddev_m / std::sqrt(2.0));
    x.latitude_stdev = x.longitude_stdev = h;
    x.height_stdev = static_cast<float>(s.quality.vertical_stddev_m);
    return {{a_, log, encode_message(inspva, enc_)}, {b_, log, encode_message(x, enc_)}};
  }

  std::vector<Message> navsat(const InsSample& s, std::uint32_t seq, std::int64_t log) const {
    const auto [p, R_enu_ins] = geodetic(s);
    NavSatFix fix;
    fix.header = header_at(s.t_s, "imu_link", seq);
    fix.status = navsat_status(s.quality.solution);
    fix.service = 1;  // GPS
    fix.latitude = p.lat_deg, fix.longitude = p.lon_deg, fix.altitude = p.height_m;
    const double h2 = std::pow(s.quality.horizontal_stddev_m, 2) / 2.0, v2 = std::pow(s.quality.vertical_stddev_m, 2);
    fix.position_covariance = {h2, 0, 0, 0, h2, 0, 0, 0, v2};
    fix.position_covariance_type = NavSatFix::kDiagonalKnown;
    Imu imu;
    imu.header = fix.header;
    imu.orientation = quaternion_from(R_enu_ins);
    imu.orientation_covariance = {1e-6, 0, 0, 0, 1e-6, 0, 0, 0, 1e-6};
    return {{a_, log, encode_message(fix, enc_)}, {b_, log, encode_message(imu, enc_)}};
  }

  Odometry odometry(const InsSample& s, std::uint32_t seq) const {
    Odometry o;
    o.header = header_at(s.t_s, "odom", seq);
    o.child_frame_id = "base_link";
    o.pose.pose = {s.T_world_ins.translation(), quaternion_from(s.T_world_ins.linear())};
    const double h2 = std::pow(s.quality.horizontal_stddev_m, 2) / 2.0, v2 = std::pow(s.quality.vertical_stddev_m, 2);
    o.pose.covariance[0] = o.pose.covariance[7] = h2;
    o.pose.covariance[14] = v2;
    o.twist.linear = s.T_world_ins.linear().transpose() * s.v_world_mps;
    return o;
  }

  std::vector<Message> tf(const InsSample& s, std::uint32_t seq, std::int64_t log) const {
    std::vector<Message> out;
    if (seq == 0) {  // the static transform once, first (a latched topic)
      const Iso3 T_base_imu = make_transform(Vec3(0.1, 0.0, 0.05), Vec3(0.0, 0.0, 0.0));
      TFMessage fixed{{{header_at(s.t_s, "base_link"), "imu_link", T_base_imu.translation(), quaternion_from(T_base_imu.linear())}}};
      out.push_back({b_, log, encode_message(fixed, enc_)});
    }
    const Iso3 T_odom_base = T_map_odom().inverse() * s.T_world_ins;
    TFMessage m{{{header_at(s.t_s, kWorld, seq), "odom", T_map_odom().translation(), quaternion_from(T_map_odom().linear())},
                 {header_at(s.t_s, "odom", seq), "base_link", T_odom_base.translation(), quaternion_from(T_odom_base.linear())}}};
    out.push_back({a_, log, encode_message(m, enc_)});
    return out;
  }

  InsMessage kind_;
  MessageEncoding enc_;
  const insalign::LocalEnu& enu_;
  Vec3 p_first_;
  std::uint32_t a_ = 0, b_ = 0;
};

std::vector<InsSample> ins_samples(const sim::World& world, const SimBagOptions& o) {
  const std::vector<StampedPose> poses = sim::dense_reported_poses(world, o.ins_rate_hz);
  if (poses.size() < 2) throw std::invalid_argument("the simulated drive is too short for an INS track");
  const Iso3 T_sim_msg = T_sim_ins_message(world, o.ins_message);
  std::vector<InsSample> out(poses.size());
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const std::size_t a = i == 0 ? 0 : i - 1, b = std::min(poses.size() - 1, i + 1);
    out[i].t_s = poses[i].t_s;
    out[i].T_world_ins = poses[i].T_world_ins * T_sim_msg;
    out[i].v_world_mps = (poses[b].T_world_ins.translation() - poses[a].T_world_ins.translation()) / (poses[b].t_s - poses[a].t_s);
    out[i].quality = sim::ins_quality(world, poses[i].t_s);
  }
  return out;
}

struct CloudEvent {
  std::size_t lidar = 0, frame = 0;
  std::int64_t log_ns = 0;
};

std::vector<CloudEvent> cloud_events(const sim::World& world) {
  std::vector<CloudEvent> out;
  for (std::size_t j = 0; j < world.lidars.size(); ++j) {
    const sim::SimLidar& l = world.lidars[j];
    for (std::size_t k = 0; k < l.frame_times_s.size(); ++k) {
      // The recorder's clock is the INS's: a sweep arrives 5 ms after it ends.
      out.push_back({j, k, to_ns(l.frame_times_s[k] + l.time_offset_s) + kCloudLatencyNs});
    }
  }
  std::stable_sort(out.begin(), out.end(), [](const CloudEvent& a, const CloudEvent& b) { return a.log_ns < b.log_ns; });
  return out;
}

std::string lidar_topic(const sim::World& world, std::size_t j, LidarConvention c) {
  return world.lidars.size() == 1 ? driver_topic(c) : "/" + world.lidars[j].name;
}

io::bag::Compression default_compression(BagFormat f) {
  return f == BagFormat::kRos1 ? Compression::kLz4 : f == BagFormat::kMcap ? Compression::kZstd : Compression::kNone;
}

// Renders batches of sweeps in parallel and writes them, with the INS messages due before each,
// in record-time order.
void write_messages(const sim::World& world, const SimBagOptions& o, BagWriter& writer, const insalign::LocalEnu& enu,
                    SimBagResult& result, const SimBagProgress& progress) {
  const MessageEncoding enc = o.format == BagFormat::kRos1 ? MessageEncoding::kRos1 : MessageEncoding::kCdr;
  const std::vector<InsSample> ins = ins_samples(world, o);
  const InsWriter ins_writer(writer, o.ins_message, enc, enu, ins.front().T_world_ins.translation());
  std::vector<std::uint32_t> cloud_topic;
  for (std::size_t j = 0; j < world.lidars.size(); ++j) {
    cloud_topic.push_back(writer.add_topic(make_topic(lidar_topic(world, j, o.lidar_convention), "sensor_msgs/PointCloud2", enc)));
  }
  const std::vector<CloudEvent> clouds = cloud_events(world);
  const std::size_t batch = 2 * std::max(1u, std::thread::hardware_concurrency());
  std::size_t next_ins = 0;
  const auto write_ins_until = [&](std::int64_t log_ns) {
    for (; next_ins < ins.size() && to_ns(ins[next_ins].t_s) + kInsLatencyNs <= log_ns; ++next_ins) {
      for (const Message& m : ins_writer.messages(ins[next_ins], static_cast<std::uint32_t>(next_ins))) {
        writer.write(m.topic, m.log_ns, m.bytes);
        ++result.ins_messages;
      }
    }
  };
  for (std::size_t begin = 0; begin < clouds.size(); begin += batch) {
    const std::size_t end = std::min(clouds.size(), begin + batch);
    std::vector<std::vector<std::uint8_t>> encoded(end - begin);
    std::vector<std::size_t> points(end - begin);
    tbb::parallel_for(begin, end, [&](std::size_t e) {
      const CloudEvent& c = clouds[e];
      const Sweep sweep = sim::render_lidar_sweep(world, c.lidar, c.frame);
      const std::string frame_id = world.lidars.size() == 1 ? "lidar" : world.lidars[c.lidar].name;
      encoded[e - begin] = encode_message(driver_cloud(sweep, o.lidar_convention, frame_id), enc);
      points[e - begin] = sweep.size();
    });
    for (std::size_t e = begin; e < end; ++e) {
      write_ins_until(clouds[e].log_ns);
      writer.write(cloud_topic[clouds[e].lidar], clouds[e].log_ns, encoded[e - begin]);
      result.points += points[e - begin];
      ++result.frames;
      if (progress) progress(result.frames, clouds.size());
    }
  }
  write_ins_until(std::numeric_limits<std::int64_t>::max());
}

nlohmann::json bag_ground_truth(const sim::World& world, const SimBagOptions& o, const SimBagResult& r,
                                const insalign::LocalEnu& enu, const Iso3& T_msg_sim) {
  nlohmann::json j = o.ground_truth.is_object() ? o.ground_truth : nlohmann::json::object();
  const Iso3 T = T_msg_sim * world.T_ins_lidar_true;
  const Eigen::Quaterniond q(T.linear());
  const Vec3 rpy = rpy_from_rotation(T.linear()) * kDegPerRad;
  j["T_ins_lidar"] = io::transform_to_json(T);
  j["translation_m"] = {T.translation().x(), T.translation().y(), T.translation().z()};
  j["rpy_deg"] = {rpy.x(), rpy.y(), rpy.z()};
  j["quaternion_wxyz"] = {q.w(), q.x(), q.y(), q.z()};
  j["T_ins_lidar_init"] = io::transform_to_json(T_msg_sim * world.T_ins_lidar_init);
  if (!j.contains("time_offset_s")) j["time_offset_s"] = world.config.time_offset_s;
  j["frames"] = r.frames;
  j["points"] = r.points;
  // Every LiDAR by its name (CONVENTIONS "Rigs": the topic's), in the message's ins frame.
  nlohmann::json lidars = nlohmann::json::object();
  for (std::size_t k = 0; k < world.lidars.size(); ++k) {
    const sim::SimLidar& l = world.lidars[k];
    const std::string topic = lidar_topic(world, k, o.lidar_convention);
    const Iso3 T_l = T_msg_sim * l.T_ins_lidar_true;
    const Vec3 rpy_l = rpy_from_rotation(T_l.linear()) * kDegPerRad;
    lidars[io::lidar_name(topic)] = {{"topic", topic},
                                    {"T_ins_lidar", io::transform_to_json(T_l)},
                                    {"translation_m", {T_l.translation().x(), T_l.translation().y(), T_l.translation().z()}},
                                    {"rpy_deg", {rpy_l.x(), rpy_l.y(), rpy_l.z()}},
                                    {"time_offset_s", l.time_offset_s},
                                    {"model", l.model.name},
                                    {"frames", l.frame_times_s.size()},
                                    {"T_ins_lidar_init", io::transform_to_json(T_msg_sim * l.T_ins_lidar_init)}};
  }
  if (world.lidars.size() > 1) j["lidars"] = lidars;
  const char* formats[] = {"ros1", "mcap", "db3"};
  j["bag"] = {{"file", r.bag.filename().string()},
              {"format", formats[static_cast<int>(o.format)]},
              {"lidar_convention", lidar_convention_name(o.lidar_convention)},
              {"ins_message", ins_message_name(o.ins_message)},
              {"ins_frame", r.ins_frame},
              {"ins_rate_hz", o.ins_rate_hz},
              {"lidars", lidars}};
  if (o.ins_message == InsMessage::kInspva || o.ins_message == InsMessage::kNavSatFixImu) {
    j["bag"]["enu_origin_deg_deg_m"] = {enu.origin().lat_deg, enu.origin().lon_deg, enu.origin().height_m};
  }
  return j;
}

}  // namespace

Iso3 T_sim_ins_message(const sim::World& world, InsMessage message) {
  if (message != InsMessage::kInspva) return Iso3::Identity();
  Iso3 T_vehicle_novatel = Iso3::Identity();  // x right, y forward, z up in the vehicle's x forward, y left, z up
  T_vehicle_novatel.linear() << 0, 1, 0,  //
      -1, 0, 0,                          //
      0, 0, 1;
  return world.T_vehicle_ins.inverse() * T_vehicle_novatel;
}

fs::path sim_bag_path(const fs::path& out_dir, BagFormat format, const std::string& name) {
  switch (format) {
    case BagFormat::kRos1: return out_dir / (name + ".bag");
    case BagFormat::kMcap: return out_dir / (name + ".mcap");
    case BagFormat::kDb3: return out_dir / name;
  }
  return out_dir / name;
}

SimBagResult write_sim_bag(const sim::World& world, const SimBagOptions& o, const fs::path& out_dir,
                           const SimBagProgress& progress) {
  io::ensure_writable_dir(out_dir);
  SimBagResult result;
  result.bag = sim_bag_path(out_dir, o.format, o.name);
  const Iso3 T_sim_msg = T_sim_ins_message(world, o.ins_message);
  result.T_ins_lidar = T_sim_msg.inverse() * world.T_ins_lidar_true;
  result.ins_frame = o.ins_message == InsMessage::kInspva ? "NovAtel SPAN vehicle frame (x right, y forward, z up)"
                     : o.ins_message == InsMessage::kNavSatFixImu ? "the Imu frame 'imu_link' (the simulator's INS frame)"
                     : o.ins_message == InsMessage::kOdometry     ? "the Odometry child frame 'base_link' (the simulator's INS frame)"
                                                                  : "TF frame 'base_link' (the simulator's INS frame)";
  const insalign::LocalEnu enu(o.origin);
  {
    WriterOptions wo;
    wo.compression = o.compression.value_or(default_compression(o.format));
    const std::unique_ptr<BagWriter> writer = make_bag_writer(o.format, result.bag, wo);
    write_messages(world, o, *writer, enu, result, progress);
    writer->close();
  }
  // Side files as for a PCD folder, in the message's ins frame.
  const Iso3 T_msg_sim = T_sim_msg.inverse();
  io::write_opencalib_extrinsic(out_dir / "init-extrinsic.json", T_msg_sim * world.T_ins_lidar_init);
  for (std::size_t k = 0; world.lidars.size() > 1 && k < world.lidars.size(); ++k) {  // a rig: one per LiDAR
    const std::string name = io::lidar_name(lidar_topic(world, k, o.lidar_convention));
    io::write_opencalib_extrinsic(out_dir / ("init-extrinsic-" + name + ".json"), T_msg_sim * world.lidars[k].T_ins_lidar_init);
  }
  const bool geodetic = o.ins_message == InsMessage::kInspva || o.ins_message == InsMessage::kNavSatFixImu;
  const Vec3 p_first = (sim::dense_reported_poses(world, o.ins_rate_hz).front().T_world_ins * T_sim_msg).translation();
  if (geodetic) {
    io::write_geodetic_fiducials(out_dir / "fiducials.txt", world.fiducials, enu, -p_first);
  } else {
    io::write_fiducials(out_dir / "fiducials.txt", world.fiducials);
  }
  io::write_file_atomic(out_dir / "ground_truth.json", bag_ground_truth(world, o, result, enu, T_msg_sim).dump(2) + "\n");
  return result;
}

std::optional<BagFormat> parse_bag_format(std::string_view name) {
  if (name == "ros1") return BagFormat::kRos1;
  if (name == "mcap") return BagFormat::kMcap;
  if (name == "db3") return BagFormat::kDb3;
  return std::nullopt;
}

std::optional<LidarConvention> parse_lidar_convention(std::string_view name) {
  for (LidarConvention c : {LidarConvention::kHesai, LidarConvention::kVelodyne, LidarConvention::kOuster, LidarConvention::kNone}) {
    if (name == lidar_convention_name(c)) return c;
  }
  return std::nullopt;
}

std::optional<InsMessage> parse_ins_message(std::string_view name) {
  for (InsMessage m : {InsMessage::kInspva, InsMessage::kNavSatFixImu, InsMessage::kOdometry, InsMessage::kTf}) {
    if (name == ins_message_name(m)) return m;
  }
  return std::nullopt;
}

const char* lidar_convention_name(LidarConvention c) {
  switch (c) {
    case LidarConvention::kHesai: return "hesai";
    case LidarConvention::kVelodyne: return "velodyne";
    case LidarConvention::kOuster: return "ouster";
    case LidarConvention::kNone: return "none";
  }
  return "?";
}

const char* ins_message_name(InsMessage m) {
  switch (m) {
    case InsMessage::kInspva: return "inspva";
    case InsMessage::kNavSatFixImu: return "navsatfix-imu";
    case InsMessage::kOdometry: return "odometry";
    case InsMessage::kTf: return "tf";
  }
  return "?";
}

}  // namespace insalign::cli
