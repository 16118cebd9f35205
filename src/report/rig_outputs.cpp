#include "report/rig_outputs.hpp"

#include <fmt/format.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <atomic>

#include <cmath>

#include "core/errors.hpp"
#include "core/stitch.hpp"
#include "files/atomic_file.hpp"
#include "files/extrinsic_json.hpp"
#include "files/formats.hpp"

namespace insalign::io {
namespace {

using nlohmann::json;

std::string pair_key(const std::string& a, const std::string& b) { return a + "__" + b; }

json finite_or_null(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

json lidar_json(const RigLidar& lidar) {
  const CalibrationResult& r = lidar.result;
  json stddev = dof_json(r.stddev);
  stddev["time_offset_s"] = std::isfinite(r.time_offset_stddev_s) ? json(r.time_offset_stddev_s) : json(nullptr);
  return {{"T_ins_lidar", transform_to_json(r.T_ins_lidar)},
          {"time_offset_s", r.time_offset_s},
          {"stddev", stddev},
          {"determined", determined_json(r.determined)},
          {"joint_with", lidar.joint_with},
          {"note", lidar.joint_note}};
}

// null when the LiDAR was not checked (the reference itself, or the check off).
json map_check_json(const RigMapCheck& c) {
  if (c.reference.empty()) return nullptr;
  return {{"reference", c.reference},
          {"converged", c.converged},
          {"T_ins_lidar_map", transform_to_json(c.T_ins_lidar_map)},
          {"moved_rot_deg", c.moved_rot_deg},
          {"moved_xy_m", c.moved_xy_m},
          {"rms_before_m", c.rms_before_m},
          {"rms_after_m", c.rms_after_m},
          {"rms_restarted_m", c.rms_restarted_m},
          {"restarted", c.restarted},
          {"map_start", c.map_start}};
}

// A number from the file, null meaning +inf (not determined).
double number_or_inf(const json& j, const std::string& file, const std::string& key) {
  if (j.is_null()) return std::numeric_limits<double>::infinity();
  if (!j.is_number()) throw InputError(file, key, "expected a number or null");
  return j.get<double>();
}

const json& member(const json& j, const std::string& key, const std::string& file, const std::string& where) {
  if (!j.is_object() || !j.contains(key)) throw InputError(file, where, "missing \"" + key + "\"");
  return j.at(key);
}

RigFileLidar lidar_from_json(const std::string& name, const json& j, const std::string& file) {
  const std::string where = "lidars." + name;
  RigFileLidar l;
  l.name = name;
  l.T_ins_lidar = transform_from_json(member(j, "T_ins_lidar", file, where), file);
  const json& offset = member(j, "time_offset_s", file, where);
  if (!offset.is_number()) throw InputError(file, where + ".time_offset_s", "expected a number");
  l.time_offset_s = offset.get<double>();
  const json& sd = member(j, "stddev", file, where);
  const char* keys[6] = {"tx_m", "ty_m", "tz_m", "roll_deg", "pitch_deg", "yaw_deg"};
  for (int i = 0; i < 6; ++i) {
    const double v = number_or_inf(member(sd, keys[i], file, where + ".stddev"), file, where + ".stddev." + keys[i]);
    l.stddev[i] = i < 3 ? v : v * kRadPerDeg;
  }
  const json& det = member(j, "determined", file, where);
  for (int i = 0; i < 6; ++i) {
    const json& d = member(det, kDofNames[i], file, where + ".determined");
    if (!d.is_boolean()) throw InputError(file, where + ".determined." + kDofNames[i], "expected true or false");
    l.determined[i] = d.get<bool>();
  }
  return l;
}

std::string urdf_num(double v) { return fmt::format("{:.17g}", v + 0.0); }

// One LiDAR's own folder: its usual files, with the rig's note in extrinsic.json, and its report
// from `drawn`'s pictures (nullptr: no report). The drawing's maps go to the rig's combined map,
// which shows the same frames at the same extrinsics: stitched once, not twice.
void write_lidar_dir(const std::filesystem::path& dir, const RigLidar& lidar, const FrameStore& store, RunInfo run,
                     const PipelineConfig& config, const RigOutputOptions& options, const LidarReportDrawing* drawn) {
  ensure_writable_dir(dir);
  const CalibrationResult& r = lidar.result;
  run.format_files = write_all_formats(dir, r.T_ins_lidar, FrameNames{"ins", lidar.name});
  write_opencalib_extrinsic(dir / "gnss-to-lidar-extrinsic.json", r.T_ins_lidar);
  if (drawn) {
    ReportData data = report_data(r, store, run, config);
    data.title = "insalign calibration report: LiDAR '" + lidar.name + "' of the rig";
    data.child_frame = lidar.name;
    data.command_line = options.command_line;
    data.warnings.insert(data.warnings.begin(), lidar.joint_note);
    data.output_files.push_back({"../report.html", "the whole rig's report"});
    write_report(dir, data, drawn->images);
  }
  json j = result_to_json(r, run);
  j["rig"] = {{"name", lidar.name}, {"joint_with", lidar.joint_with}, {"note", lidar.joint_note},
              {"determined_alone", determined_json(lidar.determined_alone)},
              {"formal_stddev", dof_json(lidar.formal_stddev)},
              {"tz_anchor", lidar.tz_anchor.empty() ? json(nullptr) : json(lidar.tz_anchor)},
              {"tz_relative_stddev_m", finite_or_null(lidar.tz_relative_stddev_m)},
              {"tz_from_anchor", lidar.tz_from_anchor},
              {"own_stage3_tz_m", finite_or_null(lidar.own_stage3_tz_m)},
              {"map_check", map_check_json(lidar.map_check)},
              {"ins_checks_by", lidar.ins_checks_by.empty() ? json(nullptr) : json(lidar.ins_checks_by)},
              {"moving_space_by", lidar.moving_space_by.empty() ? json(nullptr) : json(lidar.moving_space_by)}};
  write_file_atomic(dir / "extrinsic.json", j.dump(2) + "\n");
}

// The combined map of every LiDAR at its start and at its final extrinsic: each LiDAR's own
// report's first and last maps (report_data: the same frames, left-out spans included); the final
// map's points on moving things apart.
std::vector<RigReportMaps> rig_maps(std::vector<std::vector<MapSnapshot>> lidar_maps) {
  std::vector<RigReportMaps> maps = {{"start", {}, {}}, {"final", {}, {}}};
  for (std::vector<MapSnapshot>& m : lidar_maps) {
    if (m.empty()) m.resize(1);
    maps[0].p_world.push_back(std::move(m.front().p_world));
    MapSnapshot& final_map = m.back();
    maps[1].p_world.push_back(std::move(final_map.p_world));
    maps[1].p_moving_world.insert(maps[1].p_moving_world.end(), final_map.p_moving_world.begin(),
                                  final_map.p_moving_world.end());
  }
  return maps;
}

std::string dof_text(int i, double v) {
  if (!std::isfinite(v)) return "-";
  return fmt::format("{:.4f}", i < 3 ? v : v * kDegPerRad);
}

}  // namespace

json rig_to_json(const RigResult& rig) {
  json out = {{"lidars", json::object()}, {"T_lidar_lidar", json::object()}, {"T_lidar_lidar_stddev", json::object()},
              {"overlap", json::object()}};
  for (const RigLidar& lidar : rig.lidars) out["lidars"][lidar.name] = lidar_json(lidar);
  for (const LidarPair& p : rig.pairs) {
    const std::string key = pair_key(rig.lidars[p.a].name, rig.lidars[p.b].name);
    out["T_lidar_lidar"][key] = transform_to_json(p.T_a_b);
    out["T_lidar_lidar_stddev"][key] = dof_json(p.stddev);
    out["overlap"][key] = rig.overlap[p.a][p.b];
  }
  out["warnings"] = rig.warnings;
  out["wall_time_s"] = rig.wall_time_s;
  return out;
}

RigFile parse_rig_json(std::string_view text, const std::string& file) {
  json j;
  try {
    j = json::parse(text);
  } catch (const json::parse_error& e) {
    throw InputError(file, "byte " + std::to_string(e.byte), "not valid JSON");
  }
  RigFile out;
  const json& lidars = member(j, "lidars", file, "top level");
  if (!lidars.is_object() || lidars.empty()) throw InputError(file, "lidars", "expected an object with one key per LiDAR");
  for (const auto& [name, l] : lidars.items()) out.lidars.push_back(lidar_from_json(name, l, file));
  const json& pairs = member(j, "T_lidar_lidar", file, "top level");
  if (!pairs.is_object()) throw InputError(file, "T_lidar_lidar", "expected an object");
  for (const auto& [key, T] : pairs.items()) {
    const std::size_t cut = key.find("__");
    if (cut == std::string::npos) throw InputError(file, "T_lidar_lidar." + key, "key is not \"<a>__<b>\"");
    out.pairs.push_back({key.substr(0, cut), key.substr(cut + 2), transform_from_json(T, file)});
  }
  return out;
}

std::string format_rig_urdf(const RigResult& rig) {
  std::string s =
      "<?xml version=\"1.0\"?>\n"
      "<!-- LiDAR extrinsics of a rig from insalign: the pose of each LiDAR's link in link \"ins\" (T_ins_<name>).\n"
      "     xyz in metres, rpy in radians (URDF fixed-axis X-Y-Z = ZYX yaw-pitch-roll). -->\n"
      "<robot name=\"insalign_rig\">\n  <link name=\"ins\"/>\n";
  for (const RigLidar& lidar : rig.lidars) {
    const Iso3& T = lidar.result.T_ins_lidar;
    const Vec3 t = T.translation(), rpy = rpy_from_rotation(T.linear());
    s += fmt::format(
        "  <link name=\"{0}\"/>\n  <joint name=\"ins_to_{0}\" type=\"fixed\">\n    <parent link=\"ins\"/>\n"
        "    <child link=\"{0}\"/>\n    <origin xyz=\"{1} {2} {3}\" rpy=\"{4} {5} {6}\"/>\n  </joint>\n",
        lidar.name, urdf_num(t.x()), urdf_num(t.y()), urdf_num(t.z()), urdf_num(rpy.x()), urdf_num(rpy.y()),
        urdf_num(rpy.z()));
  }
  return s + "</robot>\n";
}

LidarReportDrawing draw_lidar_report(const CalibrationResult& r, const FrameStore& store, const ViewerConfig& viewer,
                                     std::size_t lidars) {
  LidarReportDrawing out;
  ViewerConfig share = viewer;
  share.max_points = viewer.max_points / (2 * std::max<std::size_t>(lidars, 1));
  const std::vector<std::size_t> frames = report_frames(store, r);
  // The 3D view's points placed while the pictures are drawn (result_outputs.cpp report_images).
  tbb::parallel_invoke(
      [&] {
        for (std::size_t i = 0; i < kReportMaps; ++i) out.maps.push_back(report_map(r, store, frames, i));
        out.images = draw_report_images(out.maps);
      },
      [&] {
        if (share.max_points > 0) out.scene = report_viewer_scene(r, store, frames, share);
      });
  if (out.scene.size() > 0) {
    out.scene.sections = report_sections(out.images);
    out.images.viewer = encode_viewer(out.scene);
  }
  // The rig's report shows the first and the last map only: the others' points are not kept.
  if (out.maps.size() > 2) out.maps.erase(out.maps.begin() + 1, out.maps.end() - 1);
  return out;
}

std::vector<std::filesystem::path> write_rig_outputs(const std::filesystem::path& out_dir, const RigResult& rig,
                                                     const std::vector<FrameStore>& stores,
                                                     const std::vector<RunInfo>& runs, const PipelineConfig& config,
                                                     const RigOutputOptions& options,
                                                     const std::function<void(double)>& progress,
                                                     std::vector<std::optional<LidarReportDrawing>> drawn) {
  ensure_writable_dir(out_dir);
  const std::size_t n = rig.lidars.size();
  drawn.resize(n);
  if (options.report)  // pictures not drawn beside the repeatability study
    tbb::parallel_for(std::size_t{0}, n, [&](std::size_t l) {
      if (!drawn[l]) drawn[l] = draw_lidar_report(rig.lidars[l].result, stores[l], options.viewer, 1);
    });
  std::vector<std::filesystem::path> files;
  // Each LiDAR's folder and the rig's report side by side, the folders among themselves too: one
  // report alone leaves a core idle in its serial parts. The folders read each drawing's images,
  // the rig's report takes its maps and 3D points.
  std::atomic<std::size_t> done{0};
  tbb::parallel_invoke(
      [&] {
        tbb::parallel_for(std::size_t{0}, n, [&](std::size_t l) {
          write_lidar_dir(out_dir / rig.lidars[l].name, rig.lidars[l], stores[l], runs[l], config, options,
                          options.report ? &*drawn[l] : nullptr);
          if (progress) progress(static_cast<double>(++done) / (n + 1));
        });
      },
      [&] {
        write_file_atomic(out_dir / kRigUrdfFile, format_rig_urdf(rig));
        files.push_back(out_dir / kRigUrdfFile);
        if (!options.report) return;
        std::vector<std::vector<MapSnapshot>> lidar_maps(n);
        std::vector<ViewerScene> scenes(n);
        std::vector<std::string> names;
        for (std::size_t l = 0; l < n; ++l) {
          lidar_maps[l] = std::move(drawn[l]->maps);
          scenes[l] = std::move(drawn[l]->scene);
          scenes[l].sections.clear();  // each LiDAR's own; the rig's report marks none of them
          names.push_back(rig.lidars[l].name);
        }
        const ViewerScene scene = merge_scenes(std::move(scenes), names);
        files.push_back(write_rig_report(out_dir, rig, rig_maps(std::move(lidar_maps)), options.command_line, &scene));
      });
  write_file_atomic(out_dir / kRigJsonFile, rig_to_json(rig).dump(2) + "\n");
  files.push_back(out_dir / kRigJsonFile);
  if (progress) progress(1.0);
  return files;
}

std::string left_out_line(const RigLidar& lidar) {
  const CalibrationResult& r = lidar.result;
  if (r.excluded.empty() && !r.moving.applied) return "";
  std::string s = fmt::format("left out: {:.1f} s of INS time in {} span{}", spans_duration_s(r.excluded),
                              r.excluded.size(), r.excluded.size() == 1 ? "" : "s");
  if (!lidar.ins_checks_by.empty()) s += " (LiDAR checks by '" + lidar.ins_checks_by + "')";
  if (r.moving.applied && r.moving.points_checked > 0)
    s += fmt::format("; points on moving things: {:.2f}% of the sampled points{}",
                     100.0 * r.moving.points_moving / r.moving.points_checked,
                     lidar.moving_space_by.empty() ? "" : " (one evidence for the rig, rays of '" + lidar.moving_space_by + "')");
  return s;
}

std::string rig_summary_text(const RigResult& rig, double peak_memory_mb) {
  std::string s = "\nrig: T_ins_lidar per LiDAR (x y z m; roll pitch yaw deg; stddev; '!' = not determined)\n";
  for (const RigLidar& lidar : rig.lidars) {
    const CalibrationResult& r = lidar.result;
    const Vec3 t = r.T_ins_lidar.translation(), rpy = rpy_from_rotation(r.T_ins_lidar.linear()) * kDegPerRad;
    s += fmt::format("  {:<10} {:>9.4f} {:>9.4f} {:>9.4f} {:>9.4f} {:>9.4f} {:>9.4f}  offset {:+.2f} ms\n", lidar.name,
                     t.x(), t.y(), t.z(), rpy.x(), rpy.y(), rpy.z(), 1e3 * r.time_offset_s);
    s += fmt::format("  {:<10}", "  stddev");
    for (int i = 0; i < 6; ++i) s += fmt::format(" {:>8}{}", dof_text(i, r.stddev[i]), r.determined[i] ? ' ' : '!');
    s += "\n    " + lidar.joint_note + "\n";
    if (!lidar.tz_anchor.empty() && lidar.tz_anchor != lidar.name)
      s += fmt::format("    tz: measured relative to '{}' (+- {:.1f} mm){}\n", lidar.tz_anchor, 1e3 * lidar.tz_relative_stddev_m,
                       lidar.tz_from_anchor ? std::string(", the rig's stage 3 applied (median of its LiDARs')") : std::string());
    if (const std::string left_out = left_out_line(lidar); !left_out.empty()) s += "    " + left_out + "\n";
    for (const std::string& w : r.warnings) s += "    warning: " + w + "\n";
  }
  s += "LiDAR-to-LiDAR T_a_b (x y z m, roll pitch yaw deg) +- stddev\n";
  for (const LidarPair& p : rig.pairs) {
    const Vec3 t = p.T_a_b.translation(), rpy = rpy_from_rotation(p.T_a_b.linear()) * kDegPerRad;
    s += fmt::format("  {:<18} {:>8.4f} {:>8.4f} {:>8.4f} {:>9.4f} {:>9.4f} {:>9.4f}   +- {} {} {} m, {} {} {} deg\n",
                     pair_key(rig.lidars[p.a].name, rig.lidars[p.b].name), t.x(), t.y(), t.z(), rpy.x(), rpy.y(),
                     rpy.z(), dof_text(0, p.stddev[0]), dof_text(1, p.stddev[1]), dof_text(2, p.stddev[2]),
                     dof_text(3, p.stddev[3]), dof_text(4, p.stddev[4]), dof_text(5, p.stddev[5]));
  }
  s += fmt::format("  total {:.2f} s (joint stage 2 {:.2f} s), peak memory {:.0f} MB\n", rig.wall_time_s,
                   rig.joint_wall_time_s, peak_memory_mb);
  for (const std::string& w : rig.warnings) s += "warning: " + w + "\n";
  return s;
}

}  // namespace insalign::io
