// The viewer's files: viewer.js (compiled in from viewer.js), viewer_data.js (the scene: a JSON
// header and the quantised points in base64) and the HTML snippet that loads them.
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "files/atomic_file.hpp"
#include "report/viewer.hpp"

namespace insalign::io {

extern const char kViewerJs[];  // viewer_js.cpp, generated from viewer.js

namespace {

using nlohmann::json;

constexpr std::size_t kMaxTrajectoryPoints = 4000;  // a line, not a data set: enough to follow the drive

// Appended to `out` in place, in parallel over 3-byte groups (tens of MB for a full view: the
// report must not wait on it, nor hold a second copy of it).
void append_base64(const std::string& bytes, std::string& out) {
  static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  const std::size_t groups = (bytes.size() + 2) / 3, at = out.size();
  out.resize(at + groups * 4, '=');
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, groups, 1 << 16), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t g = r.begin(); g < r.end(); ++g) {
      const std::size_t i = 3 * g, n = std::min<std::size_t>(3, bytes.size() - i);
      std::uint32_t v = 0;
      for (std::size_t k = 0; k < 3; ++k) v = (v << 8) | (k < n ? static_cast<std::uint8_t>(bytes[i + k]) : 0u);
      for (std::size_t k = 0; k <= n; ++k) out[at + 4 * g + k] = kAlphabet[(v >> (18 - 6 * k)) & 63];
    }
  });
}

json vec(const Vec3& p) { return json::array({p.x(), p.y(), p.z()}); }

// The box every placing's points fall in, quantised to 16 bits per axis.
struct Box {
  Vec3 min_m = Vec3::Zero(), scale_m = Vec3::Constant(1e-3);
};
Box bounding_box(const ViewerScene& scene) {
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (const auto& points : scene.p_world)
    for (const Vec3f& p : points) {
      lo = lo.cwiseMin(p.cast<double>());
      hi = hi.cwiseMax(p.cast<double>());
    }
  Box box;
  if (!(lo.array() <= hi.array()).all()) return box;
  box.min_m = lo;
  box.scale_m = ((hi - lo) / 65535.0).cwiseMax(Vec3::Constant(1e-6));
  return box;
}

// Point order grouped by (LiDAR, frame, class): the runs carry those, no bytes per point.
std::vector<std::uint32_t> run_order(const ViewerScene& s) {
  // A stable counting sort by (LiDAR, frame, class): the same order as a stable sort by that key,
  // without comparing millions of points (a few frames and classes, many points each).
  constexpr std::uint32_t kClasses = 4;
  static_assert(static_cast<std::uint32_t>(ViewerPointClass::kOutside) < kClasses);
  std::uint32_t frames = 1, lidars = 1;
  for (std::uint32_t i = 0; i < s.size(); ++i) {
    frames = std::max(frames, static_cast<std::uint32_t>(s.frame[i]) + 1);
    if (!s.lidar.empty()) lidars = std::max(lidars, static_cast<std::uint32_t>(s.lidar[i]) + 1);
  }
  const auto key = [&](std::uint32_t i) {
    const std::uint32_t lidar = s.lidar.empty() ? 0 : s.lidar[i];
    const std::uint32_t cls = s.point_class.empty() ? 0 : static_cast<std::uint32_t>(s.point_class[i]);
    return (lidar * frames + static_cast<std::uint32_t>(s.frame[i])) * kClasses + cls;
  };
  std::vector<std::uint32_t> start(std::size_t{lidars} * frames * kClasses + 1, 0);
  for (std::uint32_t i = 0; i < s.size(); ++i) ++start[key(i) + 1];
  for (std::size_t k = 1; k < start.size(); ++k) start[k] += start[k - 1];
  std::vector<std::uint32_t> order(s.size());
  for (std::uint32_t i = 0; i < s.size(); ++i) order[start[key(i)]++] = i;
  return order;
}

