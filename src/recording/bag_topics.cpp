#include "recording/bag_topics.hpp"

#include <algorithm>
#include <fmt/format.h>

#include "core/errors.hpp"

namespace insalign::io {

namespace {

using bag::BagReader;
using bag::Topic;

constexpr InsSourceKind kPreference[] = {InsSourceKind::kInspvax,  InsSourceKind::kInspva,
                                         InsSourceKind::kNavSatFixImu, InsSourceKind::kOdometry,
                                         InsSourceKind::kPoseWithCovariance, InsSourceKind::kPose,
                                         InsSourceKind::kTf};

bool is_pointcloud2(const Topic& t) { return bag::normalized_type(t.type) == "sensor_msgs/PointCloud2"; }
bool is_type(const Topic& t, const char* type) { return bag::normalized_type(t.type) == type; }
bool is_tf_message(const Topic& t) { return is_type(t, "tf2_msgs/TFMessage") || is_type(t, "tf/tfMessage"); }
bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}
bool is_tf_static(const Topic& t) { return is_tf_message(t) && (t.name == "/tf_static" || ends_with(t.name, "/tf_static")); }
bool is_tf_dynamic(const Topic& t) { return is_tf_message(t) && (t.name == "/tf" || ends_with(t.name, "/tf")); }

std::string list_topics(const BagReader& reader, const std::vector<std::uint32_t>& ids) {
  std::string out;
  for (std::uint32_t i : ids) out += (out.empty() ? "" : ", ") + describe_topic(reader.topics()[i]);
  return out.empty() ? "(none)" : out;
}

std::string list_all_topics(const BagReader& reader) {
  std::string out;
  for (const Topic& t : reader.topics()) out += (out.empty() ? "" : ", ") + t.name + " (" + t.type + ")";
  return out.empty() ? "(no topics)" : out;
}

[[noreturn]] void fail(const BagReader& reader, const std::string& what) {
  throw InputError(reader.path().string(), "", what);
}

std::optional<std::uint32_t> find_topic(const BagReader& reader, const std::string& name) {
  for (std::uint32_t i = 0; i < reader.topics().size(); ++i) {
    if (reader.topics()[i].name == name) return i;
  }
  return std::nullopt;
}

// Topics with messages that fit `pred`.
template <typename Pred>
std::vector<std::uint32_t> topics_where(const BagReader& reader, Pred pred) {
  std::vector<std::uint32_t> out;
  for (std::uint32_t i = 0; i < reader.topics().size(); ++i) {
    const Topic& t = reader.topics()[i];
    if (t.message_count > 0 && pred(t)) out.push_back(i);
  }
  return out;
}

// Topics that can be (part of) an INS source of `kind`; for kNavSatFixImu the fixes.
std::vector<std::uint32_t> sources_of(const BagReader& reader, InsSourceKind kind) {
  return topics_where(reader, [&](const Topic& t) {
    if (kind == InsSourceKind::kTf) return is_tf_dynamic(t);
    if (kind == InsSourceKind::kNavSatFixImu) return is_type(t, "sensor_msgs/NavSatFix");
    return ins_source_kind(t.type) == kind;
  });
}

std::vector<std::uint32_t> imu_topics(const BagReader& reader) {
  return topics_where(reader, [](const Topic& t) { return is_type(t, "sensor_msgs/Imu"); });
}

std::optional<std::uint32_t> tf_static_topic(const BagReader& reader) {
  const auto found = topics_where(reader, is_tf_static);
  if (found.empty()) return std::nullopt;
  return found.front();
}

void fill_not_used(const BagReader& reader, InsSourceTopics& chosen) {
  for (std::uint32_t i = 0; i < reader.topics().size(); ++i) {
    const Topic& t = reader.topics()[i];
    if (i == chosen.topic || (chosen.partner && i == *chosen.partner) || t.message_count == 0) continue;
    if (!ins_source_kind(t.type) || is_tf_static(t)) continue;
    if (is_tf_message(t) && !is_tf_dynamic(t)) continue;
    chosen.not_used.push_back(t.name + " (" + t.type + ", " + std::to_string(t.message_count) + " msgs)");
  }
}

// The unique Imu (or NavSatFix) that pairs with the other half of a NavSatFix + Imu source.
std::uint32_t unique_partner(const BagReader& reader, const std::vector<std::uint32_t>& candidates,
                             const std::string& what, const std::string& for_topic) {
  if (candidates.size() == 1) return candidates.front();
  if (candidates.empty()) fail(reader, fmt::format("{} needs a {} topic to pair with; the bag has none", for_topic, what));
  fail(reader, fmt::format("{} pairs with a {} topic, and there are several: {}; give both as --ins-topic FIX,IMU",
                           for_topic, what, list_topics(reader, candidates)));
}

InsSourceTopics requested_pair(const BagReader& reader, const std::string& requested) {
  const auto comma = requested.find(',');
  const std::string a = requested.substr(0, comma), b = requested.substr(comma + 1);
  const auto ia = find_topic(reader, a), ib = find_topic(reader, b);
  if (!ia || !ib) fail(reader, fmt::format("--ins-topic {}: no topic {} in the bag", requested, !ia ? a : b));
  InsSourceTopics out{InsSourceKind::kNavSatFixImu, *ia, *ib, {}};
  if (is_type(reader.topics()[*ia], "sensor_msgs/Imu")) std::swap(out.topic, *out.partner);
  if (!is_type(reader.topics()[out.topic], "sensor_msgs/NavSatFix") ||
      !is_type(reader.topics()[*out.partner], "sensor_msgs/Imu")) {
    fail(reader, fmt::format("--ins-topic {}: a pair must be one sensor_msgs/NavSatFix and one sensor_msgs/Imu topic",
                             requested));
  }
  return out;
}

InsSourceTopics requested_source(const BagReader& reader, const std::string& requested) {
  if (requested.find(',') != std::string::npos) return requested_pair(reader, requested);
  const auto id = find_topic(reader, requested);
  std::vector<std::uint32_t> any;
  for (InsSourceKind k : kPreference) {
    for (std::uint32_t i : sources_of(reader, k)) any.push_back(i);
  }
  if (!id) fail(reader, fmt::format("--ins-topic {}: no such topic; INS topics in the bag: {}", requested, list_topics(reader, any)));
  const Topic& t = reader.topics()[*id];
  const auto kind = ins_source_kind(t.type);
  if (!kind) {
    fail(reader, fmt::format("--ins-topic {} has type {}, which is not an INS message insalign reads (INS topics: {})",
                             requested, t.type, list_topics(reader, any)));
  }
  InsSourceTopics out{*kind, *id, std::nullopt, {}};
  if (*kind == InsSourceKind::kTf) {
    out.partner = tf_static_topic(reader);
  } else if (*kind == InsSourceKind::kNavSatFixImu && is_type(t, "sensor_msgs/NavSatFix")) {
    out.partner = unique_partner(reader, imu_topics(reader), "sensor_msgs/Imu", requested);
  } else if (*kind == InsSourceKind::kNavSatFixImu) {
    out.partner = *id;
    out.topic = unique_partner(reader, sources_of(reader, InsSourceKind::kNavSatFixImu), "sensor_msgs/NavSatFix", requested);
  }
  return out;
}

std::optional<InsSourceTopics> automatic_source(const BagReader& reader) {
  for (InsSourceKind kind : kPreference) {
    const std::vector<std::uint32_t> found = sources_of(reader, kind);
    if (found.empty()) continue;
    std::optional<std::uint32_t> partner;
    if (kind == InsSourceKind::kNavSatFixImu) {
      const std::vector<std::uint32_t> imus = imu_topics(reader);
      if (imus.empty()) continue;  // a fix alone has no orientation: try the next kind
      if (found.size() > 1 || imus.size() > 1) {
        fail(reader, fmt::format("cannot choose the INS source: NavSatFix topics {} and Imu topics {}; choose with "
                                 "--ins-topic FIX,IMU",
                                 list_topics(reader, found), list_topics(reader, imus)));
      }
      partner = imus.front();
    } else if (found.size() > 1) {
      fail(reader, fmt::format("cannot choose the INS source: several {} topics: {}; choose with --ins-topic",
                               ins_source_name(kind), list_topics(reader, found)));
    } else if (kind == InsSourceKind::kTf) {
      partner = tf_static_topic(reader);
    }
    return InsSourceTopics{kind, found.front(), partner, {}};
  }
  return std::nullopt;
}

}  // namespace

