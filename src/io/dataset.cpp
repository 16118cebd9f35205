#include "io/dataset.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <limits>
#include <map>
#include <memory>
#include <numeric>

#include "core/errors.hpp"
#include "io/extrinsic_json.hpp"
#include "io/fiducials.hpp"
#include "io/pcd.hpp"
#include "io/poses.hpp"

namespace insalign::io {

namespace {

constexpr std::size_t kClockSampleFrames = 5;      // sweeps decoded to align name times to the PCD clock
constexpr double kClockConsistency_s = 0.02;       // residual beyond this: names and clock disagree
constexpr double kSameTime_s = 1e-6;               // two frames or poses closer than this collide
constexpr std::size_t kMaxListedWarnings = 10;     // per kind, so a broken folder does not flood output

struct Candidate {
  std::filesystem::path path;
  std::string name;
  std::optional<double> name_time_s;
  double pcd_t_end_s = std::numeric_limits<double>::quiet_NaN();
  double t_s = std::numeric_limits<double>::quiet_NaN();
  bool bad = false;
};

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// Cheap validation of one PCD: header parses, has points, and the file is long enough.
void check_pcd_cheaply(const std::filesystem::path& path) {
  const PcdHeader h = read_pcd_header(path);
  if (h.points == 0) throw InputError(path.string(), "", "empty sweep (POINTS 0)");
  const std::uintmax_t size = std::filesystem::file_size(path);
  if (h.data == "binary" && size < h.header_bytes + h.points * h.point_bytes) {
    throw InputError(path.string(), "byte " + std::to_string(size),
                     fmt::format("truncated: {} points of {} bytes need {} bytes after the header", h.points,
                                 h.point_bytes, h.points * h.point_bytes));
  }
  if (h.data == "binary_compressed" && size < h.header_bytes + 8) {
    throw InputError(path.string(), "byte " + std::to_string(size), "truncated: no compressed data");
  }
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

class Warnings {
 public:
  explicit Warnings(std::vector<std::string>& out) : out_(out) {}
  void add(const std::string& kind, const std::string& text) {
    if (++count_[kind] <= kMaxListedWarnings) out_.push_back(text);
  }
  void flush() {
    for (const auto& [kind, n] : count_) {
      if (n > kMaxListedWarnings) out_.push_back(fmt::format("... and {} more {}", n - kMaxListedWarnings, kind));
    }
  }

 private:
  std::vector<std::string>& out_;
  std::map<std::string, std::size_t> count_;
};

}  // namespace

Dataset load_dataset(const DatasetPaths& paths, LoadReport* report_out) {
  LoadReport report;
  Warnings warn(report.warnings);
  const std::string dir = paths.lidar_dir.string();

  // 1. The folder: *.pcd frames, everything else counted and ignored.
  std::error_code ec;
  if (!std::filesystem::exists(paths.lidar_dir, ec)) throw InputError(dir, "", "LiDAR folder not found");
  if (!std::filesystem::is_directory(paths.lidar_dir, ec)) throw InputError(dir, "", "not a folder");
  std::vector<Candidate> frames;
  for (const auto& entry : std::filesystem::directory_iterator(paths.lidar_dir, ec)) {
    if (!entry.is_regular_file(ec)) continue;
    if (lower(entry.path().extension().string()) == ".pcd") {
      frames.push_back({entry.path(), entry.path().stem().string(), std::nullopt});
    } else {
      ++report.skipped_files;
    }
  }
  if (ec) throw InputError(dir, "", "cannot list the folder: " + ec.message());
  if (report.skipped_files > 0) {
    report.warnings.push_back(fmt::format("{}: ignored {} file(s) that are not .pcd", dir, report.skipped_files));
  }
  if (frames.empty()) {
    throw InputError(dir, "", fmt::format("no .pcd files in the LiDAR folder ({} other files)", report.skipped_files));
  }
  std::sort(frames.begin(), frames.end(), [](const Candidate& a, const Candidate& b) { return a.path < b.path; });
  report.frames_total = frames.size();

  // 2. Every header and file size (cheap); broken frames are skipped, all broken is fatal.
  std::optional<InputError> first_error;
  const auto mark_bad = [&](Candidate& c, const InputError& e) {
    c.bad = true;
    ++report.frames_bad;
    warn.add("unreadable frames", std::string("skipped frame: ") + e.what());
    if (!first_error) first_error = e;
  };
  for (Candidate& c : frames) {
    try {
      check_pcd_cheaply(c.path);
    } catch (const InputError& e) {
      mark_bad(c, e);
    }
    c.name_time_s = time_from_frame_name(c.name);
  }
  const auto good_count = [&] {
    return static_cast<std::size_t>(std::count_if(frames.begin(), frames.end(), [](const Candidate& c) { return !c.bad; }));
  };
  if (good_count() == 0) throw *first_error;

  // 3. Poses.
  const PoseFile pose_file = read_pose_file(paths.poses);
  const std::string pose_path = paths.poses.string();
  report.pose_format = pose_file.format == PoseFormat::kTum ? "tum" : "opencalib";

  // 4. Frame times. Names that encode times let us decode only a few sweeps to find how the
  // name clock relates to the PCD clock (OpenCalib names are local time); otherwise every sweep
  // is decoded once for its latest timestamp.
  const bool all_named = std::all_of(frames.begin(), frames.end(),
                                     [](const Candidate& c) { return c.bad || c.name_time_s.has_value(); });
  std::vector<std::size_t> good;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    if (!frames[i].bad) good.push_back(i);
  }
  std::vector<std::size_t> sample;
  if (all_named && good.size() > kClockSampleFrames) {
    for (std::size_t k = 0; k < kClockSampleFrames; ++k) {
      sample.push_back(good[k * (good.size() - 1) / (kClockSampleFrames - 1)]);
    }
  } else {
    sample = good;
  }
  std::map<std::string, std::size_t> time_fields;
  for (std::size_t i : sample) {
    try {
      PcdInfo info;
      const Sweep s = read_pcd(frames[i].path, &info);
      frames[i].pcd_t_end_s = s.t_end_s;
      ++time_fields[info.time_field];
      if (s.size() == 0) {
        throw InputError(frames[i].path.string(), "", fmt::format("empty sweep (all {} points non-finite)", info.points));
      }
    } catch (const InputError& e) {
      mark_bad(frames[i], e);
    }
  }
  if (good_count() == 0) throw *first_error;
  if (!time_fields.empty()) {
    report.time_field = std::max_element(time_fields.begin(), time_fields.end(), [](const auto& a, const auto& b) {
                          return a.second < b.second;
                        })->first;
    if (time_fields.size() > 1) report.warnings.push_back(fmt::format("{}: frames use different time fields", dir));
  }
  std::vector<double> name_to_pcd;
  for (std::size_t i : sample) {
    const Candidate& c = frames[i];
    if (!c.bad && c.name_time_s && std::isfinite(c.pcd_t_end_s)) name_to_pcd.push_back(c.pcd_t_end_s - *c.name_time_s);
  }
  if (!name_to_pcd.empty()) {
    report.name_to_lidar_clock_s = median(name_to_pcd);
    double worst = 0.0;
    for (double d : name_to_pcd) worst = std::max(worst, std::abs(d - report.name_to_lidar_clock_s));
    if (worst > kClockConsistency_s) {
      report.warnings.push_back(fmt::format(
          "{}: frame names and PCD timestamps disagree by up to {:.3f} s beyond a constant offset of {:.3f} s", dir,
          worst, report.name_to_lidar_clock_s));
    }
  }
  for (Candidate& c : frames) {
    if (c.bad) continue;
    if (all_named) {
      c.t_s = *c.name_time_s + report.name_to_lidar_clock_s;
    } else if (std::isfinite(c.pcd_t_end_s)) {
      c.t_s = c.pcd_t_end_s;
    } else if (c.name_time_s) {
      c.t_s = *c.name_time_s + report.name_to_lidar_clock_s;
    } else {
      mark_bad(c, InputError(c.path.string(), "",
                             "no frame time: the PCD has no absolute 'timestamp' field and the name is not a time"));
    }
  }
  if (good_count() == 0) throw *first_error;
  if (all_named) {
    report.frame_time_source = name_to_pcd.empty()
                                   ? "frame names (the PCDs carry no absolute time)"
                                   : fmt::format("frame names + {:.3f} s (aligned to the PCD timestamps)",
                                                 report.name_to_lidar_clock_s);
  } else {
    report.frame_time_source = "latest point timestamp of each PCD";
  }
  frames.erase(std::remove_if(frames.begin(), frames.end(), [](const Candidate& c) { return c.bad; }), frames.end());
  std::stable_sort(frames.begin(), frames.end(), [](const Candidate& a, const Candidate& b) { return a.t_s < b.t_s; });
  for (std::size_t i = 1; i < frames.size(); ++i) {
    if (frames[i].t_s - frames[i - 1].t_s < kSameTime_s) {
      throw InputError(frames[i].path.string(), "",
                       fmt::format("same frame time ({:.6f} s) as {}", frames[i].t_s, frames[i - 1].path.string()));
    }
  }

