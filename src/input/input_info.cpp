#include "input/input_info.hpp"

#include <fmt/format.h>

#include <cmath>

#include "core/errors.hpp"
#include "recording/bag_reader.hpp"
#include "input/bag_dataset.hpp"
#include "recording/bag_topics.hpp"
#include "input/input_report.hpp"

namespace insalign::io {
namespace {

constexpr double kKmhPerMps = 3.6;
constexpr const char* kInsPreference =
    "INSPVAX > INSPVA > NavSatFix + Imu > Odometry > PoseWithCovarianceStamped > PoseStamped > TF";

std::string warnings_text(const std::vector<std::string>& warnings) {
  std::string s;
  for (const std::string& w : warnings) s += "warning: " + w + "\n";
  return s;
}

std::string frames_line(const LoadReport& r) {
  const bool folder = r.input_kind == "PCD folder";
  return fmt::format("  frames         {} used of {} {}({} unreadable, {} outside the poses{})\n", r.frames_used, r.frames_total,
                     folder ? ".pcd files " : "", r.frames_bad, r.frames_outside_poses,
                     folder ? fmt::format("; {} other files ignored", r.skipped_files) : "");
}

// One LiDAR of a PCD folder or a KITTI drive, then its pose source, clock and drive.
std::string describe_lidar_input(const LoadReport& r, const Dataset& d, std::size_t sample_frames) {
  const DriveSummary s = summarize_drive(d, sample_frames);
  std::string out = fmt::format("LiDAR            {} ({})\n", r.source, r.input_kind);
  out += frames_line(r);
  out += fmt::format("  points/frame   {:.0f} (mean of {} sampled frames)\n", s.mean_points_per_frame, s.frames_sampled);
  out += fmt::format("  time field     {}\n", describe_time_field(r.time_field));
  out += fmt::format("  frame times    {}\n", r.frame_time_source);
  out += describe_pose_source(r.ins);
  if (r.poses_without_frame + r.frames_without_pose + r.poses_unplaced > 0) {
    out += fmt::format("  per frame      {} poses without a frame, {} frames without a pose line, {} unplaced\n",
                       r.poses_without_frame, r.frames_without_pose, r.poses_unplaced);
  }
  if (r.clock) out += describe_clock(*r.clock);
  return out + describe_drive(s) + warnings_text(r.warnings);
}

bool has_type(const bag::BagReader& reader, bool lidar) {
  for (const bag::Topic& t : reader.topics()) {
    if (lidar ? bag::normalized_type(t.type) == "sensor_msgs/PointCloud2" : ins_source_kind(t.type).has_value()) return true;
  }
  return false;
}

BagOptions trajectory_options(const InputSpec& spec, const InputConfig& config) {
  BagOptions o;
  o.path = spec.bag;
  o.ins_topic = spec.ins_topic;
  o.world_frame = spec.world_frame, o.ins_frame = spec.ins_frame;
  if (config.clock_offset_s) o.ins_time_shift_s = -*config.clock_offset_s;
  o.read_cut_off = config.read_cut_off;
  return o;
}

std::string choices(const InputSpec& spec) {
  const std::string lidar = spec.lidar_topics.empty() ? "the only sensor_msgs/PointCloud2 topic with messages" : "--lidar-topic";
  const std::string ins = spec.ins_topic ? "--ins-topic" : fmt::format("the first kind the recording holds of {}", kInsPreference);
  return fmt::format("chosen           LiDAR by {}; INS by {}\n", lidar, ins);
}

// Topics first (they help when a choice fails), then what calibrate would read (its errors are
// exit 2 here as there); a recording without LiDAR: its INS trajectory alone, an INS that cannot
// be read a note (nothing would be calibrated from it); neither: the listing.
void describe_recording_input(const InputSpec& spec, const InputConfig& config, const InfoSink& out, std::size_t sample_frames) {
  const std::unique_ptr<bag::BagReader> reader = bag::open_bag(spec.bag, {config.read_cut_off});
  out(describe_recording(*reader));
  if (has_type(*reader, true)) {
    const LoadedInput input = load_input(spec, config);
    const std::string bag = describe_bag(*input.recording);
    out(bag.substr(bag.find('\n') + 1) + choices(spec));  // the container line came with the topics
    const auto& clock = input.reports.front().clock;
    if (clock && clock->summary != input.recording->clock.summary) out(describe_clock(*clock));  // a correction
    out(describe_drive(summarize_drive(input.lidars.front(), sample_frames)));
  } else if (has_type(*reader, false)) {
    out("no sensor_msgs/PointCloud2 topic: the INS alone\n");
    try {
      const BagTrajectory t = load_bag_trajectory(trajectory_options(spec, config));
      out(describe_trajectory(t) + describe_drive(summarize_poses(t.poses.poses())));
    } catch (const InputError& e) {  // nothing to calibrate here: the listing is the answer, the problem a note
      out(fmt::format("INS              not read: {}\n", e.what()));
    }
  } else {
    out("no sensor_msgs/PointCloud2 and no INS topic: nothing insalign reads\n");
  }
}

// --poses alone: the source's facts and its drive (OpenCalib poses without frames have no times).
void describe_pose_file(const InputSpec& spec, const InputConfig& config, const InfoSink& out) {
  const PoseSource source = read_pose_source(spec.poses, {std::nullopt, config.poses_columns, "--poses-columns (input.poses_columns)"});
  out(describe_pose_source(source.facts));
  std::vector<StampedPose> timed;
  for (const SourcePose& p : source.poses) {
    if (std::isfinite(p.t_s)) timed.push_back({p.t_s, p.T_world_ins});
  }
  if (timed.size() >= 2) {
    out(describe_drive(summarize_poses(timed)));
  } else {
    out("  drive          the poses carry no times (OpenCalib frame names): give --lidar-dir for the drive\n");
  }
  out(warnings_text(source.facts.warnings));
}

}  // namespace

std::string describe_drive(const DriveSummary& s) {
  std::string out = fmt::format("Drive\n  poses          {}\n", s.poses);
  if (s.frames > 0) {
    out += fmt::format("  frames         {} from {:.3f} to {:.3f} s ({:.3f} s)\n", s.frames, s.frame_time_begin_s,
                       s.frame_time_end_s, s.frame_time_end_s - s.frame_time_begin_s);
  }
  out += fmt::format("  time span      {:.3f} s (largest gap {:.3f} s)\n", s.duration_s, s.max_pose_gap_s);
  out += fmt::format("  distance       {:.1f} m\n", s.distance_m);
  out += fmt::format("  heading        {:.0f} deg total change, {:.0f} deg swing\n", s.heading_change_deg, s.heading_range_deg);
  out += fmt::format("  speed          min {:.1f} / mean {:.1f} / max {:.1f} km/h\n", s.speed_min_mps * kKmhPerMps,
                     s.speed_mean_mps * kKmhPerMps, s.speed_max_mps * kKmhPerMps);
  const Vec3 extent = s.bbox_max_m - s.bbox_min_m;
  out += fmt::format("  area           {:.1f} m x {:.1f} m (x, y), height range {:.2f} m\n", extent.x(), extent.y(), extent.z());
  out += fmt::format("  roll           {:.2f} to {:.2f} deg\n", s.roll_min_deg, s.roll_max_deg);
  out += fmt::format("  pitch          {:.2f} to {:.2f} deg\n", s.pitch_min_deg, s.pitch_max_deg);
  return out;
}

std::string describe_load(const LoadReport& r) {
  std::string out = fmt::format("Input            {}: {}\n", r.input_kind, r.source);
  out += frames_line(r);
  out += fmt::format("  time field     {}\n", describe_time_field(r.time_field));
  out += fmt::format("  frame times    {}\n", r.frame_time_source);
  out += describe_pose_source(r.ins);
  if (r.clock) out += describe_clock(*r.clock);
  if (!r.fiducials.empty()) out += fmt::format("Fiducials        {}\n", r.fiducials);
  out += fmt::format("Initial guess    {}\n", r.init.empty() ? "none (global initialisation from the data)" : r.init);
  return out + warnings_text(r.warnings);
}

void describe_input(const InputSpec& spec, const InputConfig& config, const InfoSink& out, std::size_t sample_frames) {
  if (spec.lidar_dirs.empty() && spec.bag.empty() && spec.kitti_raw.empty() && !spec.poses.empty()) {
    describe_pose_file(spec, config, out);
    return;
  }
  if (input_kind(spec) == InputKind::kRecording) {
    describe_recording_input(spec, config, out, sample_frames);
    return;
  }
  const LoadedInput input = load_input(spec, config);
  for (std::size_t i = 0; i < input.lidars.size(); ++i) out(describe_lidar_input(input.reports[i], input.lidars[i], sample_frames));
}

}  // namespace insalign::io
