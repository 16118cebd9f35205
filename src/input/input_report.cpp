#include "input/input_report.hpp"

#include <fmt/format.h>

#include <cmath>

namespace insalign::io {
namespace {

using nlohmann::json;

std::string fractions_text(const std::vector<std::pair<std::string, double>>& f) {
  std::string out;
  for (const auto& [name, v] : f) out += fmt::format("{}{} {:.1f}%", out.empty() ? "" : ", ", name, 100.0 * v);
  return out;
}

json facts_json(const PoseSourceFacts& f) {
  json j = {{"path", f.path},         {"kind", f.kind},
            {"format", f.format},     {"time_base", f.time_base},
            {"ins_frame", f.body_frame}, {"height_datum", f.height_datum},
            {"world_frame", f.world_frame}, {"records", f.records},
            {"records_skipped", f.records_skipped}, {"t_begin_s", f.t_begin_s},
            {"t_end_s", f.t_end_s},   {"rate_hz", f.rate_hz}};
  if (!f.columns.empty()) j["columns"] = f.columns;
  j["solution_fractions"] = json::object();
  for (const auto& [name, v] : f.solution_fractions) j["solution_fractions"][name] = v;
  if (f.enu_origin) {
    j["enu_origin"] = {{"lat_deg", f.enu_origin->lat_deg}, {"lon_deg", f.enu_origin->lon_deg},
                       {"height_m", f.enu_origin->height_m}};
  }
  return j;
}

json clock_json(const ClockAlignment& c) {
  json candidates = json::array();
  for (const ClockCandidate& k : c.candidates) {
    candidates.push_back({{"offset_s", k.offset_s},
                          {"meaning", k.meaning},
                          {"inside_fraction", k.inside_fraction},
                          {"pairs", k.pairs},
                          {"median_diff_deg", std::isfinite(k.median_diff_deg) ? json(k.median_diff_deg) : json(nullptr)}});
  }
  json pairs = json::array();
  for (const ClockPair& p : c.pairs) {
    json ins = json::array();
    for (const double d : p.ins_deg) ins.push_back(std::isfinite(d) ? json(d) : json(nullptr));
    pairs.push_back({{"frames", {p.frame_a, p.frame_b}}, {"lidar_deg", p.lidar_deg}, {"ins_deg", ins}});
  }
  return {{"ins_minus_lidar_s", c.offset_s}, {"meaning", c.meaning},     {"checked_by_data", c.checked_by_data},
          {"decision", c.decision},         {"summary", c.summary},     {"evidence", c.evidence},
          {"lidar_range_s", {c.lidar_begin_s, c.lidar_end_s}},           {"ins_range_s", {c.ins_begin_s, c.ins_end_s}},
          {"candidates", candidates},       {"pairs", pairs}};
}

}  // namespace

std::string describe_time_field(const std::string& field) {
  if (field == "timestamp") return "timestamp (absolute seconds per point)";
  if (field == "time") return "time (seconds per point, relative to the sweep)";
  if (field == "t") return "t (nanoseconds per point from the sweep start)";
  if (field == "azimuth") return "none in the file: derived from each point's azimuth (KITTI velodyne)";
  if (field.empty()) return "none (no per-point time: sweeps cannot be deskewed)";
  return field;
}

json input_json(const LoadReport& load) {
  json j = {{"kind", load.input_kind},
            {"source", load.source},
            {"frames_total", load.frames_total},
            {"frames_used", load.frames_used},
            {"frames_outside_poses", load.frames_outside_poses},
            {"frames_skipped_bad", load.frames_bad},
            {"time_field", load.time_field},
            {"frame_time_source", load.frame_time_source},
            {"pose_format", load.pose_format},
            {"poses", facts_json(load.ins)},
            {"fiducials", load.fiducials},
            {"init", load.init},
            {"warnings", load.warnings}};
  if (load.clock) j["clock"] = clock_json(*load.clock);
  return j;
}

std::vector<std::pair<std::string, std::string>> input_rows(const LoadReport& load) {
  std::vector<std::pair<std::string, std::string>> rows = {
      {"input", fmt::format("{}: {}", load.input_kind, load.source)},
      {"pose source", fmt::format("{} ({})", load.ins.format, load.ins.path)},
      {"ins frame", load.ins.body_frame},
      {"time base", load.ins.time_base},
      {"height datum", load.ins.height_datum}};
  if (!load.ins.solution_fractions.empty()) rows.emplace_back("GNSS solution", fractions_text(load.ins.solution_fractions));
  if (load.clock) rows.emplace_back("clocks", load.clock->summary + (load.clock->evidence.empty() ? "" : ". " + load.clock->evidence));
  if (!load.fiducials.empty()) rows.emplace_back("fiducials", load.fiducials);
  if (!load.init.empty()) rows.emplace_back("initial guess", load.init);
  return rows;
}

std::string describe_pose_source(const PoseSourceFacts& f) {
  std::string s = fmt::format("Poses            {}\n", f.path);
  s += fmt::format("  format         {}\n", f.format);
  if (!f.columns.empty()) s += fmt::format("  columns        {}\n", f.columns);
  s += fmt::format("  records        {} ({} skipped), {:.2f} Hz, {:.3f} .. {:.3f} s\n", f.records, f.records_skipped, f.rate_hz,
                   f.t_begin_s, f.t_end_s);
  s += fmt::format("  time base      {}\n", f.time_base);
  s += fmt::format("  ins frame      {}\n", f.body_frame);
  s += fmt::format("  height datum   {}\n", f.height_datum);
  s += fmt::format("  world          {}\n", f.world_frame);
  if (f.enu_origin) {
    s += fmt::format("  ENU origin     lat {:.9f} deg, lon {:.9f} deg, height {:.3f} m\n", f.enu_origin->lat_deg,
                     f.enu_origin->lon_deg, f.enu_origin->height_m);
  }
  s += fmt::format("  GNSS solution  {}\n", f.solution_fractions.empty() ? "not stated by the source" : fractions_text(f.solution_fractions));
  return s;
}

std::string describe_clock(const ClockAlignment& c) {
  std::string s = fmt::format("Clocks           {}\n", c.summary);
  if (!c.evidence.empty()) s += fmt::format("  evidence       {}\n", c.evidence);
  if (c.offset_s != 0.0) s += fmt::format("  applied        t_ins = t_lidar {:+g} s\n", c.offset_s);
  return s;
}

}  // namespace insalign::io
