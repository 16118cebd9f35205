#include "recording/bag_ins.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <functional>
#include <map>
#include <optional>
#include <stdexcept>

#include "core/errors.hpp"
#include "recording/message_definitions.hpp"
#include "recording/messages.hpp"
#include "recording/bag_tf.hpp"

namespace insalign::io {

namespace {

using namespace bag;

constexpr double kSameStamp_s = 1e-6;        // two records closer than this: the later is a duplicate
constexpr double kMaxImuGap_s = 0.2;         // a fix is paired only between Imu samples this close

/// One INS message as the source kinds share it.
struct Decoded {
  InsRecord rec;
  std::string status;    ///< for status_counts; "" = the message states none
  std::string frame_id;  ///< header.frame_id
  std::string child;     ///< Odometry child_frame_id
};

std::string where_of(const BagReader& r, std::uint32_t topic, std::size_t i) {
  return fmt::format("{} {} message {}", r.path().string(), r.topics()[topic].name, i);
}

using Decoder = std::function<Decoded(Bytes, const std::string&)>;

bool oem7(const Topic& t) { return normalized_type(t.type).rfind("novatel_oem7_msgs/", 0) == 0; }

std::string status_key(const NovatelRecord& n) {
  return n.position_type.empty() ? n.ins_status : n.ins_status + " / " + n.position_type;
}

Decoder novatel_decoder(const Topic& t, bool inspvax, std::optional<Oem7Header::Layout> layout) {
  const MessageEncoding enc = t.encoding;
  const bool new_driver = oem7(t);
  return [=](Bytes b, const std::string& where) {
    NovatelRecord n;
    Header h;
    if (new_driver && inspvax) {
      const Oem7Inspvax m = decode_oem7_inspvax(b, enc, where, layout);
      n = to_ins_record(m), h = m.header;
    } else if (new_driver) {
      const Oem7Inspva m = decode_oem7_inspva(b, enc, where, layout);
      n = to_ins_record(m), h = m.header;
    } else if (inspvax) {
      const NovatelGpsInspvax m = decode_novatel_gps_inspvax(b, enc, where);
      n = to_ins_record(m), h = m.header;
    } else {
      const NovatelGpsInspva m = decode_novatel_gps_inspva(b, enc, where);
      n = to_ins_record(m), h = m.header;
    }
    return Decoded{n.record, status_key(n), h.frame_id, ""};
  };
}

const char* navsat_status_name(std::int8_t status) {
  switch (status) {
    case NavSatFix::kNoFix: return "NO_FIX";
    case NavSatFix::kFix: return "FIX";
    case NavSatFix::kSbasFix: return "SBAS_FIX";
    case NavSatFix::kGbasFix: return "GBAS_FIX";
    default: return "status ?";
  }
}

Decoder fix_decoder(MessageEncoding enc) {
  return [enc](Bytes b, const std::string& where) {
    const NavSatFix m = decode_navsatfix(b, enc, where);
    return Decoded{to_ins_record(m), navsat_status_name(m.status), m.header.frame_id, ""};
  };
}

Decoder cartesian_decoder(InsSourceKind kind, MessageEncoding enc) {
  return [kind, enc](Bytes b, const std::string& where) {
    if (kind == InsSourceKind::kOdometry) {
      const Odometry m = decode_odometry(b, enc, where);
      return Decoded{to_ins_record(m, where), "", m.header.frame_id, m.child_frame_id};
    }
    if (kind == InsSourceKind::kPoseWithCovariance) {
      const PoseWithCovarianceStamped m = decode_pose_with_covariance_stamped(b, enc, where);
      return Decoded{to_ins_record(m, where), "", m.header.frame_id, ""};
    }
    const PoseStamped m = decode_pose_stamped(b, enc, where);
    return Decoded{to_ins_record(m, where), "", m.header.frame_id, ""};
  };
}

// The most common value of a field over the messages, with a warning when they differ.
std::string common_value(const std::vector<Decoded>& d, std::string Decoded::*field, const std::string& what,
                         InsSource& out) {
  std::map<std::string, std::size_t> count;
  for (const Decoded& x : d) ++count[x.*field];
  if (count.empty()) return "";
  const auto best = std::max_element(count.begin(), count.end(), [](const auto& a, const auto& b) { return a.second < b.second; });
  if (count.size() > 1) {
    out.track.warnings.push_back(fmt::format("the INS messages name {} different {}s; '{}' is the most common ({} of {})",
                                             count.size(), what, best->first, best->second, d.size()));
  }
  return best->first;
}

struct ImuSample {
  double t_s = 0.0;
  std::optional<Mat3> R_enu_imu;
  std::string frame_id;
};

// Fix positions with the Imu orientation at each fix's stamp (exact stamp match, else slerp
// between the Imu samples around it when they are at most kMaxImuGap_s apart).
void pair_with_imu(std::vector<Decoded>& fixes, std::vector<ImuSample> imu, InsSource& out, const std::string& source) {
  std::erase_if(imu, [](const ImuSample& s) { return !s.R_enu_imu || !std::isfinite(s.t_s); });
  if (imu.empty()) {
    throw InputError(source, "", "the Imu topic " + out.topics[1] +
                                     " carries no orientation (orientation_covariance[0] = -1 or zero quaternions): "
                                     "NavSatFix + Imu needs the Imu's orientation");
  }
  std::stable_sort(imu.begin(), imu.end(), [](const ImuSample& a, const ImuSample& b) { return a.t_s < b.t_s; });
  std::vector<Decoded> paired;
  for (Decoded& f : fixes) {
    const double t = f.rec.t_s;
    auto hi = std::lower_bound(imu.begin(), imu.end(), t, [](const ImuSample& s, double v) { return s.t_s < v; });
    std::optional<Mat3> R;
    if (hi != imu.end() && hi->t_s - t < kSameStamp_s) {
      R = hi->R_enu_imu;
    } else if (hi != imu.begin() && hi != imu.end() && hi->t_s - (hi - 1)->t_s <= kMaxImuGap_s) {
      const auto lo = hi - 1;
      const double s = (t - lo->t_s) / (hi->t_s - lo->t_s);
      R = Eigen::Quaterniond(*lo->R_enu_imu).slerp(s, Eigen::Quaterniond(*hi->R_enu_imu)).toRotationMatrix();
    } else if (hi != imu.begin() && t - (hi - 1)->t_s < kSameStamp_s) {
      R = (hi - 1)->R_enu_imu;
    }
    if (!R) {
      ++out.records_unpaired;
      continue;
    }
    f.rec.R_world_ins = *R;
    paired.push_back(std::move(f));
  }
  if (out.records_unpaired > 0) {
    out.track.warnings.push_back(fmt::format("{} of {} fixes have no Imu orientation within {} s and were dropped",
                                             out.records_unpaired, fixes.size(), kMaxImuGap_s));
  }
  fixes = std::move(paired);
  std::map<std::string, std::size_t> frames;
  for (const ImuSample& s : imu) ++frames[s.frame_id];
  out.ins_frame_id = std::max_element(frames.begin(), frames.end(), [](const auto& a, const auto& b) {
                       return a.second < b.second;
                     })->first;
}

ImuSample decode_imu_sample(Bytes b, MessageEncoding enc, const std::string& where) {
  const Imu m = decode_imu(b, enc, where);
  return ImuSample{m.header.stamp.seconds(), imu_orientation(m, where), m.header.frame_id};
}

std::vector<TransformStamped> flatten(const std::vector<TFMessage>& messages) {
  std::vector<TransformStamped> all;
  for (const TFMessage& m : messages) all.insert(all.end(), m.transforms.begin(), m.transforms.end());
  return all;
}

std::vector<Decoded> tf_records(const BagReader& r, const std::vector<TFMessage>& moving, const std::vector<TFMessage>& fixed,
                                const InsReadOptions& options, InsSource& out) {
  TfChain chain = tf_chain(flatten(moving), flatten(fixed), options.world_frame, options.ins_frame, r.path().string());
  for (std::string& w : chain.warnings) out.track.warnings.push_back(std::move(w));
  if (chain.samples_outside > 0) {
    out.track.warnings.push_back(fmt::format("TF: {} stamps of the chain skipped: another moving link had no data there",
                                             chain.samples_outside));
  }
  out.ins_frame_id = chain.ins_frame;
  out.world_frame_id = chain.world_frame;
  out.track.body_frame = "TF frame '" + chain.ins_frame + "' (chain " + chain.chain + ")";
  std::vector<Decoded> d;
  for (const InsRecord& rec : chain.records) d.push_back({rec, "", chain.world_frame, chain.ins_frame});
  return d;
}

// A record no frame can use: a value not finite, a latitude or longitude out of range.
bool usable(const InsRecord& r, bool geodetic) {
  if (!std::isfinite(r.t_s) || !r.R_world_ins.allFinite()) return false;
  if (!geodetic) return r.p_world_m.allFinite();
  try {
    check_geodetic({r.lat_deg, r.lon_deg, r.height_m});
  } catch (const std::invalid_argument&) {
    return false;
  }
  return true;
}

// Time shift, time order, duplicates and records the source marks invalid; status counts.
void finish_records(std::vector<Decoded>& d, const InsReadOptions& options, InsSource& out) {
  for (Decoded& x : d) x.rec.t_s += options.time_shift_s;
  const std::size_t before = d.size();
  std::erase_if(d, [&](const Decoded& x) { return !usable(x.rec, out.track.geodetic); });
  out.records_unusable = before - d.size();
  if (out.records_unusable > 0) {
    out.track.warnings.push_back(fmt::format("dropped {} INS records holding values that are not finite or a latitude or "
                                             "longitude out of range",
                                             out.records_unusable));
  }
  if (!std::is_sorted(d.begin(), d.end(), [](const Decoded& a, const Decoded& b) { return a.rec.t_s < b.rec.t_s; })) {
    out.track.warnings.push_back("INS stamps are not in record order; sorted by header.stamp");
    std::stable_sort(d.begin(), d.end(), [](const Decoded& a, const Decoded& b) { return a.rec.t_s < b.rec.t_s; });
  }
  std::map<std::string, std::size_t> statuses;
  for (const Decoded& x : d) {
    if (!x.status.empty()) ++statuses[x.status];
  }
  out.status_counts.assign(statuses.begin(), statuses.end());
  std::vector<InsRecord> kept;
  for (const Decoded& x : d) {
    if (x.rec.solution == GnssSolution::kInvalid) {
      ++out.records_invalid;
    } else if (!kept.empty() && x.rec.t_s - kept.back().t_s < kSameStamp_s) {
      ++out.records_duplicate;
    } else {
      kept.push_back(x.rec);
    }
  }
  if (out.records_invalid > 0) {
    out.track.warnings.push_back(fmt::format("dropped {} INS records the source marks invalid (no fix, INS not navigating)",
                                             out.records_invalid));
  }
  if (out.records_duplicate > 0) {
    out.track.warnings.push_back(fmt::format("dropped {} INS records with the stamp of the one before", out.records_duplicate));
  }
  out.track.records = std::move(kept);
  out.track.records_skipped = out.records_invalid + out.records_duplicate + out.records_unpaired + out.records_unusable;
}

void describe_frames(InsSource& out, const std::vector<Decoded>& d) {
  InsTrack& t = out.track;
  switch (out.kind) {
    case InsSourceKind::kInspvax:
    case InsSourceKind::kInspva:
      out.ins_frame_id = common_value(d, &Decoded::frame_id, "frame_id", out);
      out.world_frame_id = "local ENU";
      t.body_frame = "NovAtel SPAN vehicle frame (x right, y forward, z up) of '" + out.ins_frame_id + "'";
      t.height_datum = out.kind == InsSourceKind::kInspvax ? "mean sea level + undulation -> WGS-84 ellipsoid"
                                                           : "WGS-84 ellipsoid (INSPVA height)";
      break;
    case InsSourceKind::kNavSatFixImu: {
      const std::string fix_frame = common_value(d, &Decoded::frame_id, "frame_id", out);
      out.world_frame_id = "local ENU";
      t.body_frame = "the Imu's frame '" + out.ins_frame_id + "' (position of the fix's frame '" + fix_frame + "')";
      t.height_datum = "WGS-84 ellipsoid (NavSatFix altitude)";
      if (fix_frame != out.ins_frame_id) {
        t.warnings.push_back(fmt::format("the fix is of frame '{}', the orientation of '{}': T_ins_lidar's translation "
                                         "is relative to where the fix is",
                                         fix_frame, out.ins_frame_id));
      }
      break;
    }
    case InsSourceKind::kOdometry:
      out.world_frame_id = common_value(d, &Decoded::frame_id, "frame_id", out);
      out.ins_frame_id = common_value(d, &Decoded::child, "child_frame_id", out);
      t.body_frame = "the Odometry child frame '" + out.ins_frame_id + "'";
      break;
    case InsSourceKind::kPoseWithCovariance:
    case InsSourceKind::kPose:
      out.world_frame_id = common_value(d, &Decoded::frame_id, "frame_id", out);
      out.ins_frame_id = "(the pose's frame)";
      t.body_frame = "the frame whose pose the messages give (unnamed)";
      break;
    case InsSourceKind::kTf: break;  // read_tf filled them
  }
  t.geodetic = out.kind == InsSourceKind::kInspvax || out.kind == InsSourceKind::kInspva ||
               out.kind == InsSourceKind::kNavSatFixImu;
  t.world_frame = t.geodetic ? "local ENU at the first fix (x east, y north, z up)" : "'" + out.world_frame_id + "'";
  if (!t.geodetic) t.height_datum = "none (cartesian)";
}

}  // namespace

double median_of(std::vector<double>& values) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

struct InsSourceReader::State {
  const BagReader& r;
  InsSourceTopics topics;
  InsReadOptions options;
  InsSource out;
  std::vector<Decoded> main;       ///< INSPVA(X), NavSatFix, Odometry, Pose*: one per message
  std::vector<double> lag;         ///< header.stamp - record time, main topic (TF: /tf)
  std::vector<ImuSample> imu;
  std::vector<TFMessage> tf_moving, tf_fixed;