json meta_json(const ViewerScene& s, const Box& box, const std::vector<std::uint32_t>& order) {
  json runs = json::array();
  for (std::size_t k = 0; k < order.size();) {
    const std::uint32_t i = order[k];
    const int lidar = s.lidar.empty() ? 0 : s.lidar[i];
    const int cls = s.point_class.empty() ? 0 : static_cast<int>(s.point_class[i]);
    std::size_t n = 0;
    while (k < order.size() && s.frame[order[k]] == s.frame[i] && (s.lidar.empty() ? 0 : s.lidar[order[k]]) == lidar &&
           (s.point_class.empty() ? 0 : static_cast<int>(s.point_class[order[k]])) == cls) {
      ++k;
      ++n;
    }
    runs.push_back({s.frame[i], lidar, cls, n});
  }
  json frames_t = json::array(), frames_name = json::array();
  for (const ViewerFrame& f : s.frames) {
    frames_t.push_back(f.t_s);
    frames_name.push_back(f.name);
  }
  json trajectory = json::array();
  const std::size_t step = std::max<std::size_t>(1, s.trajectory_world.size() / kMaxTrajectoryPoints);
  for (std::size_t i = 0; i < s.trajectory_world.size(); i += step) trajectory.push_back(vec(s.trajectory_world[i]));
  json fiducials = json::array();
  for (const Fiducial& f : s.fiducials) fiducials.push_back({{"id", f.id}, {"p_m", vec(f.p_world)}});
  json sections = json::array();
  for (const Section& c : s.sections)
    sections.push_back({{"kind", c.kind}, {"centre_m", vec(c.centre_m)}, {"across", vec(c.across_axis)}, {"up", vec(c.up_axis)},
                        {"half_across_m", c.half_across_m}, {"half_up_m", c.half_up_m}, {"half_depth_m", c.half_depth_m}});
  const MapFrame frame = frame_map(s.p_world.empty() ? std::vector<Vec3f>{} : s.p_world.back());
  return {{"points", s.size()}, {"points_total", s.points_total}, {"extrinsics", s.extrinsic_labels},
          {"lidars", s.lidar_names}, {"box", {{"min_m", vec(box.min_m)}, {"scale_m", vec(box.scale_m)}}},
          {"z_colour_m", {frame.colour_z_min_m, frame.colour_z_max_m}}, {"runs", runs}, {"frame_times_s", frames_t},
          {"frame_names", frames_name}, {"trajectory_m", trajectory}, {"fiducials", fiducials}, {"sections", sections}};
}

// Each placing's points as uint16 x y z (little-endian) over the box, in run order (in parallel).
std::string point_bytes(const ViewerScene& s, const Box& box, const std::vector<std::uint32_t>& order) {
  std::string out(s.p_world.size() * order.size() * 6, '\0');
  auto* bytes = reinterpret_cast<unsigned char*>(out.data());
  for (std::size_t e = 0; e < s.p_world.size(); ++e)
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, order.size(), 1 << 14), [&](const tbb::blocked_range<std::size_t>& r) {
      unsigned char* w = bytes + (e * order.size() + r.begin()) * 6;
      for (std::size_t k = r.begin(); k < r.end(); ++k)
        for (int a = 0; a < 3; ++a) {
          const double q = std::round((s.p_world[e][order[k]][a] - box.min_m[a]) / box.scale_m[a]);
          const auto v = static_cast<std::uint16_t>(std::clamp(q, 0.0, 65535.0));
          *w++ = static_cast<unsigned char>(v & 0xff);
          *w++ = static_cast<unsigned char>(v >> 8);
        }
    });
  return out;
}

constexpr const char* kViewerStyle = R"(
#insalign-viewer { margin: 10px 0; }
#insalign-viewer canvas { width: 100%; height: 560px; display: block; border: 1px solid #ccc; background: #fff; outline: none; cursor: grab; }
#insalign-viewer .viewer-bar { display: flex; flex-wrap: wrap; gap: 6px; margin-bottom: 6px; align-items: center; }
#insalign-viewer button { font-size: 13px; padding: 3px 9px; }
#insalign-viewer kbd { font-size: 11px; border: 1px solid #bbb; border-radius: 3px; padding: 0 3px; background: #f4f4f4; }
#insalign-viewer .viewer-line { font-size: 13px; color: #333; margin-top: 4px; font-family: "DejaVu Sans Mono", monospace; }
#insalign-viewer .viewer-fallback { background: #fff5e0; border: 1px solid #f0c36d; padding: 6px 12px; }
#insalign-viewer.viewer-full { position: fixed; inset: 0; z-index: 10; background: #fff; margin: 0; padding: 8px; }
#insalign-viewer.viewer-full canvas { height: calc(100vh - 110px); }
)";

// The colours and marks this scene has, in words.
std::string legend(const ViewerScene& s) {
  const auto has = [&](ViewerPointClass c) { return std::find(s.point_class.begin(), s.point_class.end(), c) != s.point_class.end(); };
  std::vector<std::string> parts;
  if (has(ViewerPointClass::kOutside)) parts.emplace_back("grey: frames outside the stretches the check used");
  if (has(ViewerPointClass::kMoving)) parts.emplace_back("magenta: moving things left out");
  if (has(ViewerPointClass::kBadIns)) parts.emplace_back("orange: frames in a left-out INS stretch");
  if (!s.trajectory_world.empty()) parts.emplace_back("black line: INS trajectory");
  if (!s.fiducials.empty()) parts.emplace_back("red crosses: fiducials");
  if (!s.sections.empty()) parts.emplace_back("boxes: the cross-sections (red wall, blue ground)");
  return fmt::format("{}.", fmt::join(parts, "; "));
}

