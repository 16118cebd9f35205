#include "input/bag_dataset.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <map>
#include <set>
#include <sstream>

#include "files/fiducials.hpp"
#include "files/installed_extrinsic.hpp"
#include "files/read_file.hpp"
#include "recording/bag_scan.hpp"
#include "recording/bag_topics.hpp"
#include "inslog/ins_track.hpp"
#include "inslog/pose_source.hpp"

namespace insalign::io {

namespace {

constexpr double kMinInsideFraction = 0.5;    // without usable record times: fewer frames inside, clocks disagree
constexpr double kMaxStampGap_s = 2.0;        // INS - LiDAR stamps at equal record time beyond this: clocks differ
constexpr double kRecordGapTolerance_s = 0.05;  // whole-second match, gap measured from record times
constexpr double kRangeGapTolerance_s = 0.15;   // ... measured between the middles of the ranges
constexpr double kCopiedStamps_s = 1e-6;        // record time - stamp below this for both: copied stamps

InsReport ins_report(const InsSource& src, const WorldTrack& world) {
  InsReport r;
  r.kind = ins_source_name(src.kind);
  r.topics = src.topics, r.types = src.types;
  r.ins_frame = src.track.body_frame, r.world_frame = src.track.world_frame;
  r.ins_frame_id = src.ins_frame_id, r.world_frame_id = src.world_frame_id;
  r.height_datum = src.track.height_datum, r.time_base = src.track.time_base;
  r.messages = src.messages, r.records = src.track.records.size(), r.records_skipped = src.track.records_skipped;
  r.t_begin_s = world.poses.front().t_s, r.t_end_s = world.poses.back().t_s;
  r.rate_hz = r.t_end_s > r.t_begin_s ? static_cast<double>(r.records - 1) / (r.t_end_s - r.t_begin_s) : 0.0;
  r.status_counts = src.status_counts;
  std::map<GnssSolution, std::size_t> n;
  for (const InsQuality& q : world.quality) ++n[q.solution];
  if (!(n.size() == 1 && n.begin()->first == GnssSolution::kUnknown)) {
    for (const auto& [s, c] : n) {
      r.solution_fractions.emplace_back(gnss_solution_name(s), static_cast<double>(c) / static_cast<double>(world.quality.size()));
    }
  }
  if (world.enu) r.enu_origin = world.enu->origin();
  r.not_used = src.not_used;
  r.stamp_minus_record_s = src.stamp_minus_record_s;
  return r;
}

// Quality only when the source states something.
std::vector<InsQuality> stated_quality(const std::vector<InsQuality>& q) {
  const bool any = std::any_of(q.begin(), q.end(), [](const InsQuality& x) {
    return x.solution != GnssSolution::kUnknown || std::isfinite(x.horizontal_stddev_m) || std::isfinite(x.vertical_stddev_m);
  });
  return any ? q : std::vector<InsQuality>{};
}

std::string signed_s(double s) { return fmt::format("{:.3f} s {}", std::abs(s), s >= 0 ? "later" : "earlier"); }

// Why the frames are (not) inside the INS range, in words.
std::string range_words(const ClockReport& c) {
  if (c.lidar_end_s < c.ins_begin_s) {
    return fmt::format("the LiDAR frames end {:.3f} s before the INS records begin", c.ins_begin_s - c.lidar_end_s);
  }
  if (c.lidar_begin_s > c.ins_end_s) {
    return fmt::format("the LiDAR frames begin {:.3f} s after the INS records end", c.lidar_begin_s - c.ins_end_s);
  }
  return fmt::format("{:.0f}% of the LiDAR frames lie inside the INS time range", 100.0 * c.frames_inside_fraction);
}

std::string gap_words(const ClockReport& c, double gap_s, bool from_records) {
  std::string out = fmt::format("the INS stamps are {} than the LiDAR's ({})", signed_s(gap_s),
                                from_records ? "median at equal record time" : "between the middles of the two ranges");
  if (c.consistent && std::abs(gap_s) < kMaxStampGap_s) return "the clocks agree: " + out;
  if (c.explanation) {
    return out + fmt::format(", close to {:.0f} s: {}", c.explanation->whole_s, c.explanation->meaning);
  }
  const double whole = std::round(gap_s);
  const double tol = from_records ? kRecordGapTolerance_s : kRangeGapTolerance_s;
  if (whole != 0.0 && std::abs(gap_s - whole) < tol) return out + fmt::format(", a whole number of seconds ({:.0f} s) of no known kind", whole);
  return out + ", not a whole number of seconds";
}

ClockReport analyse_clocks(const std::vector<LidarFrames>& lidars, const BagTrajectory& ins) {
  const PoseStream& poses = ins.poses;
  ClockReport c;
  c.ins_begin_s = poses.t_begin(), c.ins_end_s = poses.t_end();
  c.lidar_begin_s = lidars.front().frames.front().t_end_s, c.lidar_end_s = lidars.front().frames.back().t_end_s;
  std::size_t total = 0, inside = 0;
  std::vector<double> lags;
  for (const LidarFrames& l : lidars) {
    c.lidar_begin_s = std::min(c.lidar_begin_s, l.frames.front().t_end_s);
    c.lidar_end_s = std::max(c.lidar_end_s, l.frames.back().t_end_s);
    for (const CloudFrame& f : l.frames) inside += poses.covers(f.t_end_s) ? 1 : 0;
    total += l.frames.size();
    if (std::isfinite(l.report.stamp_minus_record_s)) lags.push_back(l.report.stamp_minus_record_s);
  }
  c.frames_inside_fraction = static_cast<double>(inside) / static_cast<double>(std::max<std::size_t>(1, total));
  const double lidar_lag = median_of(lags), ins_lag = ins.report.stamp_minus_record_s;
  // Record times copied from the stamps (converted data sets) say nothing about the clocks.
  const bool from_records = std::isfinite(lidar_lag) && std::isfinite(ins_lag) &&
                            !(std::abs(lidar_lag) < kCopiedStamps_s && std::abs(ins_lag) < kCopiedStamps_s);
  if (from_records) c.stamp_gap_s = ins_lag - lidar_lag;
  // Without record times: the middles of the ranges (recorders start and stop both sensors together).
  const double gap_s = from_records ? c.stamp_gap_s : 0.5 * (c.ins_begin_s + c.ins_end_s - c.lidar_begin_s - c.lidar_end_s);
  if (from_records) {
    c.consistent = std::abs(c.stamp_gap_s) <= kMaxStampGap_s;
  } else {  // by the ranges: most frames inside, and not both ends shifted alike
    const double begin_shift = c.ins_begin_s - c.lidar_begin_s, end_shift = c.ins_end_s - c.lidar_end_s;
    const bool shifted = std::abs(begin_shift) > kMaxStampGap_s && std::abs(begin_shift - end_shift) < kMaxStampGap_s;
    c.consistent = c.frames_inside_fraction >= kMinInsideFraction && !shifted;
  }
  c.explanation = explain_clock_gap(gap_s, from_records ? kRecordGapTolerance_s : kRangeGapTolerance_s);
  c.summary = fmt::format("LiDAR frames {:.3f} .. {:.3f} s, INS {:.3f} .. {:.3f} s: {}; {}", c.lidar_begin_s,
                          c.lidar_end_s, c.ins_begin_s, c.ins_end_s, range_words(c), gap_words(c, gap_s, from_records));
  return c;
}

void check_clocks(const ClockReport& c, const std::string& path) {
  if (c.consistent) return;
  throw ClockGapError(path, "the LiDAR and INS clocks disagree: " + c.summary +
                                ". Fix the clock of one sensor (or give the offset) and run again", c);
}

// The frames of one topic that the INS covers; the others counted. None: InputError.
std::vector<CloudFrame> frames_inside(LidarFrames& l, const PoseStream& poses, std::vector<std::string>& warnings,
                                      const std::string& path) {
  std::vector<CloudFrame> used;
  for (const CloudFrame& f : l.frames) {
    if (poses.covers(f.t_end_s)) used.push_back(f);
  }
  LidarTopicReport& r = l.report;
  r.frames_outside_ins = l.frames.size() - used.size();
  r.frames_used = used.size();
  if (r.frames_outside_ins > 0) {
    warnings.push_back(fmt::format("{}: skipped {} of {} frames outside the INS time range [{:.3f}, {:.3f}] s", r.topic,
                                   r.frames_outside_ins, l.frames.size(), poses.t_begin(), poses.t_end()));
  }
  if (used.empty()) {
    throw InputError(path, "", fmt::format("no frame of {} ({:.3f} .. {:.3f} s) lies inside the INS time range "
                                           "[{:.3f}, {:.3f}] s",
                                           r.topic, l.frames.front().t_end_s, l.frames.back().t_end_s, poses.t_begin(),
                                           poses.t_end()));
  }
  r.t_begin_s = used.front().t_end_s, r.t_end_s = used.back().t_end_s;
  r.rate_hz = r.t_end_s > r.t_begin_s ? static_cast<double>(used.size() - 1) / (r.t_end_s - r.t_begin_s) : 0.0;
  return used;
}

// The track in the world frame, recentred on the first position (as load_dataset does: UTM is large).
BagTrajectory trajectory_of(const InsSource& ins) {
  const WorldTrack world = to_world(ins.track);
  BagTrajectory t;
  t.enu = world.enu;
  t.report = ins_report(ins, world);
  t.warnings = ins.track.warnings;
  t.ins_quality = stated_quality(world.quality);
  std::vector<StampedPose> poses = world.poses;
  t.world_origin_m = poses.front().T_world_ins.translation();
  for (StampedPose& p : poses) p.T_world_ins.translation() -= t.world_origin_m;
  t.poses = PoseStream(std::move(poses));
  return t;
}

InsReadOptions ins_read_options(const BagOptions& o) { return {o.world_frame, o.ins_frame, o.ins_time_shift_s}; }

}  // namespace

std::optional<ClockGapExplanation> explain_clock_gap(double gap_s, double tolerance_s) {
  constexpr double kGpsUtc = 18.0, kTaiUtc = 37.0, kTaiGps = 19.0, kGpsEpoch = 315964800.0;
  std::vector<std::pair<double, std::string>> known = {
      {kGpsUtc, "GPS - UTC (18 leap seconds): one sensor stamps GPS time, the other UTC (UNIX) time"},
      {kTaiUtc, "TAI - UTC (37 s): one sensor stamps TAI (PTP without its UTC offset), the other UTC"},
      {kTaiGps, "TAI - GPS (19 s): one sensor stamps TAI, the other GPS time"},
      {kGpsEpoch, "the GPS epoch (1980-01-06) against the UNIX epoch: one sensor stamps GPS seconds, the other UNIX time"},
      {kGpsEpoch + kGpsUtc, "GPS seconds since 1980 (with 18 leap seconds) against UNIX time"},
  };
  for (int quarters = 1; quarters <= 56; ++quarters) {  // time zones: whole quarter hours up to 14 h
    const double zone = 900.0 * quarters;
    const std::string hm = fmt::format("{}:{:02d}", quarters / 4, 15 * (quarters % 4));
    known.emplace_back(zone, "a time-zone offset of " + hm + " h: one sensor stamps local time, the other UTC");
    known.emplace_back(zone + kGpsUtc, "a time-zone offset of " + hm + " h plus GPS - UTC (18 s)");
    known.emplace_back(zone - kGpsUtc, "a time-zone offset of " + hm + " h minus GPS - UTC (18 s)");
  }
  for (const auto& [whole, meaning] : known) {
    if (std::abs(std::abs(gap_s) - whole) <= tolerance_s) return ClockGapExplanation{gap_s, std::copysign(whole, gap_s), meaning};
  }
  return std::nullopt;
}

BagDatasets load_bag(const BagOptions& options) {
  return load_bag(std::shared_ptr<const bag::BagReader>(bag::open_bag(options.path, {options.read_cut_off})), options);
}

BagDatasets load_bag(std::shared_ptr<const bag::BagReader> reader, const BagOptions& options) {
  BagDatasets out;
  BagReport& rep = out.report;
  const std::string path = reader->path().string();
  rep.path = path;
  rep.container = reader->describe();
  rep.warnings = reader->warnings();

  // Topics; a few decoded clouds per LiDAR; then one pass in record order over the INS messages
  // and the clouds' stamps (a chunk holding both is decompressed once).
  const std::vector<std::uint32_t> lidar_topics = choose_lidar_topics(*reader, options.lidar_topics);
  InsSourceReader ins_reader(*reader, choose_ins_source(*reader, options.ins_topic), ins_read_options(options));
  std::vector<std::unique_ptr<LidarTopicIndexer>> indexers;
  std::vector<TopicPass> passes = ins_reader.passes();
  for (std::uint32_t topic : lidar_topics) {
    indexers.push_back(std::make_unique<LidarTopicIndexer>(*reader, topic, *out.counters));
    passes.push_back(indexers.back()->pass());
  }
  read_in_record_order(*reader, passes);
  const BagTrajectory ins = trajectory_of(ins_reader.finish());
  rep.warnings.insert(rep.warnings.end(), ins.warnings.begin(), ins.warnings.end());
  out.enu = ins.enu;
  rep.ins = ins.report;
  std::vector<LidarFrames> lidars;
  for (const auto& indexer : indexers) {
    lidars.push_back(indexer->finish());
    rep.warnings.insert(rep.warnings.end(), lidars.back().warnings.begin(), lidars.back().warnings.end());
  }
  rep.clock = analyse_clocks(lidars, ins);
  check_clocks(rep.clock, path);

  std::vector<Fiducial> fiducials;
  if (options.fiducials) fiducials = read_bag_fiducials(*options.fiducials, ins.enu, ins.world_origin_m);
  std::optional<Iso3> init;
  if (options.init) init = read_init_extrinsic(*options.init);
  for (LidarFrames& l : lidars) {
    const std::vector<CloudFrame> used = frames_inside(l, ins.poses, rep.warnings, path);
    Dataset d;
    d.frames = make_frame_source(reader, l.topic, used, out.counters);
    d.poses = ins.poses;
    d.ins_quality = ins.ins_quality;
    d.world_origin_m = ins.world_origin_m;
    d.fiducials = fiducials;
    d.T_ins_lidar_init = init;
    out.lidar_names.push_back(l.report.name);
    out.lidars.push_back(std::move(d));
    rep.lidars.push_back(l.report);
  }
  return out;
}

BagTrajectory load_bag_trajectory(const BagOptions& options) {
  return load_bag_trajectory(std::shared_ptr<const bag::BagReader>(bag::open_bag(options.path, {options.read_cut_off})), options);
}

BagTrajectory load_bag_trajectory(std::shared_ptr<const bag::BagReader> reader, const BagOptions& options) {
  BagTrajectory t = trajectory_of(read_ins_source(*reader, choose_ins_source(*reader, options.ins_topic), ins_read_options(options)));
  t.warnings.insert(t.warnings.begin(), reader->warnings().begin(), reader->warnings().end());
  return t;
}

LoadReport to_load_report(const BagReport& report, std::size_t lidar) {
  const LidarTopicReport& l = report.lidars.at(lidar);
  LoadReport r;
  r.frames_total = l.messages;
  r.frames_used = l.frames_used;
  r.frames_outside_poses = l.frames_outside_ins;
  r.frames_bad = l.frames_duplicate;
  // The PCD names mean what Hesai, Velodyne and Ouster send; other conventions (Livox's absolute
  // nanoseconds, other field names) are said in the driver's words.
  const bool pcd_meaning = l.time_convention != bag::PointTimeConvention::kAbsoluteNanoseconds &&
                           (l.time_field == "timestamp" || l.time_field == "time" || l.time_field == "t" || l.time_field.empty());
  r.time_field = pcd_meaning ? l.time_field : l.time_description;
  r.frame_time_source = fmt::format("{} header.stamp {:+.6f} s (sweep end - stamp, median of {} decoded clouds; {})",
                                    l.topic, l.stamp_to_end_s, l.frames_sampled, l.time_description);
  std::string topics;
  for (const std::string& t : report.ins.topics) topics += (topics.empty() ? "" : " + ") + t;
  r.pose_format = "bag: " + report.ins.kind + " " + topics;
  r.warnings = report.warnings;
  return r;
}

namespace {

std::string lower_trimmed(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  const auto b = s.find_first_not_of(" \t\r"), e = s.find_last_not_of(" \t\r");
  return b == std::string::npos ? "" : s.substr(b, e - b + 1);
}

bool is_wgs84_marker(const std::string& line) {
  std::string s = lower_trimmed(line);
  if (s.empty() || s.front() != '#') return false;
  s = lower_trimmed(s.substr(1));
  return s == "wgs84" || s == "wgs-84";
}

double parse_number(const std::string& token, const std::string& file, const std::string& where, const char* what) {
  std::size_t used = 0;
  double v = 0.0;
  try {
    v = std::stod(token, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != token.size() || !std::isfinite(v)) {
    throw InputError(file, where, fmt::format("{} is not a finite number: '{}'", what, token));
  }
  return v;
}

std::vector<Fiducial> read_geodetic_fiducials(const std::filesystem::path& path, const LocalEnu& enu) {
  const std::string file = path.string();
  std::istringstream in(read_file(path));
  std::vector<Fiducial> out;
  std::set<std::string> ids;
  std::string line;
  for (std::size_t line_no = 1; std::getline(in, line); ++line_no) {
    if (line_no == 1) continue;  // the "# wgs84" marker
    if (const auto hash = line.find('#'); hash != std::string::npos) line.resize(hash);
    std::istringstream ss(line);
    std::vector<std::string> tok;
    for (std::string t; ss >> t;) tok.push_back(t);
    if (tok.empty()) continue;
    const std::string where = "line " + std::to_string(line_no);
    if (tok.size() != 4) {
      throw InputError(file, where, fmt::format("expected 'id lat_deg lon_deg ellipsoidal_height_m', found {} values", tok.size()));
    }
    const GeodeticPoint p{parse_number(tok[1], file, where, "latitude"), parse_number(tok[2], file, where, "longitude"),
                          parse_number(tok[3], file, where, "height")};
    try {
      check_geodetic(p);
    } catch (const std::invalid_argument& e) {
      throw InputError(file, where, e.what());
    }
    if (!ids.insert(tok[0]).second) throw InputError(file, where, "duplicate fiducial id '" + tok[0] + "'");
    out.push_back({tok[0], enu.position(p)});
  }
  return out;
}

std::string list_line(const std::vector<std::pair<std::string, std::size_t>>& counts) {
  std::string out;
  for (const auto& [k, n] : counts) out += fmt::format("{}{} {}", out.empty() ? "" : ", ", k, n);
  return out;
}

void describe_lidar(std::string& s, const LidarTopicReport& l) {
  s += fmt::format("LiDAR {} ({}, name '{}', frame '{}'): {} messages\n", l.topic, l.type, l.name, l.frame_id, l.messages);
  s += fmt::format("  per-point time: {}\n", l.time_description);
  std::string fields;
  for (const std::string& f : l.fields) fields += (fields.empty() ? "" : ", ") + f;
  s += fmt::format("  fields: {}\n", fields);
  s += fmt::format("  frame time = header.stamp {:+.6f} s (sweep end; spread {:.6f} s over {} decoded clouds, {:.0f} points each)\n",
                   l.stamp_to_end_s, l.stamp_to_end_spread_s, l.frames_sampled, l.mean_points);
  s += fmt::format("  frames used {} of {} ({} outside the INS range, {} duplicate stamps): {:.3f} .. {:.3f} s, {:.2f} Hz\n",
                   l.frames_used, l.messages, l.frames_outside_ins, l.frames_duplicate, l.t_begin_s, l.t_end_s, l.rate_hz);
}

void describe_ins(std::string& s, const InsReport& r) {
  std::string topics;
  for (std::size_t i = 0; i < r.topics.size(); ++i) topics += fmt::format("{}{} ({})", i ? " + " : "", r.topics[i], r.types[i]);
  s += fmt::format("INS {}: {}\n", r.kind, topics);
  s += fmt::format("  ins = {}\n  world = {}\n", r.ins_frame, r.world_frame);
  if (r.enu_origin) {
    s += fmt::format("  ENU origin: lat {:.9f} deg, lon {:.9f} deg, height {:.3f} m\n", r.enu_origin->lat_deg,
                     r.enu_origin->lon_deg, r.enu_origin->height_m);
  }
  s += fmt::format("  height: {}\n  time: {}\n", r.height_datum, r.time_base);
  s += fmt::format("  {} messages, {} records used ({} dropped): {:.3f} .. {:.3f} s, {:.2f} Hz\n", r.messages, r.records,
                   r.records_skipped, r.t_begin_s, r.t_end_s, r.rate_hz);
  if (!r.status_counts.empty()) s += "  status: " + list_line(r.status_counts) + "\n";
  if (!r.solution_fractions.empty()) {
    std::string f;
    for (const auto& [k, v] : r.solution_fractions) f += fmt::format("{}{} {:.1f}%", f.empty() ? "" : ", ", k, 100.0 * v);
    s += "  solution: " + f + "\n";
  }
  for (const std::string& n : r.not_used) s += "  not used: " + n + "\n";
}

}  // namespace

bool is_geodetic_fiducial_file(const std::filesystem::path& path) {
  std::istringstream in(read_file(path));
  std::string first;
  std::getline(in, first);
  return is_wgs84_marker(first);
}

std::vector<Fiducial> read_bag_fiducials(const std::filesystem::path& path, const std::optional<LocalEnu>& enu,
                                         const Vec3& world_origin_m) {
  std::vector<Fiducial> out;
  if (is_geodetic_fiducial_file(path)) {
    if (!enu) {
      throw InputError(path.string(), "line 1",
                       "geodetic fiducials (# wgs84) need a geodetic INS source (INSPVA(X), NavSatFix + Imu); this "
                       "INS source is cartesian: give the fiducials in its world frame");
    }
    out = read_geodetic_fiducials(path, *enu);
  } else {
    out = read_fiducials(path);
  }
  for (Fiducial& f : out) f.p_world -= world_origin_m;
  return out;
}

std::string describe_recording(const bag::BagReader& reader) {
  std::string s = fmt::format("{}: {}\n", reader.path().string(), reader.describe());
  const double t0 = static_cast<double>(reader.start_time_ns()) * 1e-9, t1 = static_cast<double>(reader.end_time_ns()) * 1e-9;
  s += fmt::format("record times {:.3f} .. {:.3f} s ({:.3f} s)\n", t0, t1, t1 - t0);
  for (const bag::Topic& t : reader.topics()) {
    const std::string type = bag::normalized_type(t.type);
    const auto kind = ins_source_kind(t.type);
    const std::string role = type == "sensor_msgs/PointCloud2" ? "LiDAR"
                             : kind                           ? std::string("INS: ") + ins_source_name(*kind)
                                                              : "not read";
    s += fmt::format("  {}  {}  {} msgs  ({})\n", t.name, t.type, t.message_count, role);
  }
  for (const std::string& w : reader.warnings()) s += "warning: " + w + "\n";
  return s;
}

std::string describe_trajectory(const BagTrajectory& trajectory) {
  std::string s;
  describe_ins(s, trajectory.report);
  if (!trajectory.poses.empty()) {
    const auto describe_pose = [&](const char* which, const StampedPose& p) {
      const Vec3 t = p.T_world_ins.translation() + trajectory.world_origin_m;
      const Eigen::Quaterniond q(p.T_world_ins.linear());
      return fmt::format("  {} pose at {:.6f} s: position {:.4f} {:.4f} {:.4f} m, orientation (x y z w) {:.7f} {:.7f} {:.7f} {:.7f}\n",
                         which, p.t_s, t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
    };
    s += describe_pose("first", trajectory.poses.poses().front());
    s += describe_pose("last", trajectory.poses.poses().back());
  }
  for (const std::string& w : trajectory.warnings) s += "warning: " + w + "\n";
  return s;
}

std::string describe_bag(const BagReport& report) {
  std::string s = fmt::format("{}: {}\n", report.path, report.container);
  for (const LidarTopicReport& l : report.lidars) describe_lidar(s, l);
  describe_ins(s, report.ins);
  s += "clocks: " + report.clock.summary + "\n";
  for (const std::string& w : report.warnings) s += "warning: " + w + "\n";
  return s;
}

}  // namespace insalign::io
