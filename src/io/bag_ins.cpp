#include "io/bag_ins.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <map>
#include <optional>

#include "core/errors.hpp"
#include "io/bag/message_definitions.hpp"
#include "io/bag/messages.hpp"
#include "io/bag_tf.hpp"

namespace insalign::io {

namespace {

using namespace bag;

constexpr double kSameStamp_s = 1e-6;        // two records closer than this: the later is a duplicate
constexpr double kMaxImuGap_s = 0.2;         // a fix is paired only between Imu samples this close
constexpr std::size_t kDecodeGrain = 256;    // messages per parallel block (file order kept inside)

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

// Every message of `topic` through decode(bytes, where), in parallel over contiguous blocks in
// file order (so each block decompresses its chunks once); also header.stamp - record time.
template <typename T, typename F>
std::vector<T> decode_topic(const BagReader& r, std::uint32_t topic, F decode, std::vector<double>* stamp_minus_record = nullptr) {
  const std::vector<MessageRef> refs = r.messages(topic);
  std::vector<T> out(refs.size());
  std::vector<double> lag(refs.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, refs.size(), kDecodeGrain), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const std::vector<std::uint8_t> bytes = r.read(refs[i]);
      double t_s = 0.0;
      out[i] = decode(Bytes(bytes), where_of(r, topic, i), t_s);
      lag[i] = t_s - static_cast<double>(refs[i].log_time_ns) * 1e-9;
    }
  });
  if (stamp_minus_record != nullptr) stamp_minus_record->insert(stamp_minus_record->end(), lag.begin(), lag.end());
  return out;
}

std::vector<std::string> check(const BagReader& r, std::uint32_t topic, std::optional<Oem7Header::Layout>* layout = nullptr) {
  const DefinitionCheck c = check_definition(r.topics()[topic], r.path().string());
  if (layout != nullptr) *layout = c.oem7_layout;
  return c.warnings;
}

bool oem7(const Topic& t) { return normalized_type(t.type).rfind("novatel_oem7_msgs/", 0) == 0; }

std::string status_key(const NovatelRecord& n) {
  return n.position_type.empty() ? n.ins_status : n.ins_status + " / " + n.position_type;
}

