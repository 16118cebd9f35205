// The INS source of a recording (bag_topics.hpp chooses it) read into an InsTrack: every message
// decoded (in parallel, in file order), times = header.stamp (the INS driver's clock, not the
// bag's record time), sorted, duplicates and records the INS itself marks invalid dropped and
// counted. What `ins` and `world` are follows CONVENTIONS.md "Recordings: ROS bags":
//   INSPVA(X)        ins = NovAtel SPAN vehicle frame (x right, y forward, z up), world = local ENU
//   NavSatFix + Imu  ins = the Imu's frame (orientation from the Imu, slerped to each fix's stamp)
//   Odometry, Pose*  ins = the child frame (the pose's frame), world = header.frame_id
//   TF               ins = --ins-frame, world = --world-frame (bag_tf.hpp; automatic when obvious)
#pragma once

#include <cstddef>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "recording/bag_reader.hpp"
#include "recording/bag_scan.hpp"
#include "recording/bag_topics.hpp"
#include "inslog/ins_track.hpp"

namespace insalign::io {

struct InsReadOptions {
  std::string world_frame, ins_frame;  ///< TF only; empty: the obvious chain (bag_tf.hpp)
  double time_shift_s = 0.0;           ///< added to every INS stamp (a known clock offset)
};

/// The source as read, with what a person needs to trust it.
struct InsSource {
  InsSourceKind kind = InsSourceKind::kOdometry;
  std::vector<std::string> topics, types;  ///< one topic; NavSatFix then Imu; /tf then /tf_static
  std::size_t messages = 0;                ///< messages read (all topics)
  InsTrack track;                          ///< records in time order; format, frames, datum, warnings
  std::string ins_frame_id;                ///< the frame name `ins` is ("novatel", "imu_link", "base_link")
  std::string world_frame_id;              ///< "local ENU" for geodetic sources, else the frame name
  /// Solution or INS status as the messages state it, with counts ("INS_SOLUTION_GOOD", "GBAS_FIX").
  std::vector<std::pair<std::string, std::size_t>> status_counts;
  std::size_t records_invalid = 0;     ///< dropped: the source marks them unusable
  std::size_t records_duplicate = 0;   ///< dropped: same stamp as the record before
  std::size_t records_unpaired = 0;    ///< NavSatFix + Imu: fixes with no Imu orientation near them
  std::size_t records_unusable = 0;    ///< dropped: values not finite, latitude or longitude out of range
  /// Median of header.stamp - record time over the messages (s): compared with the LiDAR's to
  /// tell a clock difference from a late start.
  double stamp_minus_record_s = std::numeric_limits<double>::quiet_NaN();
  std::vector<std::string> not_used;   ///< other INS topics of the bag
};

/// The chosen source read in two steps, so that its messages can share one pass over the bag with
/// the clouds' stamps (bag_scan.hpp): run passes(), then finish(). Throws InputError(bag path or
/// "path topic message N", location, what) for undecodable messages, a definition that does not
/// match, no usable record, an ambiguous TF chain.
class InsSourceReader {
 public:
  InsSourceReader(const bag::BagReader& reader, const InsSourceTopics& topics, const InsReadOptions& options);
  ~InsSourceReader();
  InsSourceReader(const InsSourceReader&) = delete;
  InsSourceReader& operator=(const InsSourceReader&) = delete;
  /// The topics to read whole, each message decoded by its handler (valid while this lives).
  std::vector<TopicPass> passes();
  InsSource finish();

 private:
  struct State;
  std::unique_ptr<State> s_;
};

/// Both steps, with a pass of the INS topics alone.
InsSource read_ins_source(const bag::BagReader& reader, const InsSourceTopics& topics, const InsReadOptions& options);

/// Median of values (NaN for none); `values` is reordered.
double median_of(std::vector<double>& values);

}  // namespace insalign::io
