#include "recording/bag_frames.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <map>

#include "core/errors.hpp"
#include "recording/message_definitions.hpp"
#include "recording/ros_serialization.hpp"
#include "recording/bag_ins.hpp"
#include "recording/bag_topics.hpp"

namespace insalign::io {

namespace {

using namespace bag;

constexpr std::size_t kSampledClouds = 5;         // first, quartiles, last
constexpr std::size_t kStampPrefixBytes = 64;     // encapsulation + seq + stamp, with room to spare
constexpr double kStampToEndTolerance_s = 0.003;  // sampled offsets varying more: frame times uncertain
constexpr double kSameStamp_s = 1e-6;

std::string where_of(const BagReader& r, std::uint32_t topic, std::size_t i) {
  return fmt::format("{} {} message {}", r.path().string(), r.topics()[topic].name, i);
}

// header.stamp from the first bytes of a message (ROS 1: seq then stamp; CDR: stamp first).
double read_stamp_s(Bytes prefix, MessageEncoding encoding, const std::string& where) {
  MessageReader in(prefix, encoding, where, "std_msgs/Header");
  if (!in.cdr()) (void)in.read<std::uint32_t>("header.seq");
  return in.read_time("header.stamp").seconds();
}

std::vector<std::size_t> sample_indexes(std::size_t n) {
  std::vector<std::size_t> out;
  for (std::size_t k = 0; k < kSampledClouds && n > 0; ++k) {
    const std::size_t i = n == 1 ? 0 : k * (n - 1) / (kSampledClouds - 1);
    if (out.empty() || out.back() != i) out.push_back(i);
  }
  return out;
}

// Decodes the sampled clouds: convention, fields, and the stamp-to-end offset.
void learn_from_samples(const BagReader& r, std::uint32_t topic, const std::vector<MessageRef>& refs,
                        LidarFrames& out, BagCounters& counters) {
  LidarTopicReport& rep = out.report;
  const MessageEncoding enc = r.topics()[topic].encoding;
  std::vector<double> offsets;
  std::map<std::string, std::size_t> conventions;
  double points = 0.0;
  for (std::size_t i : sample_indexes(refs.size())) {
    const BagReader::SharedMessage message = r.read_shared(refs[i]);
    PointCloudInfo info;
    const Sweep sweep = decode_sweep(message.bytes, enc, where_of(r, topic, i), &info);
    ++counters.clouds_decoded;
    offsets.push_back(sweep.t_end_s - info.header_stamp_s);
    points += static_cast<double>(sweep.size());
    if (conventions.empty()) {
      rep.fields = info.fields, rep.frame_id = info.frame_id;
      rep.time_convention = info.time_convention, rep.time_field = info.time_field;
      rep.time_description = info.time_description;
    }
    ++conventions[info.time_description];
    if (info.dropped_nonfinite + info.dropped_time_outside > 0) {
      out.warnings.push_back(fmt::format("{} message {}: {} of {} points dropped (non-finite: {}, time over {} s before "
                                         "the sweep end: {})",
                                         rep.topic, i, info.dropped_nonfinite + info.dropped_time_outside, info.points,
                                         info.dropped_nonfinite, kMaxSweepSpan_s, info.dropped_time_outside));
    }
  }
  rep.frames_sampled = offsets.size();
  rep.mean_points = points / static_cast<double>(std::max<std::size_t>(1, offsets.size()));
  const auto [lo, hi] = std::minmax_element(offsets.begin(), offsets.end());
  rep.stamp_to_end_spread_s = *hi - *lo;
  rep.stamp_to_end_s = median_of(offsets);
  if (conventions.size() > 1) {
    out.warnings.push_back(fmt::format("{}: the sampled clouds differ in their per-point time ({} kinds); using '{}'",
                                       rep.topic, conventions.size(), rep.time_description));
  }
  if (rep.time_convention == PointTimeConvention::kNone) {
    out.warnings.push_back(rep.topic + ": no per-point time (" + rep.time_description +
                           "): frame time = header.stamp, no deskew");
  }
  if (rep.stamp_to_end_spread_s > kStampToEndTolerance_s) {
    out.warnings.push_back(fmt::format("{}: the sweep end lies {:.4f} .. {:.4f} s after header.stamp over the {} "
                                       "sampled clouds (more than {} ms apart): frame times are known to that much only",
                                       rep.topic, *lo, *hi, rep.frames_sampled, kStampToEndTolerance_s * 1e3));
  }
}

}  // namespace

LidarTopicIndexer::LidarTopicIndexer(const BagReader& r, std::uint32_t topic, BagCounters& counters) : reader_(r) {
  const Topic& t = r.topics()[topic];
  out_.topic = topic;
  out_.report.topic = t.name;
  out_.report.name = lidar_name(t.name);
  out_.report.type = t.type;
  out_.report.messages = t.message_count;
  out_.warnings = check_definition(t, r.path().string()).warnings;
  const std::vector<MessageRef> refs = r.messages(topic);
  if (refs.empty()) throw InputError(r.path().string(), "", t.name + " has no messages");
  learn_from_samples(r, topic, refs, out_, counters);
  frames_.resize(refs.size());
  lag_.resize(refs.size());
}

TopicPass LidarTopicIndexer::pass() {
  const std::uint32_t topic = out_.topic;
  return {topic, kStampPrefixBytes, [this, topic](std::size_t i, const MessageRef& ref, Bytes prefix) {
            const double stamp_s = read_stamp_s(prefix, reader_.topics()[topic].encoding, where_of(reader_, topic, i));
            frames_[i] = {ref, stamp_s, stamp_s + out_.report.stamp_to_end_s};
            lag_[i] = frames_[i].t_end_s - static_cast<double>(ref.log_time_ns) * 1e-9;
          }};
}

LidarFrames LidarTopicIndexer::finish() {
  const std::string& name = out_.report.topic;
  out_.report.stamp_minus_record_s = median_of(lag_);
  const auto by_time = [](const CloudFrame& a, const CloudFrame& b) { return a.t_end_s < b.t_end_s; };
  if (!std::is_sorted(frames_.begin(), frames_.end(), by_time)) {
    out_.warnings.push_back(name + ": header stamps are not in record order; frames sorted by stamp");
    std::stable_sort(frames_.begin(), frames_.end(), by_time);
  }
  for (const CloudFrame& f : frames_) {
    if (!out_.frames.empty() && f.t_end_s - out_.frames.back().t_end_s < kSameStamp_s) {
      ++out_.report.frames_duplicate;
    } else {
      out_.frames.push_back(f);
    }
  }
  if (out_.report.frames_duplicate > 0) {
    out_.warnings.push_back(fmt::format("{}: skipped {} clouds with the stamp of the cloud before", name,
                                        out_.report.frames_duplicate));
  }
  return std::move(out_);
}

LidarFrames index_lidar_topic(const BagReader& r, std::uint32_t topic, BagCounters& counters) {
  LidarTopicIndexer indexer(r, topic, counters);
  read_in_record_order(r, {indexer.pass()});
  return indexer.finish();
}

FrameSource make_frame_source(std::shared_ptr<const BagReader> reader, std::uint32_t topic,
                              const std::vector<CloudFrame>& frames, std::shared_ptr<BagCounters> counters) {
  struct Loader {
    std::shared_ptr<const BagReader> reader;
    std::uint32_t topic = 0;
    std::vector<MessageRef> refs;
    std::vector<std::string> names;
    std::shared_ptr<BagCounters> counters;
  };
  auto loader = std::make_shared<Loader>();
  FrameSource source;
  for (const CloudFrame& f : frames) {
    const std::string name = fmt::format("{:.6f}", f.t_end_s);
    source.frames.push_back({name, f.t_end_s});
    loader->refs.push_back(f.ref);
    loader->names.push_back(name);
  }
  loader->reader = std::move(reader);
  loader->topic = topic;
  loader->counters = std::move(counters);
  source.load = [loader](std::size_t i) {
    const BagReader& r = *loader->reader;
    // Decoded where the reader holds the message (its decompressed chunk): no copy of the cloud.
    const BagReader::SharedMessage message = r.read_shared(loader->refs.at(i));
    Sweep sweep = decode_sweep(message.bytes, r.topics()[loader->topic].encoding,
                               fmt::format("{} {} frame {}", r.path().string(), r.topics()[loader->topic].name, i));
    ++loader->counters->clouds_decoded;
    sweep.name = loader->names[i];
    return sweep;
  };
  return source;
}

}  // namespace insalign::io
