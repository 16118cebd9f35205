#include "report/report.hpp"

#include <fmt/chrono.h>
#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <cctype>
#include <chrono>
#include <cmath>

#include "files/atomic_file.hpp"
#include "report/render.hpp"

namespace insalign::io {
namespace {

constexpr const char* kImageDir = "report";
constexpr std::array<const char*, 6> kDofNames = {"x", "y", "z", "roll", "pitch", "yaw"};

std::string esc(const std::string& s) { return html_escape(s); }

double r1(double v) { return std::round(v * 10.0) / 10.0 + 0.0; }  // one decimal, never "-0.0"

std::string num(double v, int decimals) {
  if (!std::isfinite(v)) return "&ndash;";
  return fmt::format("{:.{}f}", v, decimals);
}

// [x y z] in metres and [roll pitch yaw] in degrees (ZYX).
Vec6 pose6(const Iso3& T) {
  Vec6 v;
  v.head<3>() = T.translation();
  v.tail<3>() = rpy_from_rotation(T.linear()) * kDegPerRad;
  return v;
}

// File-name-safe form of a label.
std::string slug(const std::string& s) {
  std::string out;
  for (char c : s) out += std::isalnum(static_cast<unsigned char>(c)) ? static_cast<char>(std::tolower(c)) : '_';
  return out.empty() ? "map" : out;
}

std::string extrinsic_cells(const Iso3& T) {
  const Vec6 v = pose6(T);
  std::string out;
  for (int i = 0; i < 3; ++i) out += "<td class=\"n\">" + num(v[i], 4) + "</td>";
  for (int i = 3; i < 6; ++i) out += "<td class=\"n\">" + num(v[i], 3) + "</td>";
  return out;
}

// Rotation angle (deg) and translation distance (m) between two extrinsics.
std::pair<double, double> change(const Iso3& from, const Iso3& to) {
  const double angle = Eigen::AngleAxisd(to.linear() * from.linear().transpose()).angle() * kDegPerRad;
  return {angle, (to.translation() - from.translation()).norm()};
}

const char* kStyle = R"(
body { font-family: -apple-system, "Segoe UI", Roboto, "DejaVu Sans", sans-serif; margin: 24px auto; max-width: 1240px;
       color: #1d1d1f; line-height: 1.4; padding: 0 16px; }
h1 { font-size: 26px; margin-bottom: 4px; } h2 { font-size: 20px; margin-top: 34px; border-bottom: 1px solid #ddd; padding-bottom: 4px; }
h3 { font-size: 16px; margin: 18px 0 6px; }
.meta { color: #666; font-size: 13px; }
table { border-collapse: collapse; margin: 8px 0; font-size: 14px; }
th, td { border: 1px solid #d5d5d5; padding: 4px 9px; text-align: left; vertical-align: top; }
th { background: #f2f4f7; } td.n { text-align: right; font-variant-numeric: tabular-nums; font-family: "DejaVu Sans Mono", monospace; }
.result { background: #f3f8ff; border: 1px solid #b7d0f0; border-radius: 6px; padding: 12px 18px; }
.result .big { font-size: 18px; font-family: "DejaVu Sans Mono", monospace; }
.warn { background: #fff5e0; border: 1px solid #f0c36d; border-radius: 6px; padding: 8px 16px; }
.ok { color: #18794e; font-weight: bold; } .bad { color: #b42318; font-weight: bold; }
tr.bad td { background: #fdecea; }
.grid { display: grid; grid-template-columns: repeat(auto-fill, minmax(480px, 1fr)); gap: 14px; }
.row { display: flex; flex-wrap: wrap; gap: 12px; align-items: flex-start; }
figure { margin: 0; } figure img { max-width: 100%; border: 1px solid #ccc; display: block; }
figcaption { font-size: 13px; color: #444; margin-top: 3px; }
pre { background: #f6f6f6; padding: 8px; overflow-x: auto; font-size: 13px; }
)";

std::string figure(const std::string& file, const std::string& caption) {
  return fmt::format("<figure><a href=\"{0}\"><img src=\"{0}\" alt=\"{1}\"></a><figcaption>{1}</figcaption></figure>\n",
                     esc(file), esc(caption));
}

}  // namespace

namespace {

// One map's pictures: its views and sections, rendered and encoded in parallel.
void draw_map(const MapSnapshot& m, std::size_t i, const MapFrame& frame, ReportImages& images,
              std::vector<std::pair<std::string, std::string>>& pngs) {
  SnapshotImages& s = images.snaps[i];
  s.label = m.label;
  const std::string base = fmt::format("{}/map{}_{}", kImageDir, i, slug(m.label));
  const std::array<std::pair<MapView, const char*>, 3> views = {
      {{MapView::kTop, "top"}, {MapView::kFront, "front"}, {MapView::kSide, "side"}}};
  for (const auto& [view, name] : views) {
    s.views.emplace_back(base + "_" + name + ".png", m.label + ": " + name + " view, coloured by height" +
                                                         (m.p_moving_world.empty() ? "" : "; magenta: moving things, left out"));
  }
  if (images.wall) s.wall_file = base + "_wall.png";
  if (images.ground) s.ground_file = base + "_ground.png";
  std::array<std::string, 5> png;  // top, front, side, wall, ground
  tbb::parallel_for(0, 5, [&](int k) {
    if (k < 3) {
      png[k] = encode_png(render_map_view(m.p_world, frame, views[k].first, 900, 220, &m.p_moving_world));
      return;
    }
    const std::optional<Section>& section = k == 3 ? images.wall : images.ground;
    if (!section) return;
    SectionStats& stats = k == 3 ? s.wall : s.ground;
    stats = section_stats(m.p_world, *section);
    png[k] = encode_png(render_section(m.p_world, *section, 250.0,
                                       fmt::format("{}: {} {:.1f} cm", m.label, k == 3 ? "wall" : "ground",
                                                   100 * stats.thickness_m)));
  });
  for (std::size_t v = 0; v < views.size(); ++v) pngs.emplace_back(s.views[v].first, std::move(png[v]));
  if (images.wall) pngs.emplace_back(s.wall_file, std::move(png[3]));
  if (images.ground) pngs.emplace_back(s.ground_file, std::move(png[4]));
}

}  // namespace

// The final map first: its framing serves every map, and the sections are picked on it.
ReportImages draw_report_images(std::size_t maps, const std::function<MapSnapshot(std::size_t)>& map) {
  ReportImages images;
  if (maps == 0) return images;
  images.snaps.resize(maps);
  std::vector<std::vector<std::pair<std::string, std::string>>> pngs(maps);
  MapFrame frame;
  {
    const MapSnapshot final_map = map(maps - 1);
    frame = frame_map(final_map.p_world);
    const MapSections sections = find_sections(final_map.p_world);
    images.wall = sections.wall;
    images.ground = sections.ground;
    draw_map(final_map, maps - 1, frame, images, pngs[maps - 1]);
  }
  for (std::size_t i = 0; i + 1 < maps; ++i) draw_map(map(i), i, frame, images, pngs[i]);
  for (auto& p : pngs) std::move(p.begin(), p.end(), std::back_inserter(images.png_files));
  return images;
}

std::vector<Section> report_sections(const ReportImages& images) {
  std::vector<Section> out;
  if (images.wall) out.push_back(*images.wall);
  if (images.ground) out.push_back(*images.ground);
  return out;
}

ReportImages draw_report_images(const std::vector<MapSnapshot>& maps) {
  return draw_report_images(maps.size(), [&](std::size_t i) { return maps[i]; });
}

namespace {

std::string html_result(const ReportData& data) {
  std::string h;
  const Vec6 v = pose6(data.T_ins_lidar);
  h += "<h2>Result</h2>\n<div class=\"result\">\n";
  h += fmt::format("<div>T_{}_{} (the LiDAR's pose in the INS frame; ZYX roll, pitch, yaw)</div>\n",
                   esc(data.parent_frame), esc(data.child_frame));
  h += fmt::format(
      "<div class=\"big\">x {:.4f} m &nbsp; y {:.4f} m &nbsp; z {:.4f} m<br>roll {:.4f}&deg; &nbsp; pitch {:.4f}&deg; "
      "&nbsp; yaw {:.4f}&deg;</div>\n",
      v[0], v[1], v[2], v[3], v[4], v[5]);
  if (data.time_offset_s) {
    h += fmt::format("<div>time offset {:.2f} ms (t_ins = t_lidar + offset)</div>\n", *data.time_offset_s * 1e3);
  }
  if (data.observability) {
    h += "<div>determined: ";
    for (int i = 0; i < 6; ++i) {
      h += fmt::format("<span class=\"{}\">{} {}</span> &nbsp;", data.observability->determined[i] ? "ok" : "bad",
                       kDofNames[i], data.observability->determined[i] ? "&#10003;" : "&#10007;");
    }
    h += "</div>\n";
  }
  h += "<pre>";
  const Eigen::Matrix4d M = data.T_ins_lidar.matrix();
  for (int r = 0; r < 4; ++r) {
    h += fmt::format("{:>14.9f} {:>14.9f} {:>14.9f} {:>14.9f}\n", M(r, 0), M(r, 1), M(r, 2), M(r, 3));
  }
  h += "</pre></div>\n";
  return h;
}

std::string html_warnings(const ReportData& data) {
  if (data.warnings.empty()) return "";
  std::string h;
  h += "<h2>Warnings</h2>\n<div class=\"warn\"><ul>\n";
  for (const auto& w : data.warnings) h += "<li>" + esc(w) + "</li>\n";
  h += "</ul></div>\n";
  return h;
}

// The INS spans and the points the stages did not use, and why.
std::string html_left_out(const ReportData& data) {
  if (data.left_out.empty()) return "";
  std::string h = "<h2>Left out</h2>\n<ul>\n";
  for (const std::string& line : data.left_out) h += "<li>" + esc(line) + "</li>\n";
  return h + "</ul>\n";
}

std::string html_inputs(const ReportData& data) {
  if (data.input_summary.empty()) return "";
  std::string h;
  h += "<h2>Input</h2>\n<table>\n";
  for (const auto& [k, v] : data.input_summary) h += "<tr><th>" + esc(k) + "</th><td>" + esc(v) + "</td></tr>\n";
  h += "</table>\n";
  return h;
}

std::string html_stages(const ReportData& data) {
  if (data.stages.empty()) return "";
  std::string h;
  h += "<h2>Stages</h2>\n<table>\n<tr><th>stage</th><th>x m</th><th>y m</th><th>z m</th><th>roll &deg;</th>"
       "<th>pitch &deg;</th><th>yaw &deg;</th><th>change from previous</th><th>time offset ms</th>"
       "<th>crispness (lower is crisper)</th><th>wall time s</th><th>note</th></tr>\n";
  for (std::size_t i = 0; i < data.stages.size(); ++i) {
    const StageRow& s = data.stages[i];
    std::string delta = "&ndash;";
    if (i > 0) {
      const auto [angle, dist] = change(data.stages[i - 1].T_ins_lidar, s.T_ins_lidar);
      delta = fmt::format("{:.3f}&deg;, {:.1f} cm", angle, 100 * dist);
    }
    std::string metric;
    if (!s.metric_name.empty()) {
      metric = esc(s.metric_name) + ": " + num(s.metric_before, 5) + " &rarr; " + num(s.metric_after, 5);
      if (std::isfinite(s.metric_before) && std::isfinite(s.metric_after) && s.metric_before != 0) {
        metric += fmt::format(" ({:+.1f}%)", 100 * (s.metric_after / s.metric_before - 1));
      }
    }
    h += "<tr><td>" + esc(s.stage) + "</td>" + extrinsic_cells(s.T_ins_lidar) + "<td>" + delta +
         "</td><td class=\"n\">" + num(s.time_offset_s * 1e3, 2) + "</td><td>" + metric + "</td><td class=\"n\">" +
         num(s.wall_time_s, 1) + "</td><td>" + esc(s.note) + "</td></tr>\n";
  }
  h += "</table>\n";
  return h;
}

std::string html_convergence(const ReportData& data) {
  if (data.convergence.empty()) return "";
  std::string h;
  // Each round relative to the final result: how the estimate walked in, per DOF.
  Plot rot{"Rotation per round, relative to the final result", "round", "degrees", {}, {}, 900, 300};
  Plot trans{"Translation per round, relative to the final result", "round", "centimetres", {}, {}, 900, 300};
  Plot cost{"Cost per round, relative to the stage's first round", "round", "cost / first", {}, {}, 900, 260};
  const std::array<const char*, 3> colours = {"#d62728", "#2ca02c", "#1f77b4"};
  for (int k = 0; k < 3; ++k) {
    rot.series.push_back({kDofNames[3 + k], colours[k], {}, {}});
    trans.series.push_back({kDofNames[k], colours[k], {}, {}});
  }
  std::vector<PlotSeries> costs;
  const Mat3 R_final = data.T_ins_lidar.linear();
  std::string stage;
  double first_cost = 0;
  for (std::size_t i = 0; i < data.convergence.size(); ++i) {
    const ConvergencePoint& c = data.convergence[i];
    const double x = static_cast<double>(i + 1);
    if (c.stage != stage) {
      stage = c.stage;
      first_cost = c.cost;
      rot.x_marks.emplace_back(x, stage);
      trans.x_marks.emplace_back(x, stage);
      cost.x_marks.emplace_back(x, stage);
      static constexpr std::array<const char*, 4> stage_colours = {"#9467bd", "#ff7f0e", "#17becf", "#8c564b"};
      costs.push_back({stage, stage_colours[costs.size() % stage_colours.size()], {}, {}});
    }
    const Vec3 drpy = rpy_from_rotation(c.T_ins_lidar.linear() * R_final.transpose()) * kDegPerRad;
    const Vec3 dt = (c.T_ins_lidar.translation() - data.T_ins_lidar.translation()) * 100.0;
    for (int k = 0; k < 3; ++k) {
      rot.series[k].x.push_back(x);
      rot.series[k].y.push_back(drpy[k]);
      trans.series[k].x.push_back(x);
      trans.series[k].y.push_back(dt[k]);
    }
    if (std::isfinite(c.cost) && std::isfinite(first_cost) && first_cost != 0) {
      costs.back().x.push_back(x);
      costs.back().y.push_back(c.cost / first_cost);
    }
  }
  cost.series = costs;
  h += "<h2>Convergence</h2>\n<div>" + svg_line_plot(rot) + "</div>\n<div>" + svg_line_plot(trans) + "</div>\n";
  if (!costs.empty()) h += "<div>" + svg_line_plot(cost) + "</div>\n";
  return h;
}

// The INS position correction over the drive: what the poses were off by, as the map saw it.
std::string html_trajectory_correction(const ReportData& data) {
  if (!data.trajectory_correction) return "";
  const TrajectoryCorrectionReport& c = *data.trajectory_correction;
  Plot plot{"INS position correction (corrected = reported + this)", "time after the first frame (s)", "cm", {}, {}};
  const std::array<const char*, 3> names = {"east (world x)", "north (world y)", "up (world z)"};
  const std::array<const char*, 3> colours = {"#d62728", "#2ca02c", "#1f77b4"};
  for (int k = 0; k < 3; ++k) {
    PlotSeries s{names[k], colours[k], c.t_s, {}};
    for (const Vec3& p : c.position_m) s.y.push_back(100.0 * p[k]);
    plot.series.push_back(s);
  }
  return "<h2>INS trajectory correction</h2>\n<p class=\"" + std::string(c.applied ? "bad" : "ok") + "\">" +
         esc(c.decision) + "</p>\n<div>" + svg_line_plot(plot) + "</div>\n";
}

// The 3D view (report/viewer.hpp), before the pictures it complements.
std::string html_viewer(const ReportImages& images) {
  if (images.viewer.html.empty()) return "";
  return "<h2>3D map: start and result</h2>\n<p>The stitched map placed with the starting extrinsic and with the result: "
         "switch with <kbd>B</kbd> (the camera stays), look for walls that double and poles that lean.</p>\n" +
         images.viewer.html;
}

std::string html_maps(const ReportImages& images) {
  const auto& snaps = images.snaps;
  const auto& wall = images.wall;
  const auto& ground = images.ground;
  if (snaps.empty()) return "";
  std::string h;
  h += "<h2>Cross-sections: is the map thinner?</h2>\n";
  h += fmt::format("<p>A thin slab of the stitched map ({}{}), viewed edge-on, at the same place for every extrinsic ",
                   wall ? fmt::format("wall: {:.0f} cm deep", 200 * wall->half_depth_m) : "",
                   ground ? fmt::format("{}ground: {:.0f} cm deep", wall ? ", " : "", 200 * ground->half_depth_m) : "");
  h += "(picked automatically on the final map). With the right extrinsic every frame puts a surface at the same "
       "place, so walls and ground are as thin as the LiDAR's range noise. Grid lines every 10 cm. Thickness = "
       "1.4826 &times; median absolute deviation across the surface.</p>\n";
  h += "<table><tr><th>map</th><th>wall thickness cm</th><th>ground thickness cm</th><th>points (wall / ground)</th></tr>\n";
  for (const auto& s : snaps) {
    h += "<tr><td>" + esc(s.label) + "</td><td class=\"n\">" +
         (wall ? num(100 * s.wall.thickness_m, 2) : std::string("no wall found")) + "</td><td class=\"n\">" +
         (ground ? num(100 * s.ground.thickness_m, 2) : std::string("no ground found")) + "</td><td class=\"n\">" +
         std::to_string(s.wall.points) + " / " + std::to_string(s.ground.points) + "</td></tr>\n";
  }
  h += "</table>\n";
  if (wall) {
    h += fmt::format("<h3>Wall (centre {:.1f}, {:.1f}, {:.1f} m; image x along the wall normal, up = z)</h3>\n<div class=\"row\">\n",
                     r1(wall->centre_m.x()), r1(wall->centre_m.y()), r1(wall->centre_m.z()));
    for (const auto& s : snaps) h += figure(s.wall_file, s.label);
    h += "</div>\n";
  }
  if (ground) {
    h += fmt::format("<h3>Ground (centre {:.1f}, {:.1f}, {:.1f} m; image x along world x, up = z)</h3>\n<div class=\"grid\">\n",
                     r1(ground->centre_m.x()), r1(ground->centre_m.y()), r1(ground->centre_m.z()));
    for (const auto& s : snaps) h += figure(s.ground_file, s.label);
    h += "</div>\n";
  }
  h += "<h2>Stitched map</h2>\n<p>The same framing for every extrinsic; colour is height, shade is point density. "
       "Click an image for full size.</p>\n";
  for (std::size_t v = 0; v < snaps.front().views.size(); ++v) {
    h += "<div class=\"grid\">\n";
    for (const auto& s : snaps) h += figure(s.views[v].first, s.views[v].second);
    h += "</div>\n";
  }
  return h;
}

std::string html_fiducials(const ReportData& data) {
  if (data.fiducials.empty() && data.fiducial_summary.empty()) return "";
  std::string h;
  h += "<h2>Fiducials (stage 3: z)</h2>\n";
  if (!data.fiducial_summary.empty()) h += "<p>" + esc(data.fiducial_summary) + "</p>\n";
  if (!data.fiducials.empty()) {
    h += "<table><tr><th>id</th><th>residual before cm</th><th>residual after cm</th><th>used</th><th>why not</th></tr>\n";
    for (const auto& f : data.fiducials) {
      h += std::string(f.used ? "<tr>" : "<tr class=\"bad\">") + "<td>" + esc(f.id) + "</td><td class=\"n\">" +
           num(100 * f.residual_before_m, 2) + "</td><td class=\"n\">" + num(100 * f.residual_after_m, 2) +
           "</td><td>" + (f.used ? "yes" : "no") + "</td><td>" + esc(f.reason) + "</td></tr>\n";
    }
    h += "</table>\n";
  }
  return h;
}

std::string html_time_offset(const ReportData& data) {
  if (!data.time_offset_s && data.time_offset_note.empty()) return "";
  std::string h;
  h += "<h2>Time offset</h2>\n<p>";
  if (data.time_offset_s) {
    h += fmt::format("t_ins = t_lidar + {:.3f} ms", *data.time_offset_s * 1e3);
    if (data.time_offset_stddev_s) h += fmt::format(" &plusmn; {:.3f} ms (1&sigma;)", *data.time_offset_stddev_s * 1e3);
    h += ". ";
  }
  h += esc(data.time_offset_note) + "</p>\n";
  return h;
}

std::string html_observability(const ReportData& data) {
  if (!data.observability) return "";
  std::string h;
  const ObservabilityReport& o = *data.observability;
  h += "<h2>Observability</h2>\n<table><tr><th>DOF</th><th>determined by the drive</th><th>standard deviation</th></tr>\n";
  for (int i = 0; i < 6; ++i) {
    const std::string sd = !std::isfinite(o.stddev[i]) ? std::string("&ndash;")
                           : i < 3 ? num(100 * o.stddev[i], 2) + " cm" : num(o.stddev[i] * kDegPerRad, 4) + "&deg;";
    h += std::string(o.determined[i] ? "<tr>" : "<tr class=\"bad\">") + "<td>" + kDofNames[i] + "</td><td>" +
         (o.determined[i] ? "<span class=\"ok\">yes</span>" : "<span class=\"bad\">no</span>") +
         "</td><td class=\"n\">" + sd + "</td></tr>\n";
  }
  h += "</table>\n<p>" + esc(o.explanation) + "</p>\n";
  return h;
}

std::string html_repeatability(const ReportData& data) {
  if (!data.repeatability) return "";
  std::string h;
  const RepeatabilityReport& r = *data.repeatability;
  h += "<h2>Repeatability (disjoint segments of the drive, no ground truth needed)</h2>\n";
  h += "<table><tr><th>segment</th><th>x m</th><th>y m</th><th>z m</th><th>roll &deg;</th><th>pitch &deg;</th>"
       "<th>yaw &deg;</th><th>time offset ms</th><th>note</th></tr>\n";
  h += "<tr><td><b>full drive</b></td>" + extrinsic_cells(data.T_ins_lidar) + "<td class=\"n\">" +
       (data.time_offset_s ? num(*data.time_offset_s * 1e3, 2) : std::string("&ndash;")) + "</td><td></td></tr>\n";
  for (const auto& s : r.segments) {
    if (s.ok) {
      h += "<tr><td>" + esc(s.label) + "</td>" + extrinsic_cells(s.T_ins_lidar) + "<td class=\"n\">" +
           num(s.time_offset_s * 1e3, 2) + "</td><td>" + esc(s.message) + "</td></tr>\n";
    } else {
      h += "<tr class=\"bad\"><td>" + esc(s.label) + "</td><td colspan=\"7\">failed</td><td>" + esc(s.message) + "</td></tr>\n";
    }
  }
  h += "<tr><th>spread (max &minus; min)</th>";
  bool any_large = false;
  for (int i = 0; i < 6; ++i) {
    const bool large = std::isfinite(r.spread[i]) && r.spread[i] > r.warn_above[i];
    any_large |= large;
    const double shown = i < 3 ? r.spread[i] : r.spread[i] * kDegPerRad;
    h += std::string("<td class=\"n") + (large ? " bad" : "") + "\">" + num(shown, i < 3 ? 4 : 3) + "</td>";
  }
  h += "<td></td><td></td></tr>\n</table>\n";
  h += any_large ? "<p class=\"bad\">The segments disagree by more than the warning level (" +
                       fmt::format("{:.0f} cm, {:.2f}&deg;", 100 * r.warn_above[0], r.warn_above[3] * kDegPerRad) +
                       "): the result depends on which part of the drive is used.</p>\n"
                 : "<p class=\"ok\">The segments agree within the warning level.</p>\n";
  return h;
}

std::string html_output_files(const ReportData& data) {
  if (data.output_files.empty()) return "";
  std::string h;
  h += "<h2>Output files</h2>\n<table>\n";
  for (const auto& [file, what] : data.output_files) {
    h += fmt::format("<tr><td><a href=\"{0}\">{0}</a></td><td>{1}</td></tr>\n", esc(file), esc(what));
  }
  h += "</table>\n";
  return h;
}

}  // namespace

ReportFiles write_report(const std::filesystem::path& out_dir, const ReportData& data) {
  return write_report(out_dir, data, draw_report_images(data.maps));
}

ReportFiles write_report(const std::filesystem::path& out_dir, const ReportData& data, const ReportImages& images) {
  ensure_writable_dir(out_dir);
  ensure_writable_dir(out_dir / kImageDir);
  ReportFiles files;
  files.html = out_dir / "report.html";
  for (const auto& [rel, png] : images.png_files) {
    write_file_atomic(out_dir / rel, png);
    files.images.push_back(out_dir / rel);
  }
  for (const auto& [rel, content] : images.viewer.files) write_file_atomic(out_dir / rel, content);
  for (const SnapshotImages& s : images.snaps)
    files.section_thickness_m.emplace_back(images.wall ? s.wall.thickness_m : std::nan(""),
                                           images.ground ? s.ground.thickness_m : std::nan(""));
  std::string h = "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n<title>" + esc(data.title) +
                  "</title>\n<style>" + kStyle + "</style></head><body>\n";
  const auto now = std::chrono::floor<std::chrono::seconds>(std::chrono::system_clock::now());
  h += "<h1>" + esc(data.title) + "</h1>\n";
  h += fmt::format("<div class=\"meta\">written {:%Y-%m-%d %H:%M:%S} UTC{}</div>\n", now,
                   data.command_line.empty() ? "" : " &middot; <code>" + esc(data.command_line) + "</code>");
  // Result first: the numbers to put on the car and whether to believe them.
  h += html_result(data) + html_warnings(data) + html_left_out(data) + html_inputs(data) + html_stages(data) + html_convergence(data) +
       html_viewer(images) + html_maps(images) + html_fiducials(data) + html_time_offset(data) + html_observability(data) +
       html_repeatability(data) + html_trajectory_correction(data) + html_output_files(data);
  h += "</body></html>\n";
  write_file_atomic(files.html, h);
  return files;
}

}  // namespace insalign::io