  void check(std::uint32_t topic, std::optional<Oem7Header::Layout>* layout = nullptr) {
    const DefinitionCheck c = check_definition(r.topics()[topic], r.path().string());
    if (layout != nullptr) *layout = c.oem7_layout;
    out.track.warnings.insert(out.track.warnings.end(), c.warnings.begin(), c.warnings.end());
  }
  std::size_t count(std::uint32_t topic) const { return r.messages(topic).size(); }
  double record_s(const MessageRef& ref) const { return static_cast<double>(ref.log_time_ns) * 1e-9; }
};

InsSourceReader::InsSourceReader(const BagReader& reader, const InsSourceTopics& topics, const InsReadOptions& options)
    : s_(std::make_unique<State>(State{reader, topics, options, {}, {}, {}, {}, {}, {}})) {
  InsSource& out = s_->out;
  out.kind = topics.kind;
  out.not_used = topics.not_used;
  for (auto id : {std::optional<std::uint32_t>(topics.topic), topics.partner}) {
    if (!id) continue;
    out.topics.push_back(reader.topics()[*id].name);
    out.types.push_back(reader.topics()[*id].type);
    out.messages += reader.topics()[*id].message_count;
  }
}

InsSourceReader::~InsSourceReader() = default;

std::vector<TopicPass> InsSourceReader::passes() {
  State& s = *s_;
  const std::uint32_t main = s.topics.topic;
  const MessageEncoding enc = s.r.topics()[main].encoding;
  std::vector<TopicPass> out;
  s.lag.assign(s.count(main), 0.0);
  if (s.topics.kind == InsSourceKind::kTf) {
    s.check(main);
    s.tf_moving.resize(s.lag.size());
    out.push_back({main, 0, [&s, enc, main](std::size_t i, const MessageRef& ref, Bytes b) {
                     s.tf_moving[i] = decode_tf_message(b, enc, where_of(s.r, main, i));
                     const auto& t = s.tf_moving[i].transforms;
                     s.lag[i] = t.empty() ? 0.0 : t.front().header.stamp.seconds() - s.record_s(ref);
                   }});
    if (s.topics.partner) {
      const std::uint32_t fixed = *s.topics.partner;
      s.check(fixed);
      s.tf_fixed.resize(s.count(fixed));
      out.push_back({fixed, 0, [&s, enc, fixed](std::size_t i, const MessageRef&, Bytes b) {
                       s.tf_fixed[i] = decode_tf_message(b, enc, where_of(s.r, fixed, i));
                     }});
    }
    return out;
  }
  Decoder decode;
  if (s.topics.kind == InsSourceKind::kInspvax || s.topics.kind == InsSourceKind::kInspva) {
    std::optional<Oem7Header::Layout> layout;
    s.check(main, &layout);
    decode = novatel_decoder(s.r.topics()[main], s.topics.kind == InsSourceKind::kInspvax, layout);
  } else if (s.topics.kind == InsSourceKind::kNavSatFixImu) {
    s.check(main);
    decode = fix_decoder(enc);
  } else {
    s.check(main);
    decode = cartesian_decoder(s.topics.kind, enc);
  }
  s.main.resize(s.lag.size());
  out.push_back({main, 0, [&s, decode, main](std::size_t i, const MessageRef& ref, Bytes b) {
                   s.main[i] = decode(b, where_of(s.r, main, i));
                   s.lag[i] = s.main[i].rec.t_s - s.record_s(ref);
                 }});
  if (s.topics.kind == InsSourceKind::kNavSatFixImu) {
    const std::uint32_t imu = *s.topics.partner;
    const MessageEncoding imu_enc = s.r.topics()[imu].encoding;
    s.check(imu);
    s.imu.resize(s.count(imu));
    out.push_back({imu, 0, [&s, imu, imu_enc](std::size_t i, const MessageRef&, Bytes b) {
                     s.imu[i] = decode_imu_sample(b, imu_enc, where_of(s.r, imu, i));
                   }});
  }
  return out;
}

InsSource InsSourceReader::finish() {
  State& s = *s_;
  InsSource& out = s.out;
  std::vector<Decoded> d = std::move(s.main);
  if (s.topics.kind == InsSourceKind::kNavSatFixImu) pair_with_imu(d, std::move(s.imu), out, s.r.path().string());
  if (s.topics.kind == InsSourceKind::kTf) d = tf_records(s.r, s.tf_moving, s.tf_fixed, s.options, out);
  out.stamp_minus_record_s = median_of(s.lag) + s.options.time_shift_s;
  describe_frames(out, d);
  finish_records(d, s.options, out);
  InsTrack& t = out.track;
  for (std::size_t i = 0; i < out.topics.size(); ++i) t.source += (i ? " + " : "") + out.topics[i];
  for (std::size_t i = 0; i < out.types.size(); ++i) t.format += (i ? " + " : "") + out.types[i];
  t.time_base = "header.stamp (the INS driver's clock)" +
                (s.options.time_shift_s != 0.0 ? fmt::format(", shifted by {:+g} s onto the LiDAR clock", s.options.time_shift_s) : std::string());
  if (t.records.size() < 2) {
    throw InputError(s.r.path().string(), "",
                     fmt::format("the INS source {} ({}) gives {} usable record(s) of {} messages: too few for a trajectory",
                                 t.source, t.format, t.records.size(), out.messages));
  }
  return std::move(out);
}

InsSource read_ins_source(const BagReader& reader, const InsSourceTopics& topics, const InsReadOptions& options) {
  InsSourceReader ins(reader, topics, options);
  read_in_record_order(reader, ins.passes());
  return ins.finish();
}

}  // namespace insalign::io
