#include "recording/messages.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <limits>

#include "core/errors.hpp"
#include "inslog/attitude.hpp"

namespace insalign::io::bag {

namespace {

// One field list per message serves both directions: `In` reads into the struct, `Out` writes
// from it, so encode and decode cannot drift apart.
struct In {
  MessageReader& r;
  bool cdr() const { return r.cdr(); }
  template <typename T>
  void num(T& v, const char* name) { v = r.read<T>(name); }
  void boolean(bool& v, const char* name) { v = r.read_bool(name); }
  void str(std::string& v, const char* name) { v = r.read_string(name); }
  void time(Stamp& v, const char* name) { v = r.read_time(name); }
  template <typename T, std::size_t N>
  void arr(std::array<T, N>& v, const char* name) { r.read_array(v, name); }
  void vec3(Vec3& v, const char* name) {
    for (int i = 0; i < 3; ++i) v[i] = r.read<double>(name);
  }
  template <typename V, typename F>
  void seq(V& v, std::size_t min_element_bytes, const char* name, F&& element) {
    v.resize(r.read_length(name, min_element_bytes));
    for (auto& e : v) element(e);
  }
};

struct Out {
  MessageWriter& w;
  bool cdr() const { return w.cdr(); }
  template <typename T>
  void num(const T& v, const char*) { w.write<T>(v); }
  void boolean(bool v, const char*) { w.write_bool(v); }
  void str(const std::string& v, const char*) { w.write_string(v); }
  void time(const Stamp& v, const char*) { w.write_time(v); }
  template <typename T, std::size_t N>
  void arr(const std::array<T, N>& v, const char*) { w.write_array(v); }
  void vec3(const Vec3& v, const char*) {
    for (int i = 0; i < 3; ++i) w.write<double>(v[i]);
  }
  template <typename V, typename F>
  void seq(V& v, std::size_t, const char*, F&& element) {
    w.write_length(v.size());
    for (auto& e : v) element(e);
  }
};

// M is the message type, const when writing.
template <typename IO, typename M>
void io_header(IO& io, M& h) {
  if (!io.cdr()) io.num(h.seq, "header.seq");  // ROS 2 has no seq
  io.time(h.stamp, "header.stamp");
  io.str(h.frame_id, "header.frame_id");
}

template <typename IO, typename M>
void io_quaternion(IO& io, M& q, const char* name) {
  io.num(q.x, name), io.num(q.y, name), io.num(q.z, name), io.num(q.w, name);
}

template <typename IO, typename M>
void io_pose(IO& io, M& p) {
  io.vec3(p.position, "pose.position");
  io_quaternion(io, p.orientation, "pose.orientation");
}

template <typename IO, typename M>
void io_pose_with_covariance(IO& io, M& p) {
  io_pose(io, p.pose);
  io.arr(p.covariance, "pose.covariance");
}

template <typename IO, typename M>
void io_transform_stamped(IO& io, M& tf) {
  io_header(io, tf.header);
  io.str(tf.child_frame_id, "child_frame_id");
  io.vec3(tf.translation, "transform.translation");
  io_quaternion(io, tf.rotation, "transform.rotation");
}

template <typename IO, typename M>
void io_odometry(IO& io, M& m) {
  io_header(io, m.header);
  io.str(m.child_frame_id, "child_frame_id");
  io_pose_with_covariance(io, m.pose);
  io.vec3(m.twist.linear, "twist.linear");
  io.vec3(m.twist.angular, "twist.angular");
  io.arr(m.twist.covariance, "twist.covariance");
}

template <typename IO, typename M>
void io_navsatfix(IO& io, M& m) {
  io_header(io, m.header);
  io.num(m.status, "status.status");
  io.num(m.service, "status.service");
  io.num(m.latitude, "latitude"), io.num(m.longitude, "longitude"), io.num(m.altitude, "altitude");
  io.arr(m.position_covariance, "position_covariance");
  io.num(m.position_covariance_type, "position_covariance_type");
}

template <typename IO, typename M>
void io_imu(IO& io, M& m) {
  io_header(io, m.header);
  io_quaternion(io, m.orientation, "orientation");
  io.arr(m.orientation_covariance, "orientation_covariance");
  io.vec3(m.angular_velocity, "angular_velocity");
  io.arr(m.angular_velocity_covariance, "angular_velocity_covariance");
  io.vec3(m.linear_acceleration, "linear_acceleration");
  io.arr(m.linear_acceleration_covariance, "linear_acceleration_covariance");
}

template <typename IO, typename M>
void io_point_field(IO& io, M& f) {
  io.str(f.name, "fields[].name");
  io.num(f.offset, "fields[].offset");
  io.num(f.datatype, "fields[].datatype");
  io.num(f.count, "fields[].count");
}

// Everything of a PointCloud2 before its data, then (io_pointcloud2_tail) everything after.
template <typename IO, typename M>
void io_pointcloud2_head(IO& io, M& m) {
  io_header(io, m.header);
  io.num(m.height, "height");
  io.num(m.width, "width");
  // A PointField is at least 4 + 4 + 1 + 4 bytes (ROS 1) or 13 (CDR, empty name).
  io.seq(m.fields, 13, "fields", [&](auto& f) { io_point_field(io, f); });
  io.boolean(m.is_bigendian, "is_bigendian");
  io.num(m.point_step, "point_step");
  io.num(m.row_step, "row_step");
}

template <typename IO, typename M>
void io_attitude(IO& io, M& a) {
  io.num(a.north_velocity, "north_velocity"), io.num(a.east_velocity, "east_velocity");
  io.num(a.up_velocity, "up_velocity");
  io.num(a.roll, "roll"), io.num(a.pitch, "pitch"), io.num(a.azimuth, "azimuth");
}

template <typename T, typename F>
std::vector<std::uint8_t> encode_with(const T& msg, MessageEncoding encoding, F&& fields) {
  MessageWriter w(encoding);
  Out out{w};
  fields(out, msg);
  return w.take();
}

template <typename T, typename F>
T decode_with(Bytes bytes, MessageEncoding encoding, const std::string& where, const char* type, F&& fields) {
  MessageReader r(bytes, encoding, where, type);
  In in{r};
  T msg;
  fields(in, msg);
  r.expect_end();
  return msg;
}

}  // namespace

Header read_header(MessageReader& in) {
  Header h;
  In io{in};
  io_header(io, h);
  return h;
}

void write_header(MessageWriter& out, const Header& header) {
  Out io{out};
  io_header(io, header);
}

std::size_t point_field_size(std::uint8_t datatype) {
  switch (datatype) {
    case PointField::kInt8: case PointField::kUint8: return 1;
    case PointField::kInt16: case PointField::kUint16: return 2;
    case PointField::kInt32: case PointField::kUint32: case PointField::kFloat32: return 4;
    case PointField::kFloat64: return 8;
    default: return 0;
  }
}

std::string point_field_type_name(std::uint8_t datatype) {
  static const char* const kNames[] = {"int8", "uint8", "int16", "uint16", "int32", "uint32", "float32", "float64"};
  if (datatype >= 1 && datatype <= 8) return kNames[datatype - 1];
  return "datatype " + std::to_string(datatype);
}

// ------------------------------------------------------------------------------ decode / encode

Header decode_header(Bytes bytes, MessageEncoding encoding, const std::string& where) {
  return decode_with<Header>(bytes, encoding, where, "std_msgs/Header", [](In& io, Header& m) { io_header(io, m); });
}

PointCloud2Layout decode_pointcloud2_layout(Bytes bytes, MessageEncoding encoding, const std::string& where,
                                            Bytes& data) {
  MessageReader r(bytes, encoding, where, "sensor_msgs/PointCloud2");
  In io{r};
  PointCloud2Layout m;
  io_pointcloud2_head(io, m);
  data = r.read_bytes(r.read_length("data", 1), "data");
  m.is_dense = r.read_bool("is_dense");
  r.expect_end();
  return m;
}

PointCloud2Layout decode_pointcloud2_head(Bytes prefix, MessageEncoding encoding, const std::string& where,
                                          std::size_t* data_bytes) {
  MessageReader r(prefix, encoding, where, "sensor_msgs/PointCloud2");
  In io{r};
  PointCloud2Layout m;
  io_pointcloud2_head(io, m);
  const std::uint32_t n = r.read<std::uint32_t>("data");
  if (data_bytes != nullptr) *data_bytes = n;
  return m;
}

PointCloud2 decode_pointcloud2(Bytes bytes, MessageEncoding encoding, const std::string& where) {
  Bytes data;
  PointCloud2 m{decode_pointcloud2_layout(bytes, encoding, where, data), {}};
  m.data.assign(data.begin(), data.end());
  return m;
}

NavSatFix decode_navsatfix(Bytes bytes, MessageEncoding encoding, const std::string& where) {
  return decode_with<NavSatFix>(bytes, encoding, where, "sensor_msgs/NavSatFix",
                                [](In& io, NavSatFix& m) { io_navsatfix(io, m); });
}

Imu decode_imu(Bytes bytes, MessageEncoding encoding, const std::string& where) {
  return decode_with<Imu>(bytes, encoding, where, "sensor_msgs/Imu", [](In& io, Imu& m) { io_imu(io, m); });
}

Odometry decode_odometry(Bytes bytes, MessageEncoding encoding, const std::string& where) {
  return decode_with<Odometry>(bytes, encoding, where, "nav_msgs/Odometry",
                               [](In& io, Odometry& m) { io_odometry(io, m); });
}

PoseStamped decode_pose_stamped(Bytes bytes, MessageEncoding encoding, const std::string& where) {
  return decode_with<PoseStamped>(bytes, encoding, where, "geometry_msgs/PoseStamped", [](In& io, PoseStamped& m) {
    io_header(io, m.header);
    io_pose(io, m.pose);
  });
}

PoseWithCovarianceStamped decode_pose_with_covariance_stamped(Bytes bytes, MessageEncoding encoding,
                                                              const std::string& where) {
  return decode_with<PoseWithCovarianceStamped>(bytes, encoding, where, "geometry_msgs/PoseWithCovarianceStamped",
                                                [](In& io, PoseWithCovarianceStamped& m) {
                                                  io_header(io, m.header);
                                                  io_pose_with_covariance(io, m.pose);
                                                });
}

TFMessage decode_tf_message(Bytes bytes, MessageEncoding encoding, const std::string& where) {
  return decode_with<TFMessage>(bytes, encoding, where, "tf2_msgs/TFMessage", [](In& io, TFMessage& m) {
    // A TransformStamped is at least 8 + 4 + 4 + 56 bytes.
    io.seq(m.transforms, 72, "transforms", [&](TransformStamped& tf) { io_transform_stamped(io, tf); });
  });
}

std::vector<std::uint8_t> encode_message(const Header& msg, MessageEncoding encoding) {
  return encode_with(msg, encoding, [](Out& io, const Header& m) { io_header(io, m); });
}

std::vector<std::uint8_t> encode_message(const PointCloud2& msg, MessageEncoding encoding) {
  return encode_with(msg, encoding, [](Out& io, const PointCloud2& m) {
    io_pointcloud2_head(io, m);
    io.w.write_length(m.data.size());
    io.w.write_bytes(m.data);
    io.w.write_bool(m.is_dense);
  });
}

std::vector<std::uint8_t> encode_message(const NavSatFix& msg, MessageEncoding encoding) {
  return encode_with(msg, encoding, [](Out& io, const NavSatFix& m) { io_navsatfix(io, m); });
}

std::vector<std::uint8_t> encode_message(const Imu& msg, MessageEncoding encoding) {
  return encode_with(msg, encoding, [](Out& io, const Imu& m) { io_imu(io, m); });
}

std::vector<std::uint8_t> encode_message(const Odometry& msg, MessageEncoding encoding) {
  return encode_with(msg, encoding, [](Out& io, const Odometry& m) { io_odometry(io, m); });
}

std::vector<std::uint8_t> encode_message(const PoseStamped& msg, MessageEncoding encoding) {
  return encode_with(msg, encoding, [](Out& io, const PoseStamped& m) {
    io_header(io, m.header);
    io_pose(io, m.pose);
  });
}

std::vector<std::uint8_t> encode_message(const PoseWithCovarianceStamped& msg, MessageEncoding encoding) {
  return encode_with(msg, encoding, [](Out& io, const PoseWithCovarianceStamped& m) {
    io_header(io, m.header);
    io_pose_with_covariance(io, m.pose);
  });
}

std::vector<std::uint8_t> encode_message(const TFMessage& msg, MessageEncoding encoding) {
  return encode_with(msg, encoding, [](Out& io, const TFMessage& m) {
    io.seq(m.transforms, 0, "transforms", [&](const TransformStamped& tf) { io_transform_stamped(io, tf); });
  });
}

// ----------------------------------------------------------------------------------- NovAtel

namespace {

template <typename IO, typename M>
void io_oem7_header_common(IO& io, M& h) {
  io.str(h.message_name, "nov_header.message_name");
  io.num(h.message_id, "nov_header.message_id");
  io.num(h.message_type, "nov_header.message_type");
  io.num(h.sequence_number, "nov_header.sequence_number");
  io.num(h.time_status, "nov_header.time_status");
  io.num(h.gps_week_number, "nov_header.gps_week_number");
  io.num(h.gps_week_milliseconds, "nov_header.gps_week_milliseconds");
}

template <typename IO, typename M>
void io_oem7_header_tail(IO& io, M& h, Oem7Header::Layout layout) {
  if (layout == Oem7Header::Layout::kIdleTime) {
    std::uint8_t idle = h.idle_time >= 0.0f && h.idle_time <= 255.0f ? static_cast<std::uint8_t>(h.idle_time) : 0;
    io.num(idle, "nov_header.idle_time");
    h.idle_time = idle;
  } else if (layout == Oem7Header::Layout::kReceiverStatus) {
    io.num(h.receiver_status, "nov_header.receiver_status");
    io.num(h.idle_time, "nov_header.idle_time");
  }
}

// Writing: idle_time goes through a local, so M is never const here.
void write_oem7_header(Out& io, const Oem7Header& h) {
  io_oem7_header_common(io, h);
  Oem7Header copy = h;
  io_oem7_header_tail(io, copy, h.layout);
}

template <typename IO, typename M>
void io_inspva_body(IO& io, M& m) {
  io.num(m.latitude, "latitude"), io.num(m.longitude, "longitude"), io.num(m.height, "height");
  io_attitude(io, m.pva);
  io.num(m.status, "status.status");
}

template <typename IO, typename M>
void io_inspvax_body(IO& io, M& m) {
  io.num(m.ins_status, "ins_status.status");
  io.num(m.pos_type, "pos_type.type");
  io.num(m.latitude, "latitude"), io.num(m.longitude, "longitude"), io.num(m.height, "height");
  io.num(m.undulation, "undulation");
  io_attitude(io, m.pva);
  io.num(m.latitude_stdev, "latitude_stdev"), io.num(m.longitude_stdev, "longitude_stdev");
  io.num(m.height_stdev, "height_stdev");
  io.num(m.north_velocity_stdev, "north_velocity_stdev"), io.num(m.east_velocity_stdev, "east_velocity_stdev");
  io.num(m.up_velocity_stdev, "up_velocity_stdev");
  io.num(m.roll_stdev, "roll_stdev"), io.num(m.pitch_stdev, "pitch_stdev"), io.num(m.azimuth_stdev, "azimuth_stdev");
  io.num(m.ext_sol_status, "ext_sol_status.status");
  io.num(m.time_since_update, "time_since_update");
}

bool known_ins_status(std::uint32_t s) { return s <= 3 || (s >= 6 && s <= 12); }

bool known_position_type(std::uint32_t t) {
  return novatel_solution(t) != GnssSolution::kUnknown || t == 1 || t == 2 || (t >= 70 && t <= 72);
}

// Reads the Oem7Header tail and the fixed-size body after it, trying each layout (see the header
// comment). `plausible` checks the status values of a candidate reading.
template <typename M, typename Body, typename Plausible>
void read_oem7_tail_and_body(MessageReader& r, M& msg, std::optional<Oem7Header::Layout> hint, Body&& body,
                             Plausible&& plausible) {
  using L = Oem7Header::Layout;
  if (hint) {
    In io{r};
    io_oem7_header_tail(io, msg.nov_header, *hint);
    body(io, msg);
    r.expect_end();
    msg.nov_header.layout = *hint;
    return;
  }
  const std::vector<L> order = r.cdr() ? std::vector<L>{L::kReceiverStatus, L::kIdleTime, L::kBase}
                                       : std::vector<L>{L::kBase, L::kIdleTime, L::kReceiverStatus};
  std::optional<std::pair<MessageReader, M>> fallback;
  for (L layout : order) {
    MessageReader trial = r;
    M candidate = msg;
    In io{trial};
    try {
      io_oem7_header_tail(io, candidate.nov_header, layout);
      body(io, candidate);
    } catch (const InputError&) {
      continue;
    }
    if (!trial.at_end()) continue;
    candidate.nov_header.layout = layout;
    if (plausible(candidate)) {
      r = trial, msg = candidate;
      return;
    }
    if (!fallback) fallback.emplace(trial, candidate);
  }
  if (fallback) {
    r = fallback->first, msg = fallback->second;
    return;
  }
  r.fail(fmt::format("{} bytes from here fit none of the three known Oem7Header layouts (a different "
                     "version or a custom fork of the message?)",
                     r.remaining()));
}

template <typename IO, typename M>
void io_novatel_message_header(IO& io, M& h) {
  io.str(h.message_name, "novatel_msg_header.message_name");
  io.str(h.port, "novatel_msg_header.port");
  io.num(h.sequence_num, "novatel_msg_header.sequence_num");
  io.num(h.percent_idle_time, "novatel_msg_header.percent_idle_time");
  io.str(h.gps_time_status, "novatel_msg_header.gps_time_status");
  io.num(h.gps_week_num, "novatel_msg_header.gps_week_num");
  io.num(h.gps_seconds, "novatel_msg_header.gps_seconds");
  io.num(h.receiver_status_code, "novatel_msg_header.receiver_status.original_status_code");
  for (std::size_t i = 0; i < h.receiver_status_flags.size(); ++i) {
    bool flag = h.receiver_status_flags[i];
    io.boolean(flag, "novatel_msg_header.receiver_status");
    if constexpr (!std::is_const_v<M>) h.receiver_status_flags[i] = flag;
  }
  io.num(h.receiver_software_version, "novatel_msg_header.receiver_software_version");
}

template <typename IO, typename M>
void io_novatel_gps_inspva(IO& io, M& m) {
  io_header(io, m.header);
  io_novatel_message_header(io, m.novatel_msg_header);
  io.num(m.week, "week");
  io.num(m.seconds, "seconds");
  io.num(m.latitude, "latitude"), io.num(m.longitude, "longitude"), io.num(m.height, "height");
  io_attitude(io, m.pva);
  io.str(m.status, "status");
}

template <typename IO, typename M>
void io_novatel_gps_inspvax_head(IO& io, M& m) {
  io_header(io, m.header);
  io_novatel_message_header(io, m.novatel_msg_header);
  io.str(m.ins_status, "ins_status");
  io.str(m.position_type, "position_type");
  io.num(m.latitude, "latitude"), io.num(m.longitude, "longitude"), io.num(m.altitude, "altitude");
  io.num(m.undulation, "undulation");
  io_attitude(io, m.pva);
  io.num(m.latitude_std, "latitude_std"), io.num(m.longitude_std, "longitude_std");
  io.num(m.altitude_std, "altitude_std");
  io.num(m.north_velocity_std, "north_velocity_std"), io.num(m.east_velocity_std, "east_velocity_std");
  io.num(m.up_velocity_std, "up_velocity_std");
  io.num(m.roll_std, "roll_std"), io.num(m.pitch_std, "pitch_std"), io.num(m.azimuth_std, "azimuth_std");
}

// The tail in either known layout; false (and `m` untouched) when it fits neither.
bool read_novatel_gps_inspvax_tail(MessageReader& r, NovatelGpsInspvax& m) {
  for (const bool ins_layout : {false, true}) {
    MessageReader trial = r;
    NovatelGpsInspvax c = m;
    try {
      c.extended_status_mask = trial.read<std::uint32_t>("extended_status.original_mask");
      if (!ins_layout) {
        c.advance_rtk_verified = trial.read_bool("extended_status.advance_rtk_verified");
        c.pseudorange_iono_correction = trial.read_string("extended_status.psueorange_iono_correction");
      } else {
        for (int i = 0; i < 18; ++i) (void)trial.read_bool("extended_status");  // the update flags
        (void)trial.read_string("extended_status.alignment_type");
        (void)trial.read_string("extended_status.nvm_seed_status");
      }
      c.seconds_since_update = trial.read<std::uint16_t>("seconds_since_update");
    } catch (const InputError&) {
      continue;
    }
    if (!trial.at_end()) continue;
    c.extended_status_read = true;
    r = trial, m = c;
    return true;
  }
  return false;
}

}  // namespace

Oem7Inspva decode_oem7_inspva(Bytes bytes, MessageEncoding encoding, const std::string& where,
                              std::optional<Oem7Header::Layout> layout) {
  MessageReader r(bytes, encoding, where, "novatel_oem7_msgs/INSPVA");
  In io{r};
  Oem7Inspva msg;
  io_header(io, msg.header);
  io_oem7_header_common(io, msg.nov_header);
  read_oem7_tail_and_body(
      r, msg, layout, [](In& in, Oem7Inspva& m) { io_inspva_body(in, m); },
      [](const Oem7Inspva& m) { return known_ins_status(m.status); });
  return msg;
}

Oem7Inspvax decode_oem7_inspvax(Bytes bytes, MessageEncoding encoding, const std::string& where,
                                std::optional<Oem7Header::Layout> layout) {
  MessageReader r(bytes, encoding, where, "novatel_oem7_msgs/INSPVAX");
  In io{r};
  Oem7Inspvax msg;
  io_header(io, msg.header);
  io_oem7_header_common(io, msg.nov_header);
  read_oem7_tail_and_body(
      r, msg, layout, [](In& in, Oem7Inspvax& m) { io_inspvax_body(in, m); },
      [](const Oem7Inspvax& m) { return known_ins_status(m.ins_status) && known_position_type(m.pos_type); });
  return msg;
}

NovatelGpsInspva decode_novatel_gps_inspva(Bytes bytes, MessageEncoding encoding, const std::string& where) {
  return decode_with<NovatelGpsInspva>(bytes, encoding, where, "novatel_gps_msgs/Inspva",
                                       [](In& io, NovatelGpsInspva& m) { io_novatel_gps_inspva(io, m); });
}

NovatelGpsInspvax decode_novatel_gps_inspvax(Bytes bytes, MessageEncoding encoding, const std::string& where) {
  MessageReader r(bytes, encoding, where, "novatel_gps_msgs/Inspvax");
  In io{r};
  NovatelGpsInspvax msg;
  io_novatel_gps_inspvax_head(io, msg);
  read_novatel_gps_inspvax_tail(r, msg);  // insalign reads nothing after azimuth_std
  return msg;
}

std::vector<std::uint8_t> encode_message(const Oem7Inspva& msg, MessageEncoding encoding) {
  return encode_with(msg, encoding, [](Out& io, const Oem7Inspva& m) {
    io_header(io, m.header);
    write_oem7_header(io, m.nov_header);
    io_inspva_body(io, m);
  });
}

std::vector<std::uint8_t> encode_message(const Oem7Inspvax& msg, MessageEncoding encoding) {
  return encode_with(msg, encoding, [](Out& io, const Oem7Inspvax& m) {
    io_header(io, m.header);
    write_oem7_header(io, m.nov_header);
    io_inspvax_body(io, m);
  });
}

std::vector<std::uint8_t> encode_message(const NovatelGpsInspva& msg, MessageEncoding encoding) {
  return encode_with(msg, encoding, [](Out& io, const NovatelGpsInspva& m) { io_novatel_gps_inspva(io, m); });
}

std::vector<std::uint8_t> encode_message(const NovatelGpsInspvax& msg, MessageEncoding encoding) {
  return encode_with(msg, encoding, [](Out& io, const NovatelGpsInspvax& m) {
    io_novatel_gps_inspvax_head(io, m);
    // The released layout: NovatelExtendedSolutionStatus.
    io.num(m.extended_status_mask, "extended_status.original_mask");
    io.boolean(m.advance_rtk_verified, "extended_status.advance_rtk_verified");
    io.str(m.pseudorange_iono_correction, "extended_status.psueorange_iono_correction");
    io.num(m.seconds_since_update, "seconds_since_update");
  });
}

// ------------------------------------------------------------------------- to io::InsRecord

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct PositionType {
  std::uint32_t value;
  const char* name;
  GnssSolution solution;
};
// NovAtel OEM7 position types (the novatel_oem7_msgs constants) plus the OEM6-era OmniSTAR/CDGPS
// ones that novatel_gps_msgs strings may carry.
constexpr PositionType kPositionTypes[] = {
    {0, "NONE", GnssSolution::kInvalid},
    {1, "FIXEDPOS", GnssSolution::kUnknown},
    {2, "FIXEDHEIGHT", GnssSolution::kUnknown},
    {8, "DOPPLER_VELOCITY", GnssSolution::kInvalid},
    {16, "SINGLE", GnssSolution::kSingle},
    {17, "PSRDIFF", GnssSolution::kDifferential},
    {18, "WAAS", GnssSolution::kDifferential},
    {19, "PROPAGATED", GnssSolution::kInsOnly},
    {20, "OMNISTAR", GnssSolution::kDifferential},
    {32, "L1_FLOAT", GnssSolution::kRtkFloat},
    {33, "IONOFREE_FLOAT", GnssSolution::kRtkFloat},
    {34, "NARROW_FLOAT", GnssSolution::kRtkFloat},
    {48, "L1_INT", GnssSolution::kRtkFixed},
    {49, "WIDE_INT", GnssSolution::kRtkFixed},
    {50, "NARROW_INT", GnssSolution::kRtkFixed},
    {51, "RTK_DIRECT_INS", GnssSolution::kRtkFloat},
    {52, "INS_SBAS", GnssSolution::kDifferential},
    {53, "INS_PSRSP", GnssSolution::kSingle},
    {54, "INS_PSRDIFF", GnssSolution::kDifferential},
    {55, "INS_RTKFLOAT", GnssSolution::kRtkFloat},
    {56, "INS_RTKFIXED", GnssSolution::kRtkFixed},
    {64, "OMNISTAR_HP", GnssSolution::kDifferential},
    {65, "OMNISTAR_XP", GnssSolution::kDifferential},
    {66, "CDGPS", GnssSolution::kDifferential},
    {68, "PPP_CONVERGING", GnssSolution::kDifferential},
    {69, "PPP", GnssSolution::kDifferential},
    {70, "OPERATIONAL", GnssSolution::kUnknown},
    {71, "WARNING", GnssSolution::kUnknown},
    {72, "OUT_OF_BOUNDS", GnssSolution::kUnknown},
    {73, "INS_PPP_CONVERGING", GnssSolution::kDifferential},
    {74, "INS_PPP", GnssSolution::kDifferential},
    {77, "PPP_BASIC_CONVERGING", GnssSolution::kDifferential},
    {78, "PPP_BASIC", GnssSolution::kDifferential},
    {79, "INS_PPP_BASIC_CONVERGING", GnssSolution::kDifferential},
    {80, "INS_PPP_BASIC", GnssSolution::kDifferential},
};

enum class InsState { kGood, kDegraded, kFree, kNotNavigating, kUnknown };
struct InsStatus {
  std::uint32_t value;
  const char* name;
  InsState state;
};
constexpr InsStatus kInsStatuses[] = {
    {0, "INS_INACTIVE", InsState::kNotNavigating},
    {1, "INS_ALIGNING", InsState::kNotNavigating},
    {2, "INS_HIGH_VARIANCE", InsState::kDegraded},
    {3, "INS_SOLUTION_GOOD", InsState::kGood},
    {6, "INS_SOLUTION_FREE", InsState::kFree},
    {7, "INS_ALIGNMENT_COMPLETE", InsState::kDegraded},
    {8, "DETERMINING_ORIENTATION", InsState::kNotNavigating},
    {9, "WAITING_INITIALPOS", InsState::kNotNavigating},
    {10, "WAITING_AZIMUTH", InsState::kNotNavigating},
    {11, "INITIALIZING_BIASES", InsState::kNotNavigating},
    {12, "MOTION_DETECT", InsState::kNotNavigating},
};

// By name, ignoring underscores: the oem7 constants say WAITING_INITIAL_POS, NovAtel's logs (and
// so novatel_gps_msgs strings) WAITING_INITIALPOS.
InsState ins_state(const std::string& name) {
  const auto bare = [](std::string s) {
    s.erase(std::remove(s.begin(), s.end(), '_'), s.end());
    return s;
  };
  for (const InsStatus& s : kInsStatuses) {
    if (bare(name) == bare(s.name)) return s.state;
  }
  return InsState::kUnknown;
}

// The INS status overrides the position class when the INS is not navigating or coasting.
void apply_ins_status(NovatelRecord& out, GnssSolution from_position) {
  const InsState state = ins_state(out.ins_status);
  out.ins_status_good = state == InsState::kGood;
  out.record.solution = state == InsState::kNotNavigating ? GnssSolution::kInvalid
                        : state == InsState::kFree        ? GnssSolution::kInsOnly
                                                          : from_position;
}

double positive_or_nan(double s) { return std::isfinite(s) && s > 0.0 ? s : kNaN; }

io::InsRecord geodetic_record(const Header& h, double lat_deg, double lon_deg, double ellipsoidal_height_m,
                              const NovatelAttitude& pva) {
  io::InsRecord rec;
  rec.t_s = h.stamp.seconds();
  rec.lat_deg = lat_deg;
  rec.lon_deg = lon_deg;
  rec.height_m = ellipsoidal_height_m;
  rec.R_world_ins = io::R_enu_ins_novatel(pva.roll, pva.pitch, pva.azimuth);
  return rec;
}

io::InsRecord cartesian_record(const Header& h, const Pose& pose, const Covariance36* cov, const std::string& where) {
  io::InsRecord rec;
  rec.t_s = h.stamp.seconds();
  rec.p_world_m = pose.position;
  rec.R_world_ins = rotation_from(pose.orientation, where);
  if (cov != nullptr) {
    for (int i = 0; i < 3; ++i) rec.position_stddev_m[i] = std::sqrt(positive_or_nan((*cov)[7 * i]));
  }
  return rec;
}

}  // namespace

