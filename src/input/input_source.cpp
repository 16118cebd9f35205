#include "input/input_source.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "core/errors.hpp"
#include "files/fiducials.hpp"
#include "files/installed_extrinsic.hpp"
#include "inslog/kitti.hpp"
#include "files/read_file.hpp"

namespace insalign::io {
namespace {

std::string fiducial_words(const std::vector<Fiducial>& f, const std::optional<std::filesystem::path>& path) {
  if (!path) return "";
  const bool geodetic = is_wgs84_fiducial_text(read_file(*path));
  return fmt::format("{} {} ({})", f.size(), geodetic ? "geodetic (# wgs84) through the INS's local ENU frame" : "in the world frame",
                     path->string());
}

BagOptions bag_options(const InputSpec& spec, const InputConfig& config) {
  BagOptions o;
  o.path = spec.bag;
  o.lidar_topics = spec.lidar_topics;
  o.ins_topic = spec.ins_topic;
  o.world_frame = spec.world_frame, o.ins_frame = spec.ins_frame;
  if (spec.inits.size() == 1) o.init = spec.inits.front();  // several: set per LiDAR after loading
  o.fiducials = spec.fiducials;
  if (config.clock_offset_s) o.ins_time_shift_s = -*config.clock_offset_s;
  o.read_cut_off = config.read_cut_off;
  return o;
}

// The recording's own clock analysis as the clock decision (no correction needed, or given).
ClockAlignment recording_clock(const ClockReport& c, const InputConfig& config) {
  ClockAlignment a;
  a.lidar_begin_s = c.lidar_begin_s, a.lidar_end_s = c.lidar_end_s, a.ins_begin_s = c.ins_begin_s, a.ins_end_s = c.ins_end_s;
  a.inside_fraction = c.frames_inside_fraction;
  a.offset_s = config.clock_offset_s.value_or(0.0);
  a.meaning = config.clock_offset_s ? "given by input.clock_offset_s" : "the clocks agree";
  a.decision = config.clock_offset_s ? fmt::format("INS times shifted by {:+g} s (input.clock_offset_s)", -*config.clock_offset_s)
                                      : "the clocks agree";
  a.summary = c.summary;
  return a;
}

// load_bag, and once more with the INS shifted when its clock analysis finds a known gap; the
// correction is then confirmed by the LiDAR motion.
BagDatasets load_recording(const InputSpec& spec, const InputConfig& config, std::optional<ClockAlignment>& clock) {
  BagOptions o = bag_options(spec, config);
  try {
    BagDatasets b = load_bag(o);
    clock = recording_clock(b.report.clock, config);
    return b;
  } catch (const ClockGapError& e) {
    if (config.clock_offset_s || !e.clock().explanation || !config.clock.enabled) throw;
    const ClockGapExplanation& gap = *e.clock().explanation;
    o.ins_time_shift_s = -gap.whole_s;
    BagDatasets b = load_bag(o);
    clock = confirm_clock_correction(b.lidars.front().frames, b.lidars.front().poses, gap.whole_s, gap.meaning, config.clock,
                                     spec.bag.string());
    clock->ins_begin_s = e.clock().ins_begin_s, clock->ins_end_s = e.clock().ins_end_s;
    clock->summary = e.clock().summary + "; " + clock->decision;
    return b;
  }
}

LoadedInput load_recording_input(const InputSpec& spec, const InputConfig& config) {
  std::optional<ClockAlignment> clock;
  BagDatasets b = load_recording(spec, config, clock);
  LoadedInput out;
  out.kind = InputKind::kRecording;
  out.lidar_names = b.lidar_names;
  for (std::size_t i = 0; i < b.lidars.size(); ++i) {
    LoadReport r = to_load_report(b.report, i);
    r.input_kind = "recording";
    r.source = fmt::format("{} topic {}", spec.bag.string(), b.report.lidars[i].topic);
    r.ins = recording_ins_facts(b.report.ins, spec.bag.string());
    r.clock = clock;
    r.warnings.insert(r.warnings.end(), clock->warnings.begin(), clock->warnings.end());
    r.fiducials = fiducial_words(b.lidars[i].fiducials, spec.fiducials);
    if (spec.inits.size() > 1) b.lidars[i].T_ins_lidar_init = read_init_extrinsic(spec.inits.at(i));
    if (!spec.inits.empty()) r.init = "--init " + spec.inits[spec.inits.size() > 1 ? i : 0].string();
    out.reports.push_back(std::move(r));
  }
  out.lidars = std::move(b.lidars);
  out.recording = std::move(b.report);
  return out;
}

std::string folder_name(const std::filesystem::path& folder) {
  std::filesystem::path p = folder.lexically_normal();
  if (p.filename().empty()) p = p.parent_path();
  return p.filename().string();
}

std::optional<std::filesystem::path> init_of(const InputSpec& spec, std::size_t lidar) {
  if (spec.inits.empty()) return std::nullopt;
  return spec.inits.at(lidar);
}

// Every folder with the same pose source; each LiDAR's clock decided on its own.
LoadedInput load_pcd_folders(const InputSpec& spec, const InputConfig& config) {
  LoadedInput out;
  out.kind = InputKind::kPcdFolder;
  for (std::size_t i = 0; i < spec.lidar_dirs.size(); ++i) {
    LoadReport r;
    out.lidars.push_back(load_dataset({spec.lidar_dirs[i], spec.poses, init_of(spec, i), spec.fiducials}, config, &r));
    out.reports.push_back(std::move(r));
    out.lidar_names.push_back(folder_name(spec.lidar_dirs[i]));
  }
  return out;
}

void require_distinct_names(const LoadedInput& input, const std::string& option) {
  for (std::size_t i = 0; i < input.lidar_names.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if (input.lidar_names[i] == input.lidar_names[j]) {
        throw InputError("command line", "", fmt::format("two LiDARs are named '{}' ({} {} and {}): their outputs would "
                                                         "collide; give folders with different names",
                                                         input.lidar_names[i], option, j + 1, i + 1));
      }
    }
  }
}

void require(bool ok, const std::string& what) {
  if (!ok) throw InputError("command line", "", what);
}

}  // namespace

