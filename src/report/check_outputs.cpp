#include "report/check_outputs.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <ctime>

#include "core/errors.hpp"
#include "files/atomic_file.hpp"
#include "files/extrinsic_json.hpp"
#include "files/formats.hpp"
#include "files/read_file.hpp"
#include "report/render.hpp"
#include "report/result_outputs.hpp"

namespace insalign::io {
namespace {

using nlohmann::json;

json number_or_null(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

json dofs_json(const std::array<DofCheck, 7>& dofs) {
  json out = json::object();
  for (int i = 0; i < 7; ++i) {
    const DofCheck& d = dofs[i];
    out[kCheckDofNames[i]] = {{"correction", number_or_null(d.correction)},
                              {"stddev", number_or_null(d.stddev)},
                              {"tolerance", d.tolerance},
                              {"unit", kCheckDofUnits[i]},
                              {"verdict", std::string(enum_name(d.verdict))},
                              {"why", d.why}};
  }
  return out;
}

json corrected_json(const CorrectedExtrinsic& c) {
  return {{"T_ins_lidar", transform_to_json(c.T_ins_lidar)}, {"time_offset_s", c.time_offset_s}};
}

CorrectedExtrinsic corrected_of(const LidarCheck& l) {
  return corrected_extrinsic(l.T_ins_lidar_installed, l.time_offset_installed_s, l.dofs());
}

json lidar_json(const LidarCheck& l) {
  const CheckRun& run = l.run;
  json used = json::array();
  for (const Stretch& s : run.used) used.push_back({{"begin_s", s.begin_s}, {"end_s", s.end_s}, {"why", s.why}});
  json out = {{"verdict", std::string(enum_name(l.verdict()))},
              {"message", l.message()},
              {"checked",
               {{"T_ins_lidar", transform_to_json(l.T_ins_lidar_installed)},
                {"time_offset_s", l.time_offset_installed_s},
                {"source", l.source},
                {"format", l.format}}},
              {"dofs", dofs_json(l.dofs())},
              {"corrected", corrected_json(corrected_of(l))},
              {"drives", l.history ? l.history->drives : 1},
              {"since", l.history ? l.history->since : l.drive_end},
              {"drive_end", l.drive_end},
              {"used", used},
              {"warnings", run.findings.warnings}};
  // This drive alone: what a history record is read from (the top level may combine drives).
  out["drive"] = {{"verdict", std::string(enum_name(run.findings.verdict))},
                  {"message", run.findings.message},
                  {"dofs", dofs_json(run.findings.dofs)},
                  {"corrected", corrected_json(corrected_extrinsic(l.T_ins_lidar_installed, l.time_offset_installed_s,
                                                                   run.findings.dofs))}};
  if (!run.why_unobservable.empty()) out["drive"]["why_unobservable"] = run.why_unobservable;
  if (l.history) {
    json steps = json::array();
    for (const HistoryStep& s : l.history->steps) steps.push_back({{"date", s.date}, {"before", s.before}, {"why", s.why}});
    out["history_steps"] = steps;
  }
  out["crispness_m"] = {{"installed", number_or_null(run.crispness_installed_m)},
                        {"corrected", number_or_null(run.crispness_corrected_m)}};
  out["frames_decoded"] = run.frames_decoded;
  out["frames_total"] = run.frames_total;
  out["wall_time_s"] = run.wall_time_s;
  return out;
}

std::string amount(int dof, double v) {
  if (!std::isfinite(v)) return "-";
  if (dof <= 2) return fmt::format("{:.1f} mm", 1e3 * v);
  if (dof == 6) return fmt::format("{:.2f} ms", 1e3 * v);
  return fmt::format("{:.3f} deg", v);
}

// The correction's +-2 stddev interval against the tolerance band, on an axis of +-3 tolerances.
std::string interval_svg(const DofCheck& d) {
  const double w = 240.0, half = 3.0 * d.tolerance, mid = w / 2.0;
  auto x = [&](double v) { return std::clamp(mid + v / half * mid, 0.0, w); };
  std::string s = fmt::format("<svg width=\"{}\" height=\"18\"><rect x=\"{:.1f}\" y=\"2\" width=\"{:.1f}\" height=\"14\" "
                              "fill=\"#dfd\"/><line x1=\"{:.1f}\" y1=\"0\" x2=\"{:.1f}\" y2=\"18\" stroke=\"#888\"/>",
                              w, x(-d.tolerance), x(d.tolerance) - x(-d.tolerance), mid, mid);
  if (std::isfinite(d.stddev) && std::isfinite(d.correction)) {
    const char* colour = d.verdict == DofVerdictKind::kDrifted ? "#c00" : (d.verdict == DofVerdictKind::kOk ? "#070" : "#c80");
    s += fmt::format("<line x1=\"{:.1f}\" y1=\"9\" x2=\"{:.1f}\" y2=\"9\" stroke=\"{}\" stroke-width=\"3\"/>"
                     "<circle cx=\"{:.1f}\" cy=\"9\" r=\"4\" fill=\"{}\"/>",
                     x(d.correction - 2 * d.stddev), x(d.correction + 2 * d.stddev), colour, x(d.correction), colour);
  }
  return s + "</svg>";
}

// What the reader needs first: the verdict and the per-DOF table.
std::string lidar_verdict_html(const LidarCheck& l) {
  std::string s;
  if (!l.name.empty()) s += "<h2>" + html_escape(l.name) + "</h2>\n";
  s += fmt::format("<p class=\"verdict {0}\"><b>{0}</b>: {1}</p>\n", enum_name(l.verdict()), html_escape(l.message()));
  s += "<table><tr><th>DOF</th><th>correction</th><th>stddev</th><th>tolerance</th><th>correction &plusmn; 2 stddev "
       "(green: tolerance; axis &plusmn; 3 tolerances)</th><th>verdict</th><th>why</th></tr>\n";
  for (int i = 0; i < 7; ++i) {
    const DofCheck& d = l.dofs()[i];
    s += fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
                     kCheckDofNames[i], amount(i, d.correction), amount(i, d.stddev), amount(i, d.tolerance),
                     interval_svg(d), enum_name(d.verdict), html_escape(d.why));
  }
  s += "</table>\n";
  return s;
}

// Below the 3D view: how the drive measured it.
std::string lidar_details_html(const LidarCheck& l) {
  std::string s;
  if (!l.name.empty()) s += "<h3>" + html_escape(l.name) + "</h3>\n";
  if (l.history)
    s += fmt::format("<p>History: {} drive{} since {}.</p>\n", l.history->drives, l.history->drives == 1 ? "" : "s",
                     html_escape(l.history->since));
  s += fmt::format("<p>Map crispness (point-to-plane RMS of {} stitched sweeps): installed {}, corrected {}.</p>\n",
                   "the check's", amount(0, l.run.crispness_installed_m), amount(0, l.run.crispness_corrected_m));
  s += "<p>Stretches used:</p><ul>\n";
  for (const Stretch& st : l.run.used)
    s += fmt::format("<li>{:.1f} s &ndash; {:.1f} s: {}</li>\n", st.begin_s, st.end_s, html_escape(st.why));
  s += "</ul>\n";
  if (!l.run.findings.warnings.empty()) {
    s += "<p>Warnings:</p><ul>\n";
    for (const std::string& w : l.run.findings.warnings) s += "<li>" + html_escape(w) + "</li>\n";
    s += "</ul>\n";
  }
  s += fmt::format("<p>Checked: {} ({}); {} of {} sweeps decoded in {:.1f} s.</p>\n", html_escape(l.source), l.format,
                   l.run.frames_decoded, l.run.frames_total, l.run.wall_time_s);
  return s;
}

const json& member(const json& j, const char* key, const std::string& file, const std::string& where) {
  if (!j.is_object() || !j.contains(key)) throw InputError(file, where, std::string("missing \"") + key + "\"");
  return j.at(key);
}

double number_in(const json& j, const char* key, const std::string& file, const std::string& where) {
  const json& v = member(j, key, file, where);
  if (v.is_null()) return std::numeric_limits<double>::infinity();
  if (!v.is_number()) throw InputError(file, where + "." + key, "not a number");
  return v.get<double>();
}

CheckRecord record_from(const json& l, const std::string& file, const std::string& where) {
  CheckRecord r;
  const json& drive = member(l, "drive", file, where);
  const json& checked = member(l, "checked", file, where);
  const json& corrected = member(drive, "corrected", file, where + ".drive");
  const json& dofs = member(drive, "dofs", file, where + ".drive");
  const json& end = member(l, "drive_end", file, where);
  if (!end.is_string()) throw InputError(file, where + ".drive_end", "not a string");
  r.drive_end = end.get<std::string>();
  r.T_ins_lidar_checked = transform_from_json(member(checked, "T_ins_lidar", file, where + ".checked"), file);
  r.time_offset_checked_s = number_in(checked, "time_offset_s", file, where + ".checked");
  r.T_ins_lidar_corrected = transform_from_json(member(corrected, "T_ins_lidar", file, where + ".drive.corrected"), file);
  r.time_offset_corrected_s = number_in(corrected, "time_offset_s", file, where + ".drive.corrected");
  if (!std::isfinite(r.time_offset_checked_s) || !std::isfinite(r.time_offset_corrected_s))
    throw InputError(file, where, "time_offset_s is null");
  for (int i = 0; i < 7; ++i) {
    const std::string at = where + ".drive.dofs." + kCheckDofNames[i];
    const double sd = number_in(member(dofs, kCheckDofNames[i], file, where + ".drive.dofs"), "stddev", file, at);
    if (!(sd > 0.0)) throw InputError(file, at + ".stddev", "not a positive number");
    r.stddev[i] = sd;
  }
  return r;
}

void write_one_corrected(const std::filesystem::path& dir, const Iso3& T, double offset_s, const std::array<DofCheck, 7>& dofs,
                         std::vector<std::filesystem::path>& files) {
  json ext = extrinsic_fields(T);
  ext["time_offset_s"] = offset_s;
  json sd = json::object();
  for (int i = 0; i < 7; ++i) sd[std::string(kCheckDofNames[i]) + "_" + kCheckDofUnits[i]] = number_or_null(dofs[i].stddev);
  ext["stddev"] = sd;
  ext["source"] = "insalign check";
  std::filesystem::create_directories(dir);
  for (const auto& f : write_all_formats(dir, T)) files.push_back(f);
  write_opencalib_extrinsic(dir / "gnss-to-lidar-extrinsic.json", T);
  files.push_back(dir / "gnss-to-lidar-extrinsic.json");
  write_file_atomic(dir / "extrinsic.json", ext.dump(2) + "\n");
  files.push_back(dir / "extrinsic.json");
}

}  // namespace

CheckVerdict rig_verdict(const std::vector<LidarCheck>& lidars) {
  CheckVerdict v = CheckVerdict::kOk;
  for (const LidarCheck& l : lidars) {
    if (l.verdict() == CheckVerdict::kRecalibrate) return CheckVerdict::kRecalibrate;
    if (l.verdict() == CheckVerdict::kInconclusive) v = CheckVerdict::kInconclusive;
  }
  return v;
}

std::string iso8601_utc(double unix_s) {
  const double whole = std::floor(unix_s);
  const std::time_t t = static_cast<std::time_t>(whole);
  std::tm tm{};
  gmtime_r(&t, &tm);
  const int ms = std::min(999, static_cast<int>(std::lround((unix_s - whole) * 1000.0)));
  return fmt::format("{:04}-{:02}-{:02}T{:02}:{:02}:{:02}.{:03}Z", tm.tm_year + 1900, tm.tm_mon + 1, tm.tm_mday,
                     tm.tm_hour, tm.tm_min, tm.tm_sec, ms);
}

std::string iso8601_basic(const std::string& extended) {
  std::string out;
  for (char c : extended)
    if (c != '-' && c != ':') out += c;
  return out;
}

json check_to_json(const std::vector<LidarCheck>& lidars) {
  if (lidars.size() == 1 && lidars[0].name.empty()) return lidar_json(lidars[0]);
  json out = {{"verdict", std::string(enum_name(rig_verdict(lidars)))}, {"lidars", json::object()}};
  for (const LidarCheck& l : lidars) out["lidars"][l.name] = lidar_json(l);
  return out;
}

std::string check_html(const std::vector<LidarCheck>& lidars, const std::string& viewer_html) {
  std::string s =
      "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>insalign check</title><style>"
      "body{font-family:sans-serif;max-width:1100px;margin:1em auto}table{border-collapse:collapse}"
      "td,th{border:1px solid #ccc;padding:3px 6px;font-size:90%}.verdict{font-size:130%}"
      ".ok{color:#070}.recalibrate{color:#c00}.inconclusive{color:#c80}</style></head><body>\n";
  s += fmt::format("<h1>insalign check: <span class=\"{0}\">{0}</span></h1>\n", enum_name(rig_verdict(lidars)));
  for (const LidarCheck& l : lidars) s += lidar_verdict_html(l);
  if (!viewer_html.empty())
    s += "<h2>The map in 3D</h2>\n<p>The drive's map at the installed and at the corrected extrinsic: press <kbd>B</kbd> "
         "to switch (the camera stays), <kbd>C</kbd> to colour by frame time" +
         std::string(lidars.size() > 1 ? " or by LiDAR" : "") +
         ". In colour: sweeps of the stretches the check used; in grey, where the check used part of the drive, sweeps "
         "beyond them (<kbd>L</kbd> hides these and the left-out points).</p>\n" + viewer_html;
  s += lidars.size() > 1 ? "<h2>How the drive measured it</h2>\n" : "";
  for (const LidarCheck& l : lidars) s += lidar_details_html(l);
  return s + "</body></html>\n";
}

void write_check_html(const std::filesystem::path& out_dir, const std::vector<LidarCheck>& lidars) {
  std::string viewer_html;
  if (lidars.size() == 1 && lidars[0].viewer.size() > 0) viewer_html = write_viewer(out_dir, lidars[0].viewer);
  if (lidars.size() > 1) {  // one view, coloured by LiDAR (a page holds one viewer)
    std::vector<ViewerScene> scenes;
    std::vector<std::string> names;
    for (const LidarCheck& l : lidars) {
      scenes.push_back(l.viewer);
      names.push_back(l.name);
    }
    const ViewerScene rig = merge_scenes(std::move(scenes), names);
    if (rig.size() > 0) viewer_html = write_viewer(out_dir, rig);
  }
  write_file_atomic(out_dir / "check.html", check_html(lidars, viewer_html));
}

std::map<std::string, CheckRecord> parse_check_record(std::string_view text, const std::string& file) {
  json j;
  try {
    j = json::parse(text);
  } catch (const json::parse_error& e) {
    throw InputError(file, "byte " + std::to_string(e.byte), "malformed JSON");
  }
  if (!j.is_object()) throw InputError(file, "", "expected a check.json object");
  std::map<std::string, CheckRecord> out;
  if (!j.contains("lidars")) {
    out[""] = record_from(j, file, "top level");
    return out;
  }
  const json& lidars = j.at("lidars");
  if (!lidars.is_object()) throw InputError(file, "lidars", "expected an object");
  for (const auto& [name, l] : lidars.items()) out[name] = record_from(l, file, "lidars." + name);
  return out;
}

std::map<std::string, std::vector<CheckRecord>> read_history(const std::filesystem::path& dir, const std::string& skip) {
  std::map<std::string, std::vector<CheckRecord>> out;
  if (!std::filesystem::is_directory(dir)) return out;
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (e.is_regular_file() && name.size() > 11 && name.ends_with(".check.json") && name != skip) files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  for (const auto& f : files)
    for (auto& [name, record] : parse_check_record(read_file(f), f.string())) out[name].push_back(std::move(record));
  return out;
}

std::vector<std::filesystem::path> write_corrected(const std::filesystem::path& out_dir, const std::vector<LidarCheck>& lidars) {
  std::vector<std::filesystem::path> files;
  const std::filesystem::path dir = out_dir / "corrected";
  if (lidars.size() == 1 && lidars[0].name.empty()) {
    const CorrectedExtrinsic c = corrected_of(lidars[0]);
    write_one_corrected(dir, c.T_ins_lidar, c.time_offset_s, lidars[0].dofs(), files);
    return files;
  }
  json rig = {{"lidars", json::object()}, {"T_lidar_lidar", json::object()}};
  std::vector<std::pair<std::string, Iso3>> placed;
  for (const LidarCheck& l : lidars) {
    const CorrectedExtrinsic c = corrected_of(l);
    write_one_corrected(dir / l.name, c.T_ins_lidar, c.time_offset_s, l.dofs(), files);
    Vec6 sd;
    std::array<bool, 6> determined{};
    for (int i = 0; i < 6; ++i) {
      sd(i) = i >= 3 ? l.dofs()[i].stddev * kRadPerDeg : l.dofs()[i].stddev;
      determined[i] = std::isfinite(sd(i));
    }
    rig["lidars"][l.name] = {{"T_ins_lidar", transform_to_json(c.T_ins_lidar)},
                             {"time_offset_s", c.time_offset_s},
                             {"stddev", dof_json(sd)},
                             {"determined", determined_json(determined)}};
    placed.emplace_back(l.name, c.T_ins_lidar);
  }
  for (std::size_t a = 0; a < placed.size(); ++a)
    for (std::size_t b = a + 1; b < placed.size(); ++b)
      rig["T_lidar_lidar"][placed[a].first + "__" + placed[b].first] =
          transform_to_json(placed[a].second.inverse() * placed[b].second);
  write_file_atomic(dir / "rig.json", rig.dump(2) + "\n");
  files.push_back(dir / "rig.json");
  return files;
}

}  // namespace insalign::io