std::vector<Decoded> decode_novatel(const BagReader& r, std::uint32_t topic, bool inspvax, InsSource& out,
                                    std::vector<double>& lag) {
  std::optional<Oem7Header::Layout> layout;
  for (std::string& w : check(r, topic, &layout)) out.track.warnings.push_back(std::move(w));
  const Topic& t = r.topics()[topic];
  const MessageEncoding enc = t.encoding;
  const bool new_driver = oem7(t);
  return decode_topic<Decoded>(r, topic, [&](Bytes b, const std::string& where, double& t_s) {
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
    t_s = n.record.t_s;
    return Decoded{n.record, status_key(n), h.frame_id, ""};
  }, &lag);
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

std::vector<Decoded> decode_fixes(const BagReader& r, std::uint32_t topic, InsSource& out, std::vector<double>& lag) {
  for (std::string& w : check(r, topic)) out.track.warnings.push_back(std::move(w));
  const MessageEncoding enc = r.topics()[topic].encoding;
  return decode_topic<Decoded>(r, topic, [&](Bytes b, const std::string& where, double& t_s) {
    const NavSatFix m = decode_navsatfix(b, enc, where);
    const InsRecord rec = to_ins_record(m);
    t_s = rec.t_s;
    return Decoded{rec, navsat_status_name(m.status), m.header.frame_id, ""};
  }, &lag);
}

std::vector<Decoded> decode_cartesian(const BagReader& r, std::uint32_t topic, InsSourceKind kind, InsSource& out,
                                      std::vector<double>& lag) {
  for (std::string& w : check(r, topic)) out.track.warnings.push_back(std::move(w));
  const MessageEncoding enc = r.topics()[topic].encoding;
  return decode_topic<Decoded>(r, topic, [&](Bytes b, const std::string& where, double& t_s) {
    Decoded d;
    if (kind == InsSourceKind::kOdometry) {
      const Odometry m = decode_odometry(b, enc, where);
      d = {to_ins_record(m, where), "", m.header.frame_id, m.child_frame_id};
    } else if (kind == InsSourceKind::kPoseWithCovariance) {
      const PoseWithCovarianceStamped m = decode_pose_with_covariance_stamped(b, enc, where);
      d = {to_ins_record(m, where), "", m.header.frame_id, ""};
    } else {
      const PoseStamped m = decode_pose_stamped(b, enc, where);
      d = {to_ins_record(m, where), "", m.header.frame_id, ""};
    }
    t_s = d.rec.t_s;
    return d;
  }, &lag);
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

std::vector<ImuSample> decode_imu(const BagReader& r, std::uint32_t topic, InsSource& out) {
  for (std::string& w : check(r, topic)) out.track.warnings.push_back(std::move(w));
  const MessageEncoding enc = r.topics()[topic].encoding;
  return decode_topic<ImuSample>(r, topic, [&](Bytes b, const std::string& where, double& t_s) {
    const Imu m = decode_imu(b, enc, where);
    t_s = m.header.stamp.seconds();
    return ImuSample{t_s, imu_orientation(m, where), m.header.frame_id};
  });
}

std::vector<TransformStamped> decode_transforms(const BagReader& r, std::uint32_t topic, InsSource& out,
                                                std::vector<double>* lag) {
  for (std::string& w : check(r, topic)) out.track.warnings.push_back(std::move(w));
  const MessageEncoding enc = r.topics()[topic].encoding;
  const auto messages = decode_topic<TFMessage>(r, topic, [&](Bytes b, const std::string& where, double& t_s) {
    TFMessage m = decode_tf_message(b, enc, where);
    t_s = m.transforms.empty() ? 0.0 : m.transforms.front().header.stamp.seconds();
    return m;
  }, lag);
  std::vector<TransformStamped> all;
  for (const TFMessage& m : messages) all.insert(all.end(), m.transforms.begin(), m.transforms.end());
  return all;
}

std::vector<Decoded> read_tf(const BagReader& r, const InsSourceTopics& topics, const InsReadOptions& options,
                             InsSource& out, std::vector<double>& lag) {
  const std::vector<TransformStamped> moving = decode_transforms(r, topics.topic, out, &lag);
  std::vector<TransformStamped> fixed;
  if (topics.partner) fixed = decode_transforms(r, *topics.partner, out, nullptr);
  TfChain chain = tf_chain(moving, fixed, options.world_frame, options.ins_frame, r.path().string());
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

// Time shift, time order, duplicates and records the source marks invalid; status counts.
void finish_records(std::vector<Decoded>& d, const InsReadOptions& options, InsSource& out) {
  for (Decoded& x : d) x.rec.t_s += options.time_shift_s;
  std::erase_if(d, [](const Decoded& x) { return !std::isfinite(x.rec.t_s); });
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
  out.track.records_skipped = out.records_invalid + out.records_duplicate + out.records_unpaired;
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

std::vector<Decoded> read_records(const BagReader& r, const InsSourceTopics& topics, const InsReadOptions& options,
                                  InsSource& out, std::vector<double>& lag) {
  switch (topics.kind) {
    case InsSourceKind::kInspvax:
    case InsSourceKind::kInspva:
      return decode_novatel(r, topics.topic, topics.kind == InsSourceKind::kInspvax, out, lag);
    case InsSourceKind::kNavSatFixImu: {
      std::vector<Decoded> fixes = decode_fixes(r, topics.topic, out, lag);
      pair_with_imu(fixes, decode_imu(r, *topics.partner, out), out, r.path().string());
      return fixes;
    }
    case InsSourceKind::kTf: return read_tf(r, topics, options, out, lag);
    default: return decode_cartesian(r, topics.topic, topics.kind, out, lag);
  }
}

}  // namespace

double median_of(std::vector<double>& values) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

InsSource read_ins_source(const BagReader& reader, const InsSourceTopics& topics, const InsReadOptions& options) {
  InsSource out;
  out.kind = topics.kind;
  out.not_used = topics.not_used;
  for (auto id : {std::optional<std::uint32_t>(topics.topic), topics.partner}) {
    if (!id) continue;
    out.topics.push_back(reader.topics()[*id].name);
    out.types.push_back(reader.topics()[*id].type);
    out.messages += reader.topics()[*id].message_count;
  }
  std::vector<double> lag;
  std::vector<Decoded> d = read_records(reader, topics, options, out, lag);
  out.stamp_minus_record_s = median_of(lag) + options.time_shift_s;
  describe_frames(out, d);
  finish_records(d, options, out);
  InsTrack& t = out.track;
  for (std::size_t i = 0; i < out.topics.size(); ++i) t.source += (i ? " + " : "") + out.topics[i];
  for (std::size_t i = 0; i < out.types.size(); ++i) t.format += (i ? " + " : "") + out.types[i];
  t.time_base = "header.stamp (the INS driver's clock)" +
                (options.time_shift_s != 0.0 ? fmt::format(" + {} s", options.time_shift_s) : std::string());
  if (t.records.size() < 2) {
    throw InputError(reader.path().string(), "",
                     fmt::format("the INS source {} ({}) gives {} usable record(s) of {} messages: too few for a trajectory",
                                 t.source, t.format, t.records.size(), out.messages));
  }
  return out;
}

}  // namespace insalign::io