const char* ins_source_name(InsSourceKind kind) {
  switch (kind) {
    case InsSourceKind::kInspvax: return "NovAtel INSPVAX";
    case InsSourceKind::kInspva: return "NovAtel INSPVA";
    case InsSourceKind::kNavSatFixImu: return "NavSatFix + Imu";
    case InsSourceKind::kOdometry: return "Odometry";
    case InsSourceKind::kPoseWithCovariance: return "PoseWithCovarianceStamped";
    case InsSourceKind::kPose: return "PoseStamped";
    case InsSourceKind::kTf: return "TF";
  }
  return "?";
}

std::optional<InsSourceKind> ins_source_kind(const std::string& type) {
  const std::string t = bag::normalized_type(type);
  if (t == "novatel_oem7_msgs/INSPVAX" || t == "novatel_gps_msgs/Inspvax") return InsSourceKind::kInspvax;
  if (t == "novatel_oem7_msgs/INSPVA" || t == "novatel_gps_msgs/Inspva") return InsSourceKind::kInspva;
  if (t == "sensor_msgs/NavSatFix" || t == "sensor_msgs/Imu") return InsSourceKind::kNavSatFixImu;
  if (t == "nav_msgs/Odometry") return InsSourceKind::kOdometry;
  if (t == "geometry_msgs/PoseWithCovarianceStamped") return InsSourceKind::kPoseWithCovariance;
  if (t == "geometry_msgs/PoseStamped") return InsSourceKind::kPose;
  if (t == "tf2_msgs/TFMessage" || t == "tf/tfMessage") return InsSourceKind::kTf;
  return std::nullopt;
}

