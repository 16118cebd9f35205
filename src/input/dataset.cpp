#include "input/dataset.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <limits>
#include <map>
#include <memory>
#include <numeric>
#include <optional>
#include <tbb/parallel_for.h>

#include "core/errors.hpp"
#include "files/fiducials.hpp"
#include "files/installed_extrinsic.hpp"
#include "pointcloud/pcd.hpp"
#include "inslog/pose_source.hpp"
#include "files/poses.hpp"
#include "files/read_file.hpp"

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

struct TimedPose {
  double t_s;
  std::size_t source_index;  // into PoseSource::poses
};

// 1. The folder: *.pcd frames, everything else counted and ignored.
std::vector<Candidate> list_pcd_folder(const std::filesystem::path& lidar_dir, LoadReport& report) {
  const std::string dir = lidar_dir.string();
  std::error_code ec;
  if (!std::filesystem::exists(lidar_dir, ec)) throw InputError(dir, "", "LiDAR folder not found");
  if (!std::filesystem::is_directory(lidar_dir, ec)) throw InputError(dir, "", "not a folder");
  std::vector<Candidate> frames;
  for (const auto& entry : std::filesystem::directory_iterator(lidar_dir, ec)) {
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
  return frames;
}

// Broken frames are marked and counted; the first error is kept for when all are broken.
class FrameChecks {
 public:
  FrameChecks(LoadReport& report, Warnings& warn) : report_(report), warn_(warn) {}
  void mark_bad(Candidate& c, const InputError& e) {
    c.bad = true;
    ++report_.frames_bad;
    warn_.add("unreadable frames", std::string("skipped frame: ") + e.what());
    if (!first_error_) first_error_ = e;
  }
  void require_some(const std::vector<Candidate>& frames) const {
    if (std::none_of(frames.begin(), frames.end(), [](const Candidate& c) { return !c.bad; })) throw *first_error_;
  }

 private:
  LoadReport& report_;
  Warnings& warn_;
  std::optional<InputError> first_error_;
};

// 2. Every header and file size (cheap, but a syscall or three per file: in parallel); broken
// frames are skipped in folder order, all broken is fatal.
void check_headers(std::vector<Candidate>& frames, FrameChecks& checks) {
  std::vector<std::optional<InputError>> errors(frames.size());
  tbb::parallel_for(std::size_t{0}, frames.size(), [&](std::size_t i) {
    try {
      check_pcd_cheaply(frames[i].path);
    } catch (const InputError& e) {
      errors[i] = e;
    }
    frames[i].name_time_s = time_from_frame_name(frames[i].name);
  });
  for (std::size_t i = 0; i < frames.size(); ++i)
    if (errors[i]) checks.mark_bad(frames[i], *errors[i]);
  checks.require_some(frames);
}

// Sweeps decoded for their clock: a few when every name encodes a time, else all of them.
std::vector<std::size_t> clock_sample(const std::vector<Candidate>& frames, bool all_named) {
  std::vector<std::size_t> good;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    if (!frames[i].bad) good.push_back(i);
  }
  if (!all_named || good.size() <= kClockSampleFrames) return good;
  std::vector<std::size_t> sample;
  for (std::size_t k = 0; k < kClockSampleFrames; ++k) sample.push_back(good[k * (good.size() - 1) / (kClockSampleFrames - 1)]);
  return sample;
}

// Decodes the sample: each one's latest point time, and the time field most of them use.
void decode_sample(std::vector<Candidate>& frames, const std::vector<std::size_t>& sample, FrameChecks& checks,
                   LoadReport& report, const std::string& dir) {
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
      checks.mark_bad(frames[i], e);
    }
  }
  checks.require_some(frames);
  if (time_fields.empty()) return;
  report.time_field = std::max_element(time_fields.begin(), time_fields.end(), [](const auto& a, const auto& b) {
                        return a.second < b.second;
                      })->first;
  if (time_fields.size() > 1) report.warnings.push_back(fmt::format("{}: frames use different time fields", dir));
}

