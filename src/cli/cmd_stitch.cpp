// insalign stitch: the deskewed, stitched map of a drive for a given extrinsic, as PCD or PLY,
// to inspect a calibration in CloudCompare or RViz.
#include <fmt/format.h>

#include <memory>

#include "cli/commands.hpp"
#include "cli/input_options.hpp"
#include "core/errors.hpp"
#include "core/pipeline.hpp"
#include "core/stitch.hpp"
#include "files/extrinsic_json.hpp"
#include "pointcloud/pcd.hpp"
#include "pointcloud/ply.hpp"
#include "report/viewer.hpp"

namespace insalign::cli {
namespace {

struct StitchOptions {
  InputOptions input;
  ConfigOptions config;
  std::string extrinsic, out, html;
  double time_offset_s = 0.0;
  bool time_offset_given = false;
  double voxel_m = 0.1;
  std::size_t max_frames = 120;
};

// The 3D viewer alone (report/viewer.hpp): the same frames at this one extrinsic.
void write_html(const StitchOptions& o, const FrameStore& store, const std::vector<std::size_t>& frames,
                const Iso3& T_ins_lidar, double time_offset_s, const io::ViewerConfig& viewer) {
  io::ViewerConfig config = viewer;
  if (config.max_points == 0) config.max_points = io::ViewerConfig{}.max_points;  // the page is what was asked for
  io::ViewerScene scene = io::viewer_scene(store, frames, {{o.extrinsic, T_ins_lidar, time_offset_s}}, {},
                                           nullptr, config);
  scene.fallback = "open the map as PCD or PLY (insalign stitch --out) in a point cloud viewer instead.";
  io::write_viewer_page(o.html, scene, "insalign stitch: " + o.extrinsic);
  fmt::print("{} of {} points from {} frames in the 3D view {}\n", scene.size(), scene.points_total, scene.frames.size(), o.html);
}

int run_stitch(const StitchOptions& o) {
  if (o.out.empty() && o.html.empty()) throw InputError("--out", "", "give --out FILE (.pcd or .ply), --html FILE, or both");
  const ToolConfig tool = load_config(o.config);
  const io::LoadedInput input = load_inputs(o.input, tool.input);
  if (input.lidars.size() != 1) {
    throw InputError("--extrinsic", "", fmt::format("{} LiDARs given: stitch takes one (its --extrinsic); give one --lidar-dir "
                                                    "or --lidar-topic", input.lidars.size()));
  }
  const Dataset& data = input.lidars.front();
  // The extrinsic: a result extrinsic.json ("T_ins_lidar") or an OpenCalib JSON (T_lidar_ins).
  const io::ExtrinsicFile extrinsic = io::read_extrinsic_file(o.extrinsic);
  const double time_offset_s = o.time_offset_given ? o.time_offset_s : extrinsic.time_offset_s.value_or(0.0);
  const FrameStore store = make_frame_store(data, tool.calibrate);
  const std::vector<std::size_t> frames = spread_frames(store, o.max_frames, time_offset_s);
  if (!o.html.empty()) write_html(o, store, frames, extrinsic.T_ins_lidar, time_offset_s, tool.report);
  if (o.out.empty()) return kExitOk;
  const std::vector<Vec3f> p_world = stitch_map(store, frames, extrinsic.T_ins_lidar, time_offset_s, o.voxel_m);
  const std::filesystem::path out = o.out;
  if (out.extension() == ".ply") {
    io::write_ply(out, p_world);
  } else {
    Sweep map;
    map.name = "map";
    map.p_lidar = p_world;
    io::write_pcd(out, map, io::PcdEncoding::kBinaryCompressed, io::PcdTimeField::kNone);
  }
  fmt::print("{} points from {} frames written to {} (world frame recentred by [{:.3f}, {:.3f}, {:.3f}] m)\n",
             p_world.size(), frames.size(), out.string(), data.world_origin_m.x(),
             data.world_origin_m.y(), data.world_origin_m.z());
  return kExitOk;
}

}  // namespace

Command make_stitch_command() {
  auto o = std::make_shared<StitchOptions>();
  Command command;
  command.setup = [o](CLI::App& app) {
    CLI::App* sub = app.add_subcommand("stitch", "Export the deskewed stitched map for an extrinsic (PCD or PLY)");
    add_input_options(*sub, o->input, false);
    add_config_options(*sub, o->config);
    sub->add_option("--extrinsic", o->extrinsic, "extrinsic.json of a result, or an OpenCalib JSON")->required();
    sub->add_option("--out", o->out, "output file, .pcd or .ply");
    sub->add_option("--html", o->html,
                    "also (or only) a standalone page with the map in 3D (its scripts in <name>_files/ beside it; "
                    "points: config report.viewer_points)");
    sub->add_option("--time-offset-s", o->time_offset_s, "LiDAR to INS clock offset (default: from the result)")
        ->each([o](const std::string&) { o->time_offset_given = true; });
    sub->add_option("--voxel-m", o->voxel_m, "map downsampling voxel")->capture_default_str();
    sub->add_option("--max-frames", o->max_frames, "frames spread over the drive")->capture_default_str();
    return sub;
  };
  command.run = [o] { return run_stitch(*o); };
  return command;
}

}  // namespace insalign::cli
