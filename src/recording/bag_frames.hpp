// The frames of one LiDAR topic without decoding its clouds: header.stamp of every message (from
// the first bytes of each, BagReader::read_prefix), the per-point time convention and the offset
// from header.stamp to the sweep end learned from a few fully decoded clouds (first, quartiles,
// last), and a FrameSource that decodes a cloud when a stage asks for it.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "core/dataset.hpp"
#include "recording/bag_reader.hpp"
#include "recording/pointcloud2.hpp"
#include "recording/bag_scan.hpp"

namespace insalign::io {

/// Counts for tests and benchmarks, shared by the FrameSources of one load.
struct BagCounters {
  std::atomic<std::size_t> clouds_decoded{0};  ///< full PointCloud2 decodes (at open and by load)
};

struct LidarTopicReport {
  std::string topic, name, type, frame_id;
  std::size_t messages = 0;
  bag::PointTimeConvention time_convention = bag::PointTimeConvention::kNone;
  std::string time_field;           ///< "timestamp", "time", "t", "offset_time" or ""
  std::string time_description;     ///< "'t' uint32: nanoseconds after header.stamp (Ouster)"
  std::vector<std::string> fields;  ///< of the first sampled cloud: "x float32", ...
  std::size_t frames_sampled = 0;   ///< decoded at open
  double mean_points = 0.0;         ///< over the sampled clouds
  double stamp_to_end_s = 0.0;         ///< median (sweep end - header.stamp) over the sampled clouds
  double stamp_to_end_spread_s = 0.0;  ///< max - min of it over the sampled clouds
  std::size_t frames_used = 0;
  std::size_t frames_outside_ins = 0;  ///< skipped: no INS pose at their time
  std::size_t frames_duplicate = 0;    ///< skipped: the stamp of the frame before
  double t_begin_s = 0.0, t_end_s = 0.0, rate_hz = 0.0;  ///< frames used (LiDAR clock)
  /// Median of (frame time - record time) over the messages (s), for the clock check.
  double stamp_minus_record_s = std::numeric_limits<double>::quiet_NaN();
};

struct CloudFrame {
  bag::MessageRef ref;
  double stamp_s = 0.0;  ///< header.stamp
  double t_end_s = 0.0;  ///< stamp + the topic's stamp-to-end offset
};

struct LidarFrames {
  std::uint32_t topic = 0;
  LidarTopicReport report;         ///< all but frames_used / frames_outside_ins / t_* / rate
  std::vector<CloudFrame> frames;  ///< time order, duplicates dropped
  std::vector<std::string> warnings;
};

/// Indexes one PointCloud2 topic in two steps, so that the stamps can share one pass over the bag
/// with the INS messages (bag_scan.hpp): the constructor decodes the sampled clouds, pass() reads
/// every stamp, finish() orders the frames. Throws InputError for a cloud that does not decode (a
/// missing x/y/z names the topic and message), a definition that does not match, or no messages.
class LidarTopicIndexer {
 public:
  LidarTopicIndexer(const bag::BagReader& reader, std::uint32_t topic, BagCounters& counters);
  TopicPass pass();  ///< valid while this lives
  LidarFrames finish();

 private:
  const bag::BagReader& reader_;
  LidarFrames out_;
  std::vector<CloudFrame> frames_;
  std::vector<double> lag_;
};

/// Both steps, with a pass of this topic alone.
LidarFrames index_lidar_topic(const bag::BagReader& reader, std::uint32_t topic, BagCounters& counters);

/// A FrameSource over `frames` (names = frame time, microseconds, as PCD frames are named):
/// load(i) reads and decodes one message; thread-safe.
FrameSource make_frame_source(std::shared_ptr<const bag::BagReader> reader, std::uint32_t topic,
                              const std::vector<CloudFrame>& frames, std::shared_ptr<BagCounters> counters);

}  // namespace insalign::io
