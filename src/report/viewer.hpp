// The interactive 3D view of a stitched map (report.html, check.html, `insalign stitch --html`):
// the same points placed at several extrinsics (start and result), switched in the browser with
// one key, the camera kept. Offline from file://: the page loads two scripts written beside it,
// viewer.js (plain WebGL 1, no library) and viewer_data.js (the points, base64 in a script: a
// page opened from file:// may not fetch() a sibling file). Where WebGL is missing, the snippet
// shows one line pointing at the PNG projections instead.
//
// Use from another page (e.g. check.html):
//   ViewerScene scene = viewer_scene(store, frames, {{"installed", T_a, dt_a}, {"corrected", T_b, dt_b}},
//                                    excluded, mask, ViewerConfig{});
//   scene.sections = {...};                      // optional: boxes to mark and jump to
//   std::string html = write_viewer(out_dir, scene);   // writes out_dir/report/viewer*.js
//   // put `html` into the page's <body> (one viewer per page; it carries its own style).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "core/dataset.hpp"
#include "core/frame_store.hpp"
#include "core/geometry.hpp"
#include "report/render.hpp"

namespace insalign::io {

/// `report.viewer_points` and what follows from it.
struct ViewerConfig {
  /// Points the 3D view holds at most (all extrinsics share them); more are decimated evenly.
  /// 2 million: ~32 MB of viewer_data.js for two extrinsics (12 bytes a point, base64).
  std::size_t max_points = 2'000'000;
};

template <class V>
void visit_config(V& v, ViewerConfig& c) {
  v("viewer_points", c.max_points,
    "points in the report's 3D view at most (decimated evenly; 12 bytes each in report/viewer_data.js for two "
    "extrinsics, base64); 0: no 3D view");
}

/// Why a point was left out by the stages (drawn in its own colour, hidden by a toggle).
/// kOutside: a frame outside the stretches a check used (shown for context, grey).
enum class ViewerPointClass : std::uint8_t { kUsed = 0, kMoving = 1, kBadIns = 2, kOutside = 3 };

struct ViewerFrame {
  std::string name;
  double t_s = 0.0;  ///< frame time (LiDAR clock)
};

/// One placing of the scene's points.
struct ViewerPlacing {
  std::string label;  ///< e.g. "start", "final"
  Iso3 T_ins_lidar = Iso3::Identity();
  double time_offset_s = 0.0;
};

/// What the viewer shows. Per-point vectors are in one order; p_world has one entry per extrinsic.
struct ViewerScene {
  std::vector<std::string> extrinsic_labels;   ///< the last is shown first
  std::vector<std::vector<Vec3f>> p_world;     ///< [extrinsic][point], world frame (recentred)
  std::vector<std::uint32_t> frame;            ///< [point]: index into frames
  std::vector<std::uint8_t> lidar;             ///< [point]: index into lidar_names (empty: all 0)
  std::vector<ViewerPointClass> point_class;   ///< [point] (empty: all used)
  std::vector<ViewerFrame> frames;
  std::vector<std::string> lidar_names;
  std::vector<Vec3> trajectory_world;          ///< INS positions along the drive (a line)
  std::vector<Fiducial> fiducials;
  std::vector<Section> sections;               ///< boxes to mark and jump to (the report's wall, ground)
  std::size_t points_total = 0;                ///< before decimation to the budget
  /// Where WebGL (or JavaScript) is unavailable, one line says so and then this.
  std::string fallback = "the PNG projections below show the map.";
  std::size_t size() const { return frame.size(); }
};

/// `frames` of the store placed at each extrinsic (deskewed, not voxel-filtered: the same points
/// in every placing), every k-th point kept so that at most config.max_points remain. Points the
/// mask drops are kMoving, those of frames touching an `excluded` span (INS clock) kBadIns.
/// Frames that some placing's poses do not cover are left out. Parallel over frames.
ViewerScene viewer_scene(const FrameStore& store, const std::vector<std::size_t>& frames,
                         const std::vector<ViewerPlacing>& placings, const std::vector<TimeSpan>& excluded,
                         const PointMask* mask, const ViewerConfig& config);

/// The points of frames whose sweep [t - period, t] (LiDAR clock + time_offset_s: INS clock) is not
/// within one of `inside` made kOutside (a check's view: the drive beyond the stretches it used).
void mark_outside(ViewerScene& scene, const std::vector<TimeSpan>& inside, double period_s, double time_offset_s);

/// Several LiDARs' scenes (same extrinsic labels) as one, coloured by LiDAR in the browser.
ViewerScene merge_scenes(std::vector<ViewerScene> scenes, const std::vector<std::string>& lidar_names);

/// The viewer's files (relative path, content) and the HTML snippet that loads them.
struct ViewerOutput {
  std::vector<std::pair<std::string, std::string>> files;
  std::string html;
  std::size_t data_bytes = 0;  ///< size of the points file
};
/// Encodes the scene: files go to `dir` (relative to the page, e.g. "report").
ViewerOutput encode_viewer(const ViewerScene& scene, const std::string& dir = "report");
/// Writes the files under folder (atomically) and returns the HTML snippet for a page in folder.
std::string write_viewer(const std::filesystem::path& folder, const ViewerScene& scene, const std::string& dir = "report");
/// A standalone page `html_path` with the viewer alone; its scripts in <stem>_files/ beside it.
void write_viewer_page(const std::filesystem::path& html_path, const ViewerScene& scene, const std::string& title);

}  // namespace insalign::io