// The offset from name times to the PCD clock: the median over the sample, warned when inconsistent.
void align_names_to_pcd_clock(const std::vector<Candidate>& frames, const std::vector<std::size_t>& sample,
                              LoadReport& report, const std::string& dir, bool& have_pcd_clock) {
  std::vector<double> name_to_pcd;
  for (std::size_t i : sample) {
    const Candidate& c = frames[i];
    if (!c.bad && c.name_time_s && std::isfinite(c.pcd_t_end_s)) name_to_pcd.push_back(c.pcd_t_end_s - *c.name_time_s);
  }
  have_pcd_clock = !name_to_pcd.empty();
  if (name_to_pcd.empty()) return;
  report.name_to_lidar_clock_s = median(name_to_pcd);
  double worst = 0.0;
  for (double d : name_to_pcd) worst = std::max(worst, std::abs(d - report.name_to_lidar_clock_s));
  if (worst > kClockConsistency_s) {
    report.warnings.push_back(fmt::format(
        "{}: frame names and PCD timestamps disagree by up to {:.3f} s beyond a constant offset of {:.3f} s", dir, worst,
        report.name_to_lidar_clock_s));
  }
}

// 3. Frame times. Names that encode times let us decode only a few sweeps to find how the name
// clock relates to the PCD clock (OpenCalib names are local time); otherwise every sweep is
// decoded once for its latest timestamp. Bad frames are dropped; the rest sorted by time.
void time_frames(std::vector<Candidate>& frames, FrameChecks& checks, LoadReport& report, const std::string& dir) {
  const bool all_named = std::all_of(frames.begin(), frames.end(),
                                     [](const Candidate& c) { return c.bad || c.name_time_s.has_value(); });
  const std::vector<std::size_t> sample = clock_sample(frames, all_named);
  decode_sample(frames, sample, checks, report, dir);
  bool have_pcd_clock = false;
  align_names_to_pcd_clock(frames, sample, report, dir, have_pcd_clock);
  for (Candidate& c : frames) {
    if (c.bad) continue;
    if (all_named || (!std::isfinite(c.pcd_t_end_s) && c.name_time_s)) {
      c.t_s = *c.name_time_s + report.name_to_lidar_clock_s;
    } else if (std::isfinite(c.pcd_t_end_s)) {
      c.t_s = c.pcd_t_end_s;
    } else {
      checks.mark_bad(c, InputError(c.path.string(), "",
                                    "no frame time: the PCD has no absolute 'timestamp' field and the name is not a time"));
    }
  }
  checks.require_some(frames);
  report.frame_time_source = !all_named       ? "latest point timestamp of each PCD"
                             : !have_pcd_clock ? "frame names (the PCDs carry no absolute time)"
                                               : fmt::format("frame names + {:.3f} s (aligned to the PCD timestamps)",
                                                             report.name_to_lidar_clock_s);
  frames.erase(std::remove_if(frames.begin(), frames.end(), [](const Candidate& c) { return c.bad; }), frames.end());
  std::stable_sort(frames.begin(), frames.end(), [](const Candidate& a, const Candidate& b) { return a.t_s < b.t_s; });
  for (std::size_t i = 1; i < frames.size(); ++i) {
    if (frames[i].t_s - frames[i - 1].t_s < kSameTime_s) {
      throw InputError(frames[i].path.string(), "",
                       fmt::format("same frame time ({:.6f} s) as {}", frames[i].t_s, frames[i - 1].path.string()));
    }
  }
}

// 4. Pose times: an OpenCalib pose is at its frame's time; every other source carries its own.
std::vector<TimedPose> place_poses(const PoseSource& source, const std::vector<Candidate>& frames, LoadReport& report,
                                   Warnings& warn) {
  std::map<std::string, std::size_t> frame_by_name;
  for (std::size_t i = 0; i < frames.size(); ++i) frame_by_name[frames[i].name] = i;
  std::vector<bool> frame_has_pose(frames.size(), false);
  std::vector<TimedPose> timed;
  for (std::size_t k = 0; k < source.poses.size(); ++k) {
    const SourcePose& p = source.poses[k];
    double t = p.t_s;
    if (source.per_frame) {
      const auto it = frame_by_name.find(p.frame_name);
      if (it != frame_by_name.end()) {
        t = frames[it->second].t_s;
        frame_has_pose[it->second] = true;
      } else {
        ++report.poses_without_frame;
        t += report.name_to_lidar_clock_s;
      }
      if (!std::isfinite(t)) {
        ++report.poses_unplaced;
        warn.add("unplaced poses", fmt::format("{}:{}: pose '{}' has no frame and its name is not a time; dropped",
                                               source.facts.path, p.location, p.frame_name));
        continue;
      }
    }
    timed.push_back({t, k});
  }
  for (std::size_t i = 0; source.per_frame && i < frames.size(); ++i) {
    if (frame_has_pose[i]) continue;
    ++report.frames_without_pose;
    warn.add("frames without a pose line", fmt::format("frame {} has no line in {} (interpolated if inside the pose time range)",
                                                       frames[i].name, source.facts.path));
  }
  return timed;
}