GnssSolution novatel_solution(std::uint32_t pos_type) {
  for (const PositionType& t : kPositionTypes) {
    if (t.value == pos_type) return t.solution;
  }
  return GnssSolution::kUnknown;
}

GnssSolution novatel_solution(const std::string& pos_type_name) {
  for (const PositionType& t : kPositionTypes) {
    if (pos_type_name == t.name) return t.solution;
  }
  return GnssSolution::kUnknown;
}

std::string novatel_ins_status_name(std::uint32_t ins_status) {
  for (const InsStatus& s : kInsStatuses) {
    if (s.value == ins_status) return s.name;
  }
  return "status " + std::to_string(ins_status);
}

NovatelRecord to_ins_record(const Oem7Inspva& msg) {
  NovatelRecord out{geodetic_record(msg.header, msg.latitude, msg.longitude, msg.height, msg.pva), false,
                    novatel_ins_status_name(msg.status), ""};
  apply_ins_status(out, GnssSolution::kUnknown);  // INSPVA states no position type
  return out;
}

NovatelRecord to_ins_record(const Oem7Inspvax& msg) {
  NovatelRecord out{geodetic_record(msg.header, msg.latitude, msg.longitude,
                                    msg.height + static_cast<double>(msg.undulation), msg.pva),
                    false, novatel_ins_status_name(msg.ins_status), ""};
  for (const PositionType& t : kPositionTypes) {
    if (t.value == msg.pos_type) out.position_type = t.name;
  }
  if (out.position_type.empty()) out.position_type = "type " + std::to_string(msg.pos_type);
  apply_ins_status(out, novatel_solution(msg.pos_type));
  out.record.position_stddev_m = {positive_or_nan(msg.longitude_stdev), positive_or_nan(msg.latitude_stdev),
                                  positive_or_nan(msg.height_stdev)};
  return out;
}