  // 5. Pose times: an OpenCalib pose is at its frame's time; TUM poses carry their own.
  std::map<std::string, std::size_t> frame_by_name;
  for (std::size_t i = 0; i < frames.size(); ++i) frame_by_name[frames[i].name] = i;
  struct TimedPose {
    double t_s;
    std::size_t line;
    Iso3 T_world_ins;
  };
  std::vector<TimedPose> timed;
  std::vector<bool> frame_has_pose(frames.size(), false);
  for (std::size_t k = 0; k < pose_file.T_world_ins.size(); ++k) {
    double t = pose_file.t_s[k];
    if (pose_file.format == PoseFormat::kOpenCalib) {
      const auto it = frame_by_name.find(pose_file.frame_names[k]);
      if (it != frame_by_name.end()) {
        t = frames[it->second].t_s;
        frame_has_pose[it->second] = true;
      } else {
        ++report.poses_without_frame;
        t += report.name_to_lidar_clock_s;
      }
      if (!std::isfinite(t)) {
        ++report.poses_unplaced;
        warn.add("unplaced poses", fmt::format("{}:line {}: pose '{}' has no frame and its name is not a time; dropped",
                                               pose_path, pose_file.line[k], pose_file.frame_names[k]));
        continue;
      }
    }
    timed.push_back({t, pose_file.line[k], pose_file.T_world_ins[k]});
  }
  if (timed.empty()) throw InputError(pose_path, "", "no pose can be placed in time");
  if (!std::is_sorted(timed.begin(), timed.end(), [](const TimedPose& a, const TimedPose& b) { return a.t_s < b.t_s; })) {
    report.warnings.push_back(pose_path + ": pose lines are not in time order; sorted by time");
    std::stable_sort(timed.begin(), timed.end(), [](const TimedPose& a, const TimedPose& b) { return a.t_s < b.t_s; });
  }
  for (std::size_t k = 1; k < timed.size(); ++k) {
    if (timed[k].t_s - timed[k - 1].t_s < kSameTime_s) {
      const auto [a, b] = std::minmax(timed[k - 1].line, timed[k].line);
      throw InputError(pose_path, "line " + std::to_string(b),
                       fmt::format("same time ({:.6f} s) as the pose on line {}", timed[k].t_s, a));
    }
  }
  Dataset dataset;
  dataset.world_origin_m = timed.front().T_world_ins.translation();
  std::vector<StampedPose> stamped;
  stamped.reserve(timed.size());
  for (const TimedPose& p : timed) {
    Iso3 T = p.T_world_ins;
    T.translation() -= dataset.world_origin_m;
    stamped.push_back({p.t_s, T});
  }
  dataset.poses = PoseStream(std::move(stamped));
  if (pose_file.format == PoseFormat::kOpenCalib) {
    for (std::size_t i = 0; i < frames.size(); ++i) {
      if (!frame_has_pose[i]) {
        ++report.frames_without_pose;
        warn.add("frames without a pose line",
                 fmt::format("frame {} has no line in {} (interpolated if inside the pose time range)",
                             frames[i].name, pose_path));
      }
    }
  }