// Sorted (with a warning), distinct times, recentred on the first position.
void set_poses(Dataset& dataset, std::vector<TimedPose> timed, const PoseSource& source, LoadReport& report) {
  const std::string& path = source.facts.path;
  if (timed.empty()) throw InputError(path, "", "no pose can be placed in time");
  const auto by_time = [](const TimedPose& a, const TimedPose& b) { return a.t_s < b.t_s; };
  if (!std::is_sorted(timed.begin(), timed.end(), by_time)) {
    report.warnings.push_back(path + ": pose lines are not in time order; sorted by time");
    std::stable_sort(timed.begin(), timed.end(), by_time);
  }
  for (std::size_t k = 1; k < timed.size(); ++k) {
    if (timed[k].t_s - timed[k - 1].t_s < kSameTime_s) {
      const auto [a, b] = std::minmax(timed[k - 1].source_index, timed[k].source_index);
      throw InputError(path, source.poses[b].location,
                       fmt::format("same time ({:.6f} s) as the pose at {}", timed[k].t_s, source.poses[a].location));
    }
  }
  dataset.world_origin_m = source.poses[timed.front().source_index].T_world_ins.translation();
  std::vector<StampedPose> stamped;
  for (const TimedPose& p : timed) {
    Iso3 T = source.poses[p.source_index].T_world_ins;
    T.translation() -= dataset.world_origin_m;
    stamped.push_back({p.t_s, T});
    if (!source.quality.empty()) {
      InsQuality q = source.quality[p.source_index];
      q.t_s = p.t_s;
      dataset.ins_quality.push_back(q);
    }
  }
  dataset.poses = PoseStream(std::move(stamped));
}

// Lazy, thread-safe frame loading: each call reads its own file; shared state is immutable.
FrameSource pcd_frame_source(const std::vector<Candidate>& frames) {
  FrameSource source;
  auto files = std::make_shared<std::vector<std::pair<std::filesystem::path, double>>>();
  for (const Candidate& c : frames) {
    source.frames.push_back({c.name, c.t_s});
    files->emplace_back(c.path, c.t_s);
  }
  source.load = [files](std::size_t index) {
    const auto& [path, t_s] = files->at(index);
    Sweep sweep = read_pcd(path);
    // Relative point times carry no clock: the frame time found at load time is the end.
    if (!std::isfinite(sweep.t_end_s)) sweep.t_end_s = t_s;
    return sweep;
  };
  return source;
}

ClockAlignment decide_clock(const Dataset& d, const InputConfig& config, const std::string& file,
                            const std::string& one_clock) {
  if (!one_clock.empty()) {
    ClockAlignment a = given_clock_offset(d.frames, d.poses, 0.0, file);
    a.meaning = "one clock: " + one_clock;
    a.decision = a.meaning;
    a.summary = a.meaning;
    return a;
  }
  if (config.clock_offset_s) return given_clock_offset(d.frames, d.poses, *config.clock_offset_s, file);
  return align_clocks(d.frames, d.poses, config.clock, file);
}

std::string fiducial_words(const std::vector<Fiducial>& f, const std::filesystem::path& path) {
  std::string text;
  try {
    text = read_file(path);
  } catch (const InputError&) {
  }
  return fmt::format("{} {} ({})", f.size(),
                     is_wgs84_fiducial_text(text) ? "geodetic (# wgs84) through the INS's local ENU frame" : "in the world frame",
                     path.string());
}

}  // namespace