std::string lidar_name(const std::string& topic) {
  std::string name = topic;
  while (!name.empty() && name.front() == '/') name.erase(name.begin());
  std::replace(name.begin(), name.end(), '/', '_');
  return name;
}

std::string describe_topic(const Topic& topic) {
  return fmt::format("{} ({} msgs)", topic.name, topic.message_count);
}

std::vector<std::uint32_t> choose_lidar_topics(const BagReader& reader, const std::vector<std::string>& requested) {
  const std::vector<std::uint32_t> clouds = topics_where(reader, is_pointcloud2);
  if (requested.empty()) {
    if (clouds.size() == 1) return clouds;
    if (clouds.empty()) {
      std::string container;  // a cut-off recording says where it stops: that is usually why
      for (const std::string& w : reader.warnings()) container += "; " + w;
      fail(reader, "no sensor_msgs/PointCloud2 topic with messages (topics: " + list_all_topics(reader) + ")" + container);
    }
    fail(reader, fmt::format("several LiDAR topics, candidates: {}; choose with --lidar-topic", list_topics(reader, clouds)));
  }
  std::vector<std::uint32_t> out;
  for (const std::string& name : requested) {
    const auto id = find_topic(reader, name);
    if (!id) fail(reader, fmt::format("--lidar-topic {}: no such topic; PointCloud2 topics: {}", name, list_topics(reader, clouds)));
    const Topic& t = reader.topics()[*id];
    if (!is_pointcloud2(t)) {
      fail(reader, fmt::format("--lidar-topic {} has type {}, not sensor_msgs/PointCloud2 (PointCloud2 topics: {})", name,
                               t.type, list_topics(reader, clouds)));
    }
    if (t.message_count == 0) fail(reader, fmt::format("--lidar-topic {} has no messages", name));
    if (std::find(out.begin(), out.end(), *id) != out.end()) fail(reader, "--lidar-topic " + name + " given twice");
    out.push_back(*id);
  }
  return out;
}

InsSourceTopics choose_ins_source(const BagReader& reader, const std::optional<std::string>& requested) {
  std::optional<InsSourceTopics> chosen;
  if (requested) {
    chosen = requested_source(reader, *requested);
  } else {
    chosen = automatic_source(reader);
  }
  if (!chosen) {
    fail(reader, "no INS source: insalign reads NovAtel INSPVAX/INSPVA, NavSatFix + Imu, Odometry, "
                 "PoseWithCovarianceStamped, PoseStamped or TF (/tf); the bag has: " +
                     list_all_topics(reader));
  }
  fill_not_used(reader, *chosen);
  return *chosen;
}

}  // namespace insalign::io