NovatelRecord to_ins_record(const NovatelGpsInspva& msg) {
  NovatelRecord out{geodetic_record(msg.header, msg.latitude, msg.longitude, msg.height, msg.pva), false,
                    msg.status, ""};
  apply_ins_status(out, GnssSolution::kUnknown);
  return out;
}

NovatelRecord to_ins_record(const NovatelGpsInspvax& msg) {
  NovatelRecord out{geodetic_record(msg.header, msg.latitude, msg.longitude,
                                    msg.altitude + static_cast<double>(msg.undulation), msg.pva),
                    false, msg.ins_status, msg.position_type};
  apply_ins_status(out, novatel_solution(msg.position_type));
  out.record.position_stddev_m = {positive_or_nan(msg.longitude_std), positive_or_nan(msg.latitude_std),
                                  positive_or_nan(msg.altitude_std)};
  return out;
}

io::InsRecord to_ins_record(const NavSatFix& msg) {
  io::InsRecord rec;
  rec.t_s = msg.header.stamp.seconds();
  rec.lat_deg = msg.latitude;
  rec.lon_deg = msg.longitude;
  rec.height_m = msg.altitude;
  switch (msg.status) {
    case NavSatFix::kFix: rec.solution = GnssSolution::kSingle; break;
    case NavSatFix::kSbasFix:
    case NavSatFix::kGbasFix: rec.solution = GnssSolution::kDifferential; break;
    case NavSatFix::kNoFix: rec.solution = GnssSolution::kInvalid; break;
    default: rec.solution = GnssSolution::kUnknown; break;
  }
  if (msg.position_covariance_type != NavSatFix::kUnknown) {
    for (int i = 0; i < 3; ++i) rec.position_stddev_m[i] = std::sqrt(positive_or_nan(msg.position_covariance[4 * i]));
  }
  return rec;
}

