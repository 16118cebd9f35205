// insalign info: the dataset summary a calibration engineer reads before calibrating.
#include <fmt/core.h>

#include <memory>
#include <string>

#include "cli/commands.hpp"
#include "io/dataset.hpp"

namespace insalign::cli {

namespace {

struct InfoOptions {
  std::string lidar_dir, poses;
  std::size_t sample_frames = 5;
};

const char* describe_time_field(const std::string& field) {
  if (field == "timestamp") return "timestamp (absolute seconds per point)";
  if (field == "time") return "time (seconds per point, relative to the sweep)";
  if (field == "t") return "t (nanoseconds per point from the sweep start)";
  return "none (no per-point time: sweeps cannot be deskewed)";
}

int run_info(const InfoOptions& o) {
  io::LoadReport report;
  const Dataset dataset = io::load_dataset({o.lidar_dir, o.poses, std::nullopt, std::nullopt}, &report);
  const DriveSummary s = io::summarize_drive(dataset, o.sample_frames);
  constexpr double kKmhPerMps = 3.6;

  fmt::print("LiDAR folder     {}\n", o.lidar_dir);
  fmt::print("  frames         {} used of {} .pcd files ({} unreadable, {} outside the poses; {} other files "
             "ignored)\n",
             report.frames_used, report.frames_total, report.frames_bad, report.frames_outside_poses,
             report.skipped_files);
  fmt::print("  points/frame   {:.0f} (mean of {} sampled frames)\n", s.mean_points_per_frame, s.frames_sampled);
  fmt::print("  time field     {}\n", describe_time_field(report.time_field));
  fmt::print("  frame times    {}\n", report.frame_time_source);
  fmt::print("  frame span     {:.3f} s ({:.3f} to {:.3f})\n", s.frame_time_end_s - s.frame_time_begin_s,
             s.frame_time_begin_s, s.frame_time_end_s);
  fmt::print("Poses            {} ({})\n", o.poses, report.pose_format);
  fmt::print("  poses          {} ({} without a frame, {} frames without a pose line, {} unplaced)\n", s.poses,
             report.poses_without_frame, report.frames_without_pose, report.poses_unplaced);
  fmt::print("  time span      {:.3f} s (largest gap {:.3f} s)\n", s.duration_s, s.max_pose_gap_s);
  fmt::print("  distance       {:.1f} m\n", s.distance_m);
  fmt::print("  heading        {:.0f} deg total change, {:.0f} deg swing\n", s.heading_change_deg,
             s.heading_range_deg);
  fmt::print("  speed          min {:.1f} / mean {:.1f} / max {:.1f} km/h\n", s.speed_min_mps * kKmhPerMps,
             s.speed_mean_mps * kKmhPerMps, s.speed_max_mps * kKmhPerMps);
  const Vec3 extent = s.bbox_max_m - s.bbox_min_m;
  fmt::print("  area           {:.1f} m x {:.1f} m (x, y), height range {:.2f} m\n", extent.x(), extent.y(),
             extent.z());
  fmt::print("  roll           {:.2f} to {:.2f} deg\n", s.roll_min_deg, s.roll_max_deg);
  fmt::print("  pitch          {:.2f} to {:.2f} deg\n", s.pitch_min_deg, s.pitch_max_deg);
  for (const std::string& w : report.warnings) fmt::print("warning: {}\n", w);
  return kExitOk;
}

}  // namespace

Command make_info_command() {
  auto options = std::make_shared<InfoOptions>();
  Command command;
  command.setup = [options](CLI::App& app) {
    CLI::App* sub = app.add_subcommand("info", "Summarise a dataset: frames, points, time span, drive figures");
    sub->add_option("--lidar-dir", options->lidar_dir, "folder of <frame-name>.pcd sweeps")->required();
    sub->add_option("--poses", options->poses, "pose file (OpenCalib per-frame lines or TUM)")->required();
    sub->add_option("--sample-frames", options->sample_frames, "frames decoded to count points")
        ->capture_default_str();
    return sub;
  };
  command.run = [options] { return run_info(*options); };
  return command;
}

}  // namespace insalign::cli