std::string snippet(const ViewerScene& s, const std::string& dir) {
  const std::string data = dir + "/viewer_data.js";
  std::string h = fmt::format("<style>{}</style>\n<div id=\"insalign-viewer\" data-src=\"{}\" data-fallback=\"{}\">\n",
                              kViewerStyle, html_escape(data), html_escape(s.fallback));
  // Shown until viewer.js replaces it: what a browser without JavaScript or WebGL says.
  h += "<div class=\"viewer-fallback\">The 3D view needs JavaScript and WebGL: " + html_escape(s.fallback) + "</div>\n";
  h += "<div class=\"viewer-body\" style=\"display:none\">\n<div class=\"viewer-bar\">\n";
  std::string swap;
  for (const std::string& l : s.extrinsic_labels) swap += (swap.empty() ? "" : " &harr; ") + html_escape(l);
  h += "<button data-action=\"swap\"><kbd>B</kbd> " + swap + "</button>\n";
  h += "<button data-action=\"colour\"><kbd>C</kbd> colour: height / " + std::string(s.lidar_names.size() > 1 ? "LiDAR / " : "") +
       "frame time</button>\n<button data-action=\"leftout\"><kbd>L</kbd> left-out points</button>\n"
       "<button data-action=\"overlays\"><kbd>O</kbd> trajectory, fiducials, sections</button>\n";
  for (std::size_t i = 0; i < s.sections.size() && i < 9; ++i)
    h += fmt::format("<button data-action=\"section{}\"><kbd>{}</kbd> go to the {} section</button>\n", i, i + 1,
                     html_escape(s.sections[i].kind));
  h += "<button data-action=\"home\"><kbd>R</kbd> reset view</button>\n<button data-action=\"smaller\"><kbd>-</kbd></button>"
       "<button data-action=\"bigger\"><kbd>+</kbd> point size</button>\n<button data-action=\"full\"><kbd>F</kbd> full window</button>\n</div>\n";
  h += "<canvas tabindex=\"0\" aria-label=\"3D view of the stitched map\"></canvas>\n<div class=\"viewer-line viewer-state\"></div>\n"
       "<div class=\"viewer-line viewer-info\">Click a point for its coordinates and frame. Drag: orbit; right-drag or "
       "shift-drag: pan; wheel: zoom.</div>\n";
  const double every = s.size() ? static_cast<double>(s.points_total) / static_cast<double>(s.size()) : 0.0;
  h += fmt::format("<div class=\"viewer-line\">{} of {} points shown{} (config report.viewer_points) from {} frames; {}</div>\n",
                   s.size(), s.points_total, every > 1.05 ? fmt::format(" (1 in {:.0f})", every) : "", s.frames.size(), legend(s));
  h += "</div>\n<div id=\"viewer-status\" hidden data-state=\"loading\"></div>\n</div>\n";
  h += fmt::format("<script src=\"{}\"></script>\n<script src=\"{}/viewer.js\"></script>\n", html_escape(data), html_escape(dir));
  return h;
}

}  // namespace

ViewerOutput encode_viewer(const ViewerScene& scene, const std::string& dir) {
  ViewerOutput out;
  const Box box = bounding_box(scene);
  const std::vector<std::uint32_t> order = run_order(scene);
  std::string data = "window.insalignViewerData = {\"meta\": " + meta_json(scene, box, order).dump() + ",\n\"points\": \"";
  {
    const std::string bytes = point_bytes(scene, box, order);
    data.reserve(data.size() + (bytes.size() + 2) / 3 * 4 + 4);
    append_base64(bytes, data);
  }
  data += "\"};\n";
  out.data_bytes = data.size();
  out.files.emplace_back(dir + "/viewer_data.js", std::move(data));
  out.files.emplace_back(dir + "/viewer.js", kViewerJs);
  out.html = snippet(scene, dir);
  return out;
}

std::string write_viewer(const std::filesystem::path& folder, const ViewerScene& scene, const std::string& dir) {
  ViewerOutput out = encode_viewer(scene, dir);
  ensure_writable_dir(folder / dir);
  for (const auto& [rel, content] : out.files) write_file_atomic(folder / rel, content);
  return out.html;
}

void write_viewer_page(const std::filesystem::path& html_path, const ViewerScene& scene, const std::string& title) {
  const std::filesystem::path folder = html_path.parent_path().empty() ? "." : html_path.parent_path();
  const std::string body = write_viewer(folder, scene, html_path.stem().string() + "_files");
  write_file_atomic(html_path, "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n<title>" + html_escape(title) +
                                   "</title></head>\n<body style=\"font-family: sans-serif; margin: 16px;\">\n<h1 style=\"font-size: 20px\">" +
                                   html_escape(title) + "</h1>\n" + body + "</body></html>\n");
}

}  // namespace insalign::io