io::InsRecord to_ins_record(const Odometry& msg, const std::string& where) {
  return cartesian_record(msg.header, msg.pose.pose, &msg.pose.covariance, where);
}

io::InsRecord to_ins_record(const PoseStamped& msg, const std::string& where) {
  return cartesian_record(msg.header, msg.pose, nullptr, where);
}

io::InsRecord to_ins_record(const PoseWithCovarianceStamped& msg, const std::string& where) {
  return cartesian_record(msg.header, msg.pose.pose, &msg.pose.covariance, where);
}

Mat3 rotation_from(const Quaternion& q, const std::string& where) {
  const double norm = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
  if (!std::isfinite(norm) || std::abs(norm - 1.0) > 0.01) {
    throw InputError(where, "",
                     fmt::format("orientation quaternion (x y z w) = ({} {} {} {}) is not a unit quaternion (norm {})",
                                 q.x, q.y, q.z, q.w, norm));
  }
  return Eigen::Quaterniond(q.w / norm, q.x / norm, q.y / norm, q.z / norm).toRotationMatrix();
}

Quaternion quaternion_from(const Mat3& R) {
  const Eigen::Quaterniond q = Eigen::Quaterniond(R).normalized();
  return {q.x(), q.y(), q.z(), q.w()};
}

Iso3 transform_from(const TransformStamped& tf, const std::string& where) {
  Iso3 T = Iso3::Identity();
  T.linear() = rotation_from(tf.rotation, where);
  T.translation() = tf.translation;
  return T;
}

std::optional<Mat3> imu_orientation(const Imu& msg, const std::string& where) {
  const Quaternion& q = msg.orientation;
  if (!msg.has_orientation() || (q.x == 0.0 && q.y == 0.0 && q.z == 0.0 && q.w == 0.0)) return std::nullopt;
  return rotation_from(q, where);
}

}  // namespace insalign::io::bag
