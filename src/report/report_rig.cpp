// The rig's report.html: a table over every LiDAR, the overlap and LiDAR-to-LiDAR tables, the
// combined map coloured by LiDAR at the start and at the result, cross-sections where LiDARs
// overlap (each LiDAR's surface should fall on the others'), and a section per LiDAR linking its
// own full report in <name>/report.html.
#include <fmt/chrono.h>
#include <fmt/format.h>

#include <chrono>
#include <cmath>

#include <tbb/parallel_invoke.h>

#include "core/voxel_grid.hpp"
#include "files/atomic_file.hpp"
#include "report/render.hpp"
#include "report/rig_outputs.hpp"
#include "report/viewer.hpp"

namespace insalign::io {
namespace {

constexpr Rgb kPalette[] = {{230, 80, 60}, {50, 120, 220}, {40, 170, 80}, {200, 150, 20}, {150, 70, 190}, {20, 170, 180}};
Rgb colour_of(std::size_t l) { return kPalette[l % std::size(kPalette)]; }
constexpr Rgb kMovingColour{255, 0, 255};  // magenta, as in each LiDAR's own report
std::string css(Rgb c) { return fmt::format("rgb({},{},{})", c.r, c.g, c.b); }

std::string esc(const std::string& s) { return html_escape(s); }

std::string dof_cell(int i, double v) {
  if (!std::isfinite(v)) return "-";
  return fmt::format("{:.4f}", i < 3 ? v : v * kDegPerRad);
}

// Top view of every LiDAR's map in its colour and the points on moving things in magenta, one
// framing for all snapshots.
Image top_view(const RigReportMaps& maps, const MapFrame& frame) {
  const double w_m = std::max(frame.max_m.x() - frame.min_m.x(), 1.0), h_m = std::max(frame.max_m.y() - frame.min_m.y(), 1.0);
  const double px_per_m = std::min(900.0 / w_m, 900.0 / h_m);
  Image img(static_cast<int>(w_m * px_per_m) + 1, static_cast<int>(h_m * px_per_m) + 1, Rgb{255, 255, 255});
  const auto draw = [&](const std::vector<Vec3f>& points, Rgb colour) {
    for (const Vec3f& p : points)
      img.blend(static_cast<int>((p.x() - frame.min_m.x()) * px_per_m), static_cast<int>((frame.max_m.y() - p.y()) * px_per_m),
                colour, 0.35);
  };
  for (std::size_t l = 0; l < maps.p_world.size(); ++l) draw(maps.p_world[l], colour_of(l));
  draw(maps.p_moving_world, kMovingColour);
  img.text(8, 8, fmt::format("{:.0f} m across", w_m), Rgb{0, 0, 0});
  return img;
}

// A section box edge-on, every LiDAR's points in its colour.
Image section_view(const std::vector<std::vector<Vec3f>>& maps, const Section& s, double px_per_m, const std::string& label) {
  const Vec3 depth = s.across_axis.cross(s.up_axis).normalized();
  Image img(static_cast<int>(2 * s.half_across_m * px_per_m), static_cast<int>(2 * s.half_up_m * px_per_m), Rgb{255, 255, 255});
  for (int g = 1; 0.1 * g < 2 * s.half_across_m; ++g) img.fill_rect(int(0.1 * g * px_per_m), 0, int(0.1 * g * px_per_m) + 1, img.height, Rgb{225, 225, 225});
  for (std::size_t l = 0; l < maps.size(); ++l) {
    for (const Vec3f& pf : maps[l]) {
      const Vec3 d = pf.cast<double>() - s.centre_m;
      const double u = d.dot(s.across_axis), v = d.dot(s.up_axis);
      if (std::abs(u) > s.half_across_m || std::abs(v) > s.half_up_m || std::abs(d.dot(depth)) > s.half_depth_m) continue;
      img.blend(static_cast<int>((u + s.half_across_m) * px_per_m), static_cast<int>((s.half_up_m - v) * px_per_m), colour_of(l), 0.6);
    }
  }
  img.text(6, 6, label, Rgb{0, 0, 0});
  return img;
}

// Points of the final map in voxels that at least two LiDARs occupy: where the sections go.
// Open addressing: a node map cost a quarter of a rig's outputs step (millions of points).
std::vector<Vec3f> overlap_points(const std::vector<std::vector<Vec3f>>& maps) {
  std::size_t points = 0;
  for (const auto& map : maps) points += map.size();
  VoxelKeyMap<std::uint32_t> owners(points / 16);  // bit mask of LiDARs per 0.5 m voxel
  for (std::size_t l = 0; l < maps.size(); ++l)
    for (const Vec3f& p : maps[l]) owners[voxel_key(p, 2.0)] |= 1u << (l % 32);
  std::vector<Vec3f> out;
  for (const auto& map : maps)
    for (const Vec3f& p : map) {
      const std::uint32_t m = *owners.find(voxel_key(p, 2.0));
      if (m & (m - 1)) out.push_back(p);
    }
  return out;
}

std::string lidar_table(const RigResult& rig) {
  std::string h = "<table><tr><th>LiDAR</th><th>x m</th><th>y m</th><th>z m</th><th>roll</th><th>pitch</th><th>yaw</th>"
                  "<th>offset ms</th><th>stddev (m, deg; - = not determined)</th><th>refined</th><th>report</th></tr>\n";
  for (std::size_t l = 0; l < rig.lidars.size(); ++l) {
    const RigLidar& lidar = rig.lidars[l];
    const CalibrationResult& r = lidar.result;
    const Vec3 t = r.T_ins_lidar.translation(), rpy = rpy_from_rotation(r.T_ins_lidar.linear()) * kDegPerRad;
    std::string sd;
    for (int i = 0; i < 6; ++i) sd += fmt::format("{}{}{} ", kDofNames[i], r.determined[i] ? " " : " NOT ", dof_cell(i, r.stddev[i]));
    h += fmt::format("<tr><td><span style=\"color:{}\">&#9632;</span> {}</td><td>{:.4f}</td><td>{:.4f}</td><td>{:.4f}</td>"
                     "<td>{:.4f}</td><td>{:.4f}</td><td>{:.4f}</td><td>{:+.2f}</td><td>{}</td><td>{}</td>"
                     "<td><a href=\"{}/report.html\">{}/report.html</a></td></tr>\n",
                     css(colour_of(l)), esc(lidar.name), t.x(), t.y(), t.z(), rpy.x(), rpy.y(), rpy.z(),
                     1e3 * r.time_offset_s, esc(sd), esc(lidar.joint_note), esc(lidar.name), esc(lidar.name));
  }
  return h + "</table>\n";
}

std::string pair_tables(const RigResult& rig) {
  std::string h = "<h2>Overlap of the stage-1 maps</h2>\n<p>Shared occupied voxels over the smaller map's; LiDARs at or "
                  "above the configured minimum share one map in stage 2.</p>\n<table><tr><th></th>";
  for (const RigLidar& l : rig.lidars) h += "<th>" + esc(l.name) + "</th>";
  h += "</tr>\n";
  for (std::size_t a = 0; a < rig.lidars.size(); ++a) {
    h += "<tr><th>" + esc(rig.lidars[a].name) + "</th>";
    for (std::size_t b = 0; b < rig.lidars.size(); ++b) h += fmt::format("<td>{:.3f}</td>", rig.overlap[a][b]);
    h += "</tr>\n";
  }
  h += "</table>\n<h2>LiDAR-to-LiDAR transforms</h2>\n<p>T_a_b maps LiDAR b's coordinates into LiDAR a's "
       "(= T_ins_a<sup>-1</sup> T_ins_b); 1-sigma in frame a, from the final stddevs with the joint stage 2's correlations.</p>\n"
       "<table><tr><th>a__b</th><th>x m</th><th>y m</th><th>z m</th><th>roll</th><th>pitch</th><th>yaw</th><th>stddev m / deg</th></tr>\n";
  for (const LidarPair& p : rig.pairs) {
    const Vec3 t = p.T_a_b.translation(), rpy = rpy_from_rotation(p.T_a_b.linear()) * kDegPerRad;
    std::string sd;
    for (int i = 0; i < 6; ++i) sd += dof_cell(i, p.stddev[i]) + " ";
    h += fmt::format("<tr><td>{}__{}</td><td>{:.4f}</td><td>{:.4f}</td><td>{:.4f}</td><td>{:.4f}</td><td>{:.4f}</td>"
                     "<td>{:.4f}</td><td>{}</td></tr>\n",
                     esc(rig.lidars[p.a].name), esc(rig.lidars[p.b].name), t.x(), t.y(), t.z(), rpy.x(), rpy.y(), rpy.z(), sd);
  }
  return h + "</table>\n";
}

std::string figure(const std::string& file, const std::string& caption) {
  return fmt::format("<figure><a href=\"{0}\"><img src=\"{0}\" alt=\"{1}\"></a><figcaption>{1}</figcaption></figure>\n",
                     esc(file), esc(caption));
}

// The combined maps and the overlap sections, images written into out_dir/report/. The top views
// and the sections are drawn side by side: each is one serial pass over millions of points.
std::string map_images(const std::filesystem::path& out_dir, const std::vector<RigReportMaps>& maps) {
  if (maps.empty()) return "";
  ensure_writable_dir(out_dir / "report");
  std::string tops = "<h2>Combined map, coloured by LiDAR</h2>\n<div class=\"grid\">\n";
  std::string cuts = "</div>\n<h2>Cross-sections where LiDARs overlap</h2>\n<p>A thin slab edge-on (grid every 10 cm), "
                     "picked on the final map where at least two LiDARs have points. With the right extrinsics every "
                     "LiDAR's surface lies on the others'.</p>\n<div class=\"grid\">\n";
  const auto draw_tops = [&] {
    std::vector<Vec3f> all;
    for (const auto& m : maps.back().p_world) all.insert(all.end(), m.begin(), m.end());
    const MapFrame frame = frame_map(all);
    for (const RigReportMaps& m : maps) {
      const std::string rel = "report/rig_" + m.label + "_top.png";
      write_png(out_dir / rel, top_view(m, frame));
      tops += figure(rel, m.label + ": top view, one colour per LiDAR" +
                              (m.p_moving_world.empty() ? "" : "; magenta: moving things, left out"));
    }
  };
  const auto draw_cuts = [&] {
    const MapSections sections = find_sections(overlap_points(maps.back().p_world));
    for (const auto& section : {sections.wall, sections.ground}) {
      if (!section) continue;
      for (const RigReportMaps& m : maps) {
        const std::string rel = "report/rig_" + m.label + "_" + section->kind + ".png";
        std::string label = m.label + " " + section->kind + ":";
        for (const auto& p : m.p_world) {
          const SectionStats st = section_stats(p, *section);
          label += st.points > 20 ? fmt::format(" {:.1f}cm", 100 * st.thickness_m) : " -";
        }
        write_png(out_dir / rel, section_view(m.p_world, *section, 250.0, label));
        cuts += figure(rel, label + " (thickness per LiDAR)");
      }
    }
  };
  tbb::parallel_invoke(draw_tops, draw_cuts);
  return tops + cuts + "</div>\n";
}

std::string lidar_section(const RigLidar& lidar) {
  const CalibrationResult& r = lidar.result;
  std::string h = "<h2>LiDAR '" + esc(lidar.name) + "'</h2>\n<p>" + esc(lidar.joint_note) + ". Full report: <a href=\"" +
                  esc(lidar.name) + "/report.html\">" + esc(lidar.name) + "/report.html</a>.</p>\n<table>"
                  "<tr><th>step</th><th>status</th><th>time s</th><th>note</th></tr>\n";
  const auto row = [&](const char* step, const StageOutcome& o, const std::string& note) {
    h += fmt::format("<tr><td>{}</td><td>{}</td><td>{:.2f}</td><td>{}</td></tr>\n", step, enum_name(o.status), o.wall_time_s, esc(note));
  };
  row("start", r.init.outcome, r.init.explanation);
  row("stage 1", r.rough.outcome, r.rough.outcome.message.empty() ? r.rough.observability.explanation : r.rough.outcome.message);
  if (r.refine)
    row(lidar.joint_with.empty() ? "stage 2 (alone)" : "stage 2 (joint)", r.refine->outcome,
        fmt::format("{}: {:.4g} -> {:.4g}, {} frames", r.refine->measure, r.refine->crispness_before, r.refine->crispness_after,
                    r.refine->frames_used));
  row("stage 3", r.z.outcome, r.z.outcome.message);
  h += "</table>\n";
  if (const std::string left_out = left_out_line(lidar); !left_out.empty()) h += "<p>" + esc(left_out) + "</p>\n";
  for (const std::string& w : r.warnings) h += "<p class=\"warn\">warning: " + esc(w) + "</p>\n";
  return h;
}

}  // namespace

std::filesystem::path write_rig_report(const std::filesystem::path& out_dir, const RigResult& rig,
                                       const std::vector<RigReportMaps>& maps, const std::string& command_line,
                                       const ViewerScene* scene) {
  ensure_writable_dir(out_dir);
  const auto now = std::chrono::floor<std::chrono::seconds>(std::chrono::system_clock::now());
  std::string h = "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n<title>insalign rig calibration report"
                  "</title>\n<style>body{font-family:sans-serif;margin:2em;max-width:1400px}table{border-collapse:collapse}"
                  "td,th{border:1px solid #ccc;padding:3px 6px;font-size:90%}img{max-width:100%}.grid{display:grid;"
                  "grid-template-columns:repeat(auto-fill,minmax(420px,1fr));gap:8px}.warn{color:#a40}</style></head><body>\n"
                  "<h1>insalign rig calibration report</h1>\n";
  h += fmt::format("<div>written {:%Y-%m-%d %H:%M:%S} UTC{}; {} LiDARs, {:.1f} s</div>\n", now,
                   command_line.empty() ? "" : " &middot; <code>" + esc(command_line) + "</code>", rig.lidars.size(),
                   rig.wall_time_s);
  h += "<h2>Result: T_ins_lidar per LiDAR (ZYX roll, pitch, yaw in degrees)</h2>\n" + lidar_table(rig);
  for (const std::string& w : rig.warnings) h += "<p class=\"warn\">warning: " + esc(w) + "</p>\n";
  h += pair_tables(rig);
  if (scene && scene->size() > 0)
    h += "<h2>3D map: start and result, every LiDAR</h2>\n<p>Switch with <kbd>B</kbd> (the camera stays); <kbd>C</kbd> "
         "colours by LiDAR: each LiDAR's surfaces should fall on the others'.</p>\n" + write_viewer(out_dir, *scene);
  h += map_images(out_dir, maps);
  for (const RigLidar& lidar : rig.lidars) h += lidar_section(lidar);
  h += "</body></html>\n";
  write_file_atomic(out_dir / "report.html", h);
  return out_dir / "report.html";
}

}  // namespace insalign::io