  // 6. Frames the poses do not reach are skipped.
  std::vector<Candidate> used;
  for (Candidate& c : frames) {
    if (dataset.poses.covers(c.t_s)) {
      used.push_back(std::move(c));
      continue;
    }
    ++report.frames_outside_poses;
    if (pose_file.format == PoseFormat::kTum) ++report.frames_without_pose;
    warn.add("frames outside the poses",
             fmt::format("skipped frame {}: its time {:.3f} s is outside the poses [{:.3f}, {:.3f}] s", c.name, c.t_s,
                         dataset.poses.t_begin(), dataset.poses.t_end()));
  }
  if (used.empty()) {
    throw InputError(pose_path, "",
                     fmt::format("no frame lies within the poses' time range [{:.3f}, {:.3f}] s (frames span "
                                 "[{:.3f}, {:.3f}] s): are the LiDAR and pose clocks the same?",
                                 dataset.poses.t_begin(), dataset.poses.t_end(), frames.front().t_s,
                                 frames.back().t_s));
  }
  report.frames_used = used.size();

  // 7. Optional inputs.
  if (paths.init) dataset.T_ins_lidar_init = read_opencalib_extrinsic(*paths.init);
  if (paths.fiducials) {
    dataset.fiducials = read_fiducials(*paths.fiducials);
    for (Fiducial& f : dataset.fiducials) f.p_world -= dataset.world_origin_m;
  }

  // 8. Lazy, thread-safe frame loading: each call reads its own file; shared state is immutable.
  auto files = std::make_shared<std::vector<std::pair<std::filesystem::path, double>>>();
  for (const Candidate& c : used) {
    dataset.frames.frames.push_back({c.name, c.t_s});
    files->emplace_back(c.path, c.t_s);
  }
  dataset.frames.load = [files](std::size_t index) {
    const auto& [path, t_s] = files->at(index);
    Sweep sweep = read_pcd(path);
    // Relative point times carry no clock: the frame time found at load time is the end.
    if (!std::isfinite(sweep.t_end_s)) sweep.t_end_s = t_s;
    return sweep;
  };

  warn.flush();
  if (report_out) *report_out = std::move(report);
  return dataset;
}

DriveSummary summarize_drive(const Dataset& dataset, std::size_t frames_to_sample) {
  DriveSummary s = summarize_poses(dataset.poses.poses());
  const auto& frames = dataset.frames.frames;
  s.frames = frames.size();
  if (frames.empty()) return s;
  s.frame_time_begin_s = frames.front().t_end_s;
  s.frame_time_end_s = frames.back().t_end_s;
  const std::size_t n = std::min(frames_to_sample, frames.size());
  std::size_t total = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t i = n == 1 ? 0 : k * (frames.size() - 1) / (n - 1);
    total += dataset.frames.load(i).size();
  }
  s.frames_sampled = n;
  s.mean_points_per_frame = n > 0 ? static_cast<double>(total) / static_cast<double>(n) : 0.0;
  return s;
}

}  // namespace insalign::io
