#include "inslog/pose_source.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "core/errors.hpp"
#include "inslog/ins_log.hpp"
#include "inslog/text_export.hpp"
#include "files/poses.hpp"

namespace insalign::io {
namespace {

bool states_quality(const std::vector<InsQuality>& q) {
  return std::any_of(q.begin(), q.end(), [](const InsQuality& x) {
    return x.solution != GnssSolution::kUnknown || std::isfinite(x.horizontal_stddev_m) || std::isfinite(x.vertical_stddev_m);
  });
}

void set_span(PoseSourceFacts& f, const std::vector<SourcePose>& poses) {
  f.records = poses.size();
  if (poses.empty() || !std::isfinite(poses.front().t_s)) return;
  f.t_begin_s = poses.front().t_s, f.t_end_s = poses.back().t_s;
  for (const SourcePose& p : poses) {
    if (std::isfinite(p.t_s)) f.t_begin_s = std::min(f.t_begin_s, p.t_s), f.t_end_s = std::max(f.t_end_s, p.t_s);
  }
  f.rate_hz = f.t_end_s > f.t_begin_s ? static_cast<double>(poses.size() - 1) / (f.t_end_s - f.t_begin_s) : 0.0;
}

PoseSource from_pose_file(const std::filesystem::path& path) {
  const PoseFile file = read_pose_file(path);
  PoseSource s;
  s.per_frame = file.format == PoseFormat::kOpenCalib;
  for (std::size_t k = 0; k < file.T_world_ins.size(); ++k) {
    s.poses.push_back({file.t_s[k], s.per_frame ? file.frame_names[k] : "", "line " + std::to_string(file.line[k]),
                       file.T_world_ins[k]});
  }
  PoseSourceFacts& f = s.facts;
  f.kind = s.per_frame ? "opencalib" : "tum";
  f.format = s.per_frame ? "OpenCalib per-frame poses (<frame-name> + the 3x4 T_world_ins)" : "TUM (t x y z qx qy qz qw)";
  f.time_base = s.per_frame ? "the frames' times (poses matched to frames by name)"
                            : "seconds as written, taken as the LiDAR's clock (checked against the frames)";
  f.body_frame = "the pose file's ins frame (T_world_ins as written)";
  f.height_datum = "as written (cartesian world)";
  f.world_frame = "the pose file's world frame, recentred on the first pose";
  if (file.reorthonormalised > 0) {
    f.warnings.push_back(fmt::format("{}: {} rotations were off orthonormal by more than print rounding; re-orthonormalised",
                                     path.string(), file.reorthonormalised));
  }
  set_span(f, s.poses);
  return s;
}

InsLogOptions log_options(const PoseSourceOptions& o, InsLogFormat format) {
  InsLogOptions log;
  log.lidar_time_hint_unix_s = o.lidar_time_hint_unix_s;
  if (format == InsLogFormat::kTextExport && !o.columns_spec.empty()) {
    log.columns = parse_text_export_columns(o.columns_spec, o.columns_source);
  }
  return log;
}

}  // namespace

const char* gnss_solution_name(GnssSolution s) {
  switch (s) {
    case GnssSolution::kRtkFixed: return "RTK fixed";
    case GnssSolution::kRtkFloat: return "RTK float";
    case GnssSolution::kDifferential: return "differential";
    case GnssSolution::kSingle: return "single point";
    case GnssSolution::kInsOnly: return "INS only";
    case GnssSolution::kInvalid: return "invalid";
    case GnssSolution::kUnknown: break;
  }
  return "not stated";
}

std::vector<std::pair<std::string, double>> solution_fractions(const std::vector<InsQuality>& quality) {
  std::map<GnssSolution, std::size_t> n;
  for (const InsQuality& q : quality) ++n[q.solution];
  std::vector<std::pair<std::string, double>> out;
  if (quality.empty() || (n.size() == 1 && n.begin()->first == GnssSolution::kUnknown)) return out;
  for (const auto& [s, c] : n) out.emplace_back(gnss_solution_name(s), static_cast<double>(c) / static_cast<double>(quality.size()));
  return out;
}

PoseSource pose_source_of(const InsTrack& track, const std::string& kind) {
  const WorldTrack world = to_world(track);
  PoseSource s;
  s.enu = world.enu;
  for (std::size_t k = 0; k < world.poses.size(); ++k) {
    s.poses.push_back({world.poses[k].t_s, "", track.records[k].location, world.poses[k].T_world_ins});
  }
  if (states_quality(world.quality)) s.quality = world.quality;
  PoseSourceFacts& f = s.facts;
  f.path = track.source;
  f.kind = kind;
  f.format = track.format, f.time_base = track.time_base, f.body_frame = track.body_frame;
  f.height_datum = track.height_datum, f.world_frame = track.world_frame;
  f.records_skipped = track.records_skipped;
  f.solution_fractions = solution_fractions(s.quality);
  if (s.enu) f.enu_origin = s.enu->origin();
  f.warnings = track.warnings;
  set_span(f, s.poses);
  return s;
}

PoseSource read_pose_source(const std::filesystem::path& path, const PoseSourceOptions& options) {
  const std::optional<InsLogFormat> format = detect_ins_log(path);
  if (!format) {
    if (std::filesystem::is_directory(path)) {
      throw InputError(path.string(), "", "a folder is not a pose file (a KITTI oxts/ folder holds timestamps.txt and data/)");
    }
    PoseSource s = from_pose_file(path);
    s.facts.path = path.string();
    return s;
  }
  PoseSource s = pose_source_of(read_ins_log(path, *format, log_options(options, *format)), ins_log_format_name(*format));
  s.facts.path = path.string();
  if (*format == InsLogFormat::kTextExport) s.facts.columns = format_text_export_columns(log_options(options, *format).columns);
  if (s.poses.empty()) throw InputError(path.string(), "", "no usable pose record");
  return s;
}

}  // namespace insalign::io