InputKind input_kind(const InputSpec& spec) {
  const bool pcd = !spec.lidar_dirs.empty(), bag = !spec.bag.empty(), kitti = !spec.kitti_raw.empty();
  require(static_cast<int>(pcd) + static_cast<int>(bag) + static_cast<int>(kitti) <= 1,
          "give one input: --lidar-dir with --poses, --bag, or --kitti-raw");
  require(spec.poses.empty() || pcd, "--poses goes with --lidar-dir (a recording or a KITTI drive brings its own INS)");
  require(pcd || bag || kitti, "no input: give --lidar-dir DIR --poses FILE, --bag PATH, or --kitti-raw DRIVE_DIR");
  require(!pcd || !spec.poses.empty(), "--lidar-dir needs --poses FILE (the INS poses)");
  for (const auto& dir : spec.lidar_dirs) require(!dir.empty(), "--lidar-dir needs a folder");
  require(bag || (spec.lidar_topics.empty() && !spec.ins_topic && spec.world_frame.empty() && spec.ins_frame.empty()),
          "--lidar-topic, --ins-topic, --world-frame and --ins-frame go with --bag");
  const std::size_t lidars = pcd ? spec.lidar_dirs.size() : bag ? std::max<std::size_t>(1, spec.lidar_topics.size()) : 1;
  require(spec.inits.size() <= 1 || spec.inits.size() == lidars,
          fmt::format("{} --init for {} LiDARs: give one --init per LiDAR, in the order of {}", spec.inits.size(), lidars,
                      pcd ? "--lidar-dir" : "--lidar-topic"));
  require(spec.inits.size() <= lidars,
          fmt::format("{} --init for {} LiDAR: a recording with one LiDAR topic takes one --init", spec.inits.size(), lidars));
  return pcd ? InputKind::kPcdFolder : bag ? InputKind::kRecording : InputKind::kKittiRaw;
}

PoseSourceFacts recording_ins_facts(const InsReport& ins, const std::string& path) {
  PoseSourceFacts f;
  f.path = path;
  f.kind = "bag";
  std::string topics;
  for (std::size_t i = 0; i < ins.topics.size(); ++i) topics += fmt::format("{}{} ({})", i ? " + " : "", ins.topics[i], ins.types[i]);
  f.format = ins.kind + ": " + topics;
  f.time_base = ins.time_base, f.body_frame = ins.ins_frame, f.height_datum = ins.height_datum;
  f.world_frame = ins.world_frame;
  f.records = ins.records, f.records_skipped = ins.records_skipped;
  f.t_begin_s = ins.t_begin_s, f.t_end_s = ins.t_end_s, f.rate_hz = ins.rate_hz;
  f.solution_fractions = ins.solution_fractions;
  f.enu_origin = ins.enu_origin;
  return f;
}

Dataset load_kitti_raw(const std::filesystem::path& drive_dir, const std::optional<std::filesystem::path>& init,
                       const std::optional<std::filesystem::path>& fiducials, const InputConfig& config, LoadReport* report_out) {
  const KittiDrive drive = read_kitti_drive(drive_dir);
  LoadReport r;
  r.warnings = drive.warnings;
  r.input_kind = "KITTI raw drive";
  r.source = drive.drive_dir.string();
  r.frames_total = drive.frames.size();
  r.time_field = "azimuth";
  r.frame_time_source =
      "velodyne_points/timestamps_end.txt (the sweep end); per-point time derived from each point's azimuth between "
      "timestamps_start.txt and timestamps_end.txt (the .bin holds none; clockwise spin from behind, as the HDL-64E)";
  const PoseSource source = pose_source_of(drive.ins, "kitti");
  Dataset d = timed_dataset(kitti_frame_source(drive), source, config, r,
                            "KITTI stamps every stream with the recording computer's clock");
  if (init) {
    d.T_ins_lidar_init = read_init_extrinsic(*init);
    r.init = "--init " + init->string();
  } else if (drive.T_ins_lidar_init) {
    d.T_ins_lidar_init = drive.T_ins_lidar_init;
    r.init = drive.calib_file.string() + " (T_velo_imu, inverted)";
  }
  if (fiducials) {
    d.fiducials = read_dataset_fiducials(*fiducials, source.enu, d.world_origin_m, source.facts.format);
    r.fiducials = fiducial_words(d.fiducials, fiducials);
  }
  if (report_out) *report_out = std::move(r);
  return d;
}

LoadedInput load_input(const InputSpec& spec, const InputConfig& config) {
  LoadedInput out;
  switch (input_kind(spec)) {
    case InputKind::kPcdFolder:
      out = load_pcd_folders(spec, config);
      break;
    case InputKind::kRecording:
      out = load_recording_input(spec, config);
      break;
    case InputKind::kKittiRaw: {
      LoadReport r;
      out.kind = InputKind::kKittiRaw;
      out.lidars.push_back(load_kitti_raw(spec.kitti_raw, init_of(spec, 0), spec.fiducials, config, &r));
      out.reports.push_back(std::move(r));
      out.lidar_names.push_back(folder_name(spec.kitti_raw));
      break;
    }
  }
  require_distinct_names(out, out.kind == InputKind::kRecording ? "--lidar-topic" : "--lidar-dir");
  return out;
}

}  // namespace insalign::io