void apply_clock(Dataset& dataset, const ClockAlignment& clock, const std::string& file, LoadReport& report) {
  Warnings warn(report.warnings);
  if (clock.offset_s != 0.0) {
    dataset.poses = shifted_poses(dataset.poses, -clock.offset_s);
    for (InsQuality& q : dataset.ins_quality) q.t_s -= clock.offset_s;
  }
  const FrameSource all = dataset.frames;
  auto index = std::make_shared<std::vector<std::size_t>>();
  FrameSource used;
  for (std::size_t i = 0; i < all.frames.size(); ++i) {
    const FrameInfo& f = all.frames[i];
    if (dataset.poses.covers(f.t_end_s)) {
      used.frames.push_back(f);
      index->push_back(i);
      continue;
    }
    ++report.frames_outside_poses;
    warn.add("frames outside the poses", fmt::format("skipped frame {}: its time {:.3f} s is outside the poses [{:.3f}, {:.3f}] s",
                                                     f.name, f.t_end_s, dataset.poses.t_begin(), dataset.poses.t_end()));
  }
  warn.flush();
  if (used.frames.empty()) {
    throw InputError(file, "", fmt::format("no frame lies within the poses' time range [{:.3f}, {:.3f}] s (frames span "
                                           "[{:.3f}, {:.3f}] s): are the LiDAR and pose clocks the same?",
                                           dataset.poses.t_begin(), dataset.poses.t_end(), all.frames.front().t_end_s,
                                           all.frames.back().t_end_s));
  }
  used.load = [load = all.load, index](std::size_t i) { return load(index->at(i)); };
  dataset.frames = std::move(used);
  report.frames_used = dataset.frames.frames.size();
  report.clock = clock;
}

Dataset timed_dataset(FrameSource frames, const PoseSource& source, const InputConfig& config, LoadReport& report,
                      const std::string& one_clock) {
  Warnings warn(report.warnings);
  std::vector<TimedPose> timed;
  for (std::size_t k = 0; k < source.poses.size(); ++k) timed.push_back({source.poses[k].t_s, k});
  Dataset dataset;
  set_poses(dataset, std::move(timed), source, report);
  dataset.frames = std::move(frames);
  apply_clock(dataset, decide_clock(dataset, config, source.facts.path, one_clock), source.facts.path, report);
  report.warnings.insert(report.warnings.end(), report.clock->warnings.begin(), report.clock->warnings.end());
  report.ins = source.facts;
  report.pose_format = source.facts.kind;
  warn.flush();
  return dataset;
}

Dataset load_dataset(const DatasetPaths& paths, LoadReport* report_out) { return load_dataset(paths, InputConfig{}, report_out); }

Dataset load_dataset(const DatasetPaths& paths, const InputConfig& config, LoadReport* report_out) {
  LoadReport report;
  Warnings warn(report.warnings);
  FrameChecks checks(report, warn);
  const std::string dir = paths.lidar_dir.string();
  std::vector<Candidate> frames = list_pcd_folder(paths.lidar_dir, report);
  check_headers(frames, checks);
  time_frames(frames, checks, report, dir);
  const PoseSource source = read_pose_source(paths.poses, {frames.front().t_s, config.poses_columns, "--poses-columns (input.poses_columns)"});
  report.pose_format = source.facts.kind;
  report.ins = source.facts;
  report.warnings.insert(report.warnings.end(), source.facts.warnings.begin(), source.facts.warnings.end());
  Dataset dataset;
  set_poses(dataset, place_poses(source, frames, report, warn), source, report);
  dataset.frames = pcd_frame_source(frames);
  const std::string one_clock = source.per_frame ? "OpenCalib poses are matched to the frames by name" : "";
  apply_clock(dataset, decide_clock(dataset, config, source.facts.path, one_clock), source.facts.path, report);
  if (!source.per_frame) report.frames_without_pose += report.frames_outside_poses;
  report.warnings.insert(report.warnings.end(), report.clock->warnings.begin(), report.clock->warnings.end());
  if (paths.init) {
    dataset.T_ins_lidar_init = read_init_extrinsic(*paths.init);
    report.init = "--init " + paths.init->string();
  }
  if (paths.fiducials) {
    dataset.fiducials = read_dataset_fiducials(*paths.fiducials, source.enu, dataset.world_origin_m, source.facts.format);
    report.fiducials = fiducial_words(dataset.fiducials, *paths.fiducials);
  }
  report.input_kind = "PCD folder";
  report.source = dir;
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
