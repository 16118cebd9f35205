#include "io/config_file.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "io/read_file.hpp"

namespace insalign::io {
namespace {

std::string line_at(const YAML::Mark& mark) { return "line " + std::to_string(mark.line + 1); }

void flatten(const YAML::Node& node, const std::string& prefix, const std::string& file,
             std::set<std::string>& seen, std::vector<ConfigScalar>& out) {
  for (const auto& kv : node) {
    const YAML::Node& key = kv.first;
    const YAML::Node& value = kv.second;
    if (!key.IsScalar()) throw InputError(file, line_at(key.Mark()), "a key must be a plain name");
    const std::string dotted = prefix.empty() ? key.Scalar() : prefix + "." + key.Scalar();
    if (!seen.insert(dotted).second) throw InputError(file, line_at(key.Mark()), "'" + dotted + "' is given twice");
    if (value.IsMap()) {
      flatten(value, dotted, file, seen, out);
    } else if (value.IsSequence()) {
      throw InputError(file, line_at(key.Mark()), "'" + dotted + "' takes a single value, not a list");
    } else {
      ConfigScalar s;
      s.key = dotted;
      s.line = key.Mark().line + 1;
      if (value.IsNull()) {
        s.text = "null";
      } else {
        s.text = value.Scalar();
        s.quoted = value.Tag() == "!";  // yaml-cpp tags quoted scalars "!", plain ones "?"
      }
      out.push_back(std::move(s));
    }
  }
}

std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

std::string last_part(const std::string& key) {
  const auto dot = key.rfind('.');
  return dot == std::string::npos ? key : key.substr(dot + 1);
}

}  // namespace

std::vector<ConfigScalar> parse_config_scalars(std::string_view yaml_text, const std::string& file) {
  YAML::Node root;
  try {
    root = YAML::Load(std::string(yaml_text));
  } catch (const YAML::Exception& e) {
    throw InputError(file, e.mark.is_null() ? "" : line_at(e.mark), e.msg);
  }
  std::vector<ConfigScalar> out;
  if (root.IsNull()) return out;  // an empty file changes nothing
  if (!root.IsMap()) throw InputError(file, line_at(root.Mark()), "expected 'section: {name: value}' maps at the top");
  std::set<std::string> seen;
  flatten(root, "", file, seen, out);
  return out;
}

std::vector<ConfigScalar> read_config_scalars(const std::filesystem::path& path) {
  return parse_config_scalars(read_file(path), path.string());
}

std::optional<bool> config_parse_bool(const std::string& text) {
  std::string t = text;
  std::transform(t.begin(), t.end(), t.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (t == "true" || t == "yes" || t == "on") return true;
  if (t == "false" || t == "no" || t == "off") return false;
  return std::nullopt;
}

std::optional<long long> config_parse_int(const std::string& text) {
  const std::string t = !text.empty() && text[0] == '+' ? text.substr(1) : text;
  long long v = 0;
  const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
  if (t.empty() || ec != std::errc() || end != t.data() + t.size()) return std::nullopt;
  return v;
}

std::optional<double> config_parse_double(const std::string& text) {
  const std::string t = !text.empty() && text[0] == '+' ? text.substr(1) : text;
  double v = 0;
  const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
  if (t.empty() || ec != std::errc() || end != t.data() + t.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::string config_format_double(double v) {
  char buf[64];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, v);
  std::string s(buf, ec == std::errc() ? end : buf);
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";  // reads as a number, not an integer
  return s;
}

std::string config_quote(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

std::optional<std::string> config_closest_key(const std::string& key, const std::vector<std::string>& candidates) {
  std::optional<std::string> best;
  std::size_t best_distance = std::max<std::size_t>(2, key.size() / 4) + 1;
  for (const auto& c : candidates) {
    const std::size_t d = edit_distance(key, c);
    if (d < best_distance) {
      best_distance = d;
      best = c;
    }
  }
  if (best) return best;
  // Right name in the wrong section ("min_range_m" at the top instead of under "rough").
  for (const auto& c : candidates)
    if (last_part(c) == last_part(key)) return c;
  return std::nullopt;
}

// ---- The table ------------------------------------------------------------------------------
// One line per parameter. The key is what a user writes; the accessor says where it lives.

namespace {

using P = ConfigParam<ToolConfig>;

template <class Access>
P field(std::string key, std::string meaning, Access access) {
  return config_field<ToolConfig>(std::move(key), std::move(meaning), access);
}
template <class Access, class E>
P enumeration(std::string key, std::string meaning, Access access, std::vector<std::pair<std::string, E>> names) {
  return config_enum<ToolConfig>(std::move(key), std::move(meaning), access, std::move(names));
}

#define INSALIGN_AT(expr) [](auto& c) -> auto& { return c.expr; }

// The same FrameSelectionConfig / FramePickConfig appears under several stages.
void add_frame_pick(std::vector<P>& t, const std::string& k, auto access) {
  t.push_back(field(k + ".max_frames", "frames spread evenly over the drive's motion (path + turning)",
                    [access](auto& c) -> auto& { return access(c).max_frames; }));
  t.push_back(field(k + ".min_motion_m", "frames closer than this (path + weighted turning, m) to the previous pick are skipped",
                    [access](auto& c) -> auto& { return access(c).min_motion_m; }));
  t.push_back(field(k + ".turn_weight_m_per_deg", "1 deg of heading change counts as this much path length, m",
                    [access](auto& c) -> auto& { return access(c).turn_weight_m_per_deg; }));
  t.push_back(field(k + ".min_range_m", "points nearer than this are dropped (the car body), m",
                    [access](auto& c) -> auto& { return access(c).min_range_m; }));
  t.push_back(field(k + ".max_range_m", "points farther than this are dropped (sparse, noisy), m",
                    [access](auto& c) -> auto& { return access(c).max_range_m; }));
  t.push_back(field(k + ".frame_voxel_m", "per-frame downsampling voxel in the LiDAR frame, m",
                    [access](auto& c) -> auto& { return access(c).frame_voxel_m; }));
  t.push_back(field(k + ".max_points_per_frame", "each frame thinned evenly to at most this many points (0: no cap)",
                    [access](auto& c) -> auto& { return access(c).max_points_per_frame; }));
}

std::vector<P> build_table() {
  std::vector<P> t;
  // Pipeline.
  t.push_back(field("calibrate.run_refine", "run stage 2 (false: stop after stage 1)", INSALIGN_AT(calibrate.run_refine)));
  t.push_back(field("calibrate.refine_max_unexplained_shift_m",
                    "stage 2 may move x, y by max speed x its time-offset change plus this, else it reruns with the offset fixed, m",
                    INSALIGN_AT(calibrate.refine_max_unexplained_shift_m)));
  t.push_back(field("calibrate.ins_height_m", "INS origin height above the ground for stage 3 when there are no fiducials, m (null: unknown)",
                    INSALIGN_AT(calibrate.ins_height_m)));
  t.push_back(field("calibrate.repeatability_segments", "disjoint drive segments calibrated on their own to show the spread (0 or 1: off)",
                    INSALIGN_AT(calibrate.repeatability_segments)));
  t.push_back(field("calibrate.repeatability_warn_rot_deg", "segment spread (max - min) above this is a warning, deg",
                    INSALIGN_AT(calibrate.repeatability_warn_rot_deg)));
  t.push_back(field("calibrate.repeatability_warn_trans_m", "segment spread (max - min) above this is a warning, m",
                    INSALIGN_AT(calibrate.repeatability_warn_trans_m)));

  // Motion pre-check.
  t.push_back(field("motion.min_distance_m", "the drive must cover at least this path length, m", INSALIGN_AT(calibrate.motion.min_distance_m)));
  t.push_back(field("motion.min_heading_change_deg", "total |heading change| needed (90 = one proper turn), deg",
                    INSALIGN_AT(calibrate.motion.min_heading_change_deg)));
  t.push_back(field("motion.min_lever_arm_sensitivity", "lever-arm sensitivity needed (0.35 = a 41 deg turn with equal legs)",
                    INSALIGN_AT(calibrate.motion.min_lever_arm_sensitivity)));
  t.push_back(field("motion.speed_window_s", "speeds are measured over windows at least this long, s", INSALIGN_AT(calibrate.motion.speed_window_s)));

  // Global initialisation.
  t.push_back(field("init.trust_init", "true: use --init unchanged, no checks", INSALIGN_AT(calibrate.init.trust_init)));
  t.push_back(field("init.min_range_m", "nearer points are the car body, m", INSALIGN_AT(calibrate.init.min_range_m)));
  t.push_back(field("init.max_range_m", "farther points are sparse and noisy, m", INSALIGN_AT(calibrate.init.max_range_m)));
  t.push_back(field("init.voxel_m", "downsampling voxel of every loaded frame, m", INSALIGN_AT(calibrate.init.voxel_m)));
  t.push_back(field("init.level_frames", "frames (spread over the drive) for the ground plane", INSALIGN_AT(calibrate.init.level_frames)));
  t.push_back(field("init.ground_inlier_m", "RANSAC ground-plane inlier distance, m", INSALIGN_AT(calibrate.init.ground_inlier_m)));
  t.push_back(field("init.ground_ransac_iterations", "RANSAC iterations for the ground plane", INSALIGN_AT(calibrate.init.ground_ransac_iterations)));
  t.push_back(field("init.max_tilt_deg", "ground normals farther than this from LiDAR z are rejected, deg", INSALIGN_AT(calibrate.init.max_tilt_deg)));
  t.push_back(field("init.coarse_yaw_step_deg", "yaw candidate step over 360 deg, deg", INSALIGN_AT(calibrate.init.coarse_yaw_step_deg)));
  t.push_back(field("init.coarse_frames", "frames of the straight stretch scored for yaw", INSALIGN_AT(calibrate.init.coarse_frames)));
  t.push_back(field("init.coarse_stretch_m", "length of that stretch, m", INSALIGN_AT(calibrate.init.coarse_stretch_m)));
  t.push_back(field("init.crispness_voxel_m", "voxel of the occupancy count used as a score, m", INSALIGN_AT(calibrate.init.crispness_voxel_m)));
  t.push_back(field("init.ground_clearance_m", "points this close to the ground plane are left out of scores, m", INSALIGN_AT(calibrate.init.ground_clearance_m)));
  t.push_back(field("init.hand_eye_pairs", "frame pairs registered for hand-eye", INSALIGN_AT(calibrate.init.hand_eye_pairs)));
  t.push_back(field("init.pair_dt_s", "time between the frames of a pair, s", INSALIGN_AT(calibrate.init.pair_dt_s)));
  t.push_back(field("init.min_pair_turn_deg", "pairs turning less only constrain yaw, deg", INSALIGN_AT(calibrate.init.min_pair_turn_deg)));
  t.push_back(field("init.max_angle_mismatch_deg", "|INS turn - LiDAR turn| above this rejects a pair, deg", INSALIGN_AT(calibrate.init.max_angle_mismatch_deg)));
  t.push_back(field("init.max_residual_m", "pairs with a larger hand-eye residual are dropped, m", INSALIGN_AT(calibrate.init.max_residual_m)));
  t.push_back(field("init.ins_height_guess_m", "INS origin height above the ground assumed without fiducials, m", INSALIGN_AT(calibrate.init.ins_height_guess_m)));
  t.push_back(field("init.score_frames", "frames spread over the drive for the final scores", INSALIGN_AT(calibrate.init.score_frames)));
  t.push_back(field("init.override_score_ratio", "the data overrides --init when the init's score exceeds the data's by this factor",
                    INSALIGN_AT(calibrate.init.override_score_ratio)));
  t.push_back(field("init.same_basin_rot_deg", "candidates closer than this share a basin, deg", INSALIGN_AT(calibrate.init.same_basin_rot_deg)));
  t.push_back(field("init.same_basin_trans_m", "...if also this close in translation, m", INSALIGN_AT(calibrate.init.same_basin_trans_m)));
  t.push_back(field("init.icp.max_iterations", "scan registration: Gauss-Newton iterations", INSALIGN_AT(calibrate.init.icp.max_iterations)));
  t.push_back(field("init.icp.max_corr_dist_start_m", "scan registration: correspondence gate at the start, m", INSALIGN_AT(calibrate.init.icp.max_corr_dist_start_m)));
  t.push_back(field("init.icp.max_corr_dist_end_m", "scan registration: the gate shrinks to this, m", INSALIGN_AT(calibrate.init.icp.max_corr_dist_end_m)));
  t.push_back(field("init.icp.normal_neighbours", "scan registration: neighbours for a target normal", INSALIGN_AT(calibrate.init.icp.normal_neighbours)));
  t.push_back(field("init.icp.max_plane_thickness_m", "scan registration: thicker neighbourhoods get no normal, m", INSALIGN_AT(calibrate.init.icp.max_plane_thickness_m)));
  t.push_back(field("init.icp.huber_delta_m", "scan registration: robust kernel scale, m", INSALIGN_AT(calibrate.init.icp.huber_delta_m)));
  t.push_back(field("init.icp.converged_step_m", "scan registration: stop when the update is below this (m and rad)", INSALIGN_AT(calibrate.init.icp.converged_step_m)));
  t.push_back(field("init.icp.min_inliers", "scan registration: fewer correspondences means not converged", INSALIGN_AT(calibrate.init.icp.min_inliers)));

  // Stage 1.
  t.push_back(field("rough.min_range_m", "points nearer than this are the car body, m", INSALIGN_AT(calibrate.rough.min_range_m)));
  t.push_back(field("rough.max_range_m", "points farther than this are dropped, m", INSALIGN_AT(calibrate.rough.max_range_m)));
  t.push_back(field("rough.downsample_voxel_m", "per-frame downsampling voxel in the LiDAR frame, m", INSALIGN_AT(calibrate.rough.downsample_voxel_m)));
  t.push_back(field("rough.max_depth", "adaptive-voxel octree depth below the root voxel", INSALIGN_AT(calibrate.rough.max_depth)));
  t.push_back(field("rough.max_eigen_ratio", "plane test: smallest / middle eigenvalue below this", INSALIGN_AT(calibrate.rough.max_eigen_ratio)));
  t.push_back(field("rough.min_points_per_plane", "voxels with fewer points are dropped", INSALIGN_AT(calibrate.rough.min_points_per_plane)));
  t.push_back(field("rough.min_frames_per_plane", "planes seen by fewer frames are dropped", INSALIGN_AT(calibrate.rough.min_frames_per_plane)));
  t.push_back(field("rough.always_fix_tz", "true: keep tz at its initial value even when the drive determines it", INSALIGN_AT(calibrate.rough.always_fix_tz)));
  t.push_back(field("rough.deskew", "use per-point times when the sweeps have them", INSALIGN_AT(calibrate.rough.deskew)));
  t.push_back(field("rough.frames.groups", "frame groups spread over the drive", INSALIGN_AT(calibrate.rough.frames.groups)));
  t.push_back(field("rough.frames.frames_per_group", "consecutive moving frames per group", INSALIGN_AT(calibrate.rough.frames.frames_per_group)));
  t.push_back(field("rough.frames.min_step_m", "a frame joins a group if it moved this far from the previous member, m", INSALIGN_AT(calibrate.rough.frames.min_step_m)));
  t.push_back(field("rough.frames.min_step_deg", "...or turned this much, deg", INSALIGN_AT(calibrate.rough.frames.min_step_deg)));
  t.push_back(field("rough.frames.rotation_weight_m_per_rad", "motion measure = distance + this * turned angle, m/rad",
                    INSALIGN_AT(calibrate.rough.frames.rotation_weight_m_per_rad)));
  t.push_back(field("rough.frames.sweep_span_s", "poses must cover this much before a frame time (deskewing), s", INSALIGN_AT(calibrate.rough.frames.sweep_span_s)));
  t.push_back(field("rough.observability.max_stddev_trans_m", "a translation DOF is determined below this standard deviation, m",
                    INSALIGN_AT(calibrate.rough.observability.max_stddev_trans_m)));
  t.push_back(field("rough.observability.max_stddev_rot_deg", "a rotation DOF is determined below this standard deviation, deg",
                    INSALIGN_AT(calibrate.rough.observability.max_stddev_rot_deg)));
  t.push_back(field("rough.observability.min_shift_m",
                    "a DOF is determined only if changing it by the accuracy target moves the points this much RMS, m",
                    INSALIGN_AT(calibrate.rough.observability.min_shift_m)));

  // Stage 2.
  t.push_back(enumeration("refine.method", "crispness measure: continuous (plane thickness, Gauss-Newton) or occupancy_grid (the paper)",
                          INSALIGN_AT(calibrate.refine.method),
                          std::vector<std::pair<std::string, RefineMethod>>{{"continuous", RefineMethod::kContinuous},
                                                                            {"occupancy_grid", RefineMethod::kOccupancyGrid}}));
  add_frame_pick(t, "refine.frames", [](auto& c) -> auto& { return c.calibrate.refine.frames; });
  t.push_back(field("refine.estimate_time_offset", "also estimate the LiDAR-to-INS time offset", INSALIGN_AT(calibrate.refine.estimate_time_offset)));
  t.push_back(field("refine.time_offset_range_s", "time offset searched within start +- this, s", INSALIGN_AT(calibrate.refine.time_offset_range_s)));
  t.push_back(field("refine.estimate_tz", "also move tz (unobservable from planar driving)", INSALIGN_AT(calibrate.refine.estimate_tz)));
  t.push_back(field("refine.occupancy_voxel_m", "occupancy_grid: voxel of the occupancy count, m", INSALIGN_AT(calibrate.refine.occupancy_voxel_m)));
  t.push_back(field("refine.grid_rot_range_deg", "occupancy_grid: first-round half range per rotation axis, deg", INSALIGN_AT(calibrate.refine.grid_rot_range_deg)));
  t.push_back(field("refine.grid_trans_range_m", "occupancy_grid: first-round half range per translation axis, m", INSALIGN_AT(calibrate.refine.grid_trans_range_m)));
  t.push_back(field("refine.grid_steps", "occupancy_grid: samples per side in a round", INSALIGN_AT(calibrate.refine.grid_steps)));
  t.push_back(field("refine.grid_rounds", "occupancy_grid: rounds, the range shrinking after each", INSALIGN_AT(calibrate.refine.grid_rounds)));
  t.push_back(field("refine.grid_shrink", "occupancy_grid: range factor between rounds", INSALIGN_AT(calibrate.refine.grid_shrink)));
  t.push_back(field("refine.grid_sweeps_per_round", "occupancy_grid: coordinate passes over all DOF per round", INSALIGN_AT(calibrate.refine.grid_sweeps_per_round)));
  t.push_back(field("refine.plane_voxel_m", "continuous: voxel fitted with a local plane, m", INSALIGN_AT(calibrate.refine.plane_voxel_m)));
  t.push_back(field("refine.plane_voxel_min_m", "continuous: non-planar voxels split once down to this, m", INSALIGN_AT(calibrate.refine.plane_voxel_min_m)));
  t.push_back(field("refine.plane_min_points", "continuous: a local plane needs at least this many points", INSALIGN_AT(calibrate.refine.plane_min_points)));
  t.push_back(field("refine.plane_max_planarity", "continuous: lambda_min / lambda_mid above this is not a plane", INSALIGN_AT(calibrate.refine.plane_max_planarity)));
  t.push_back(field("refine.huber_m", "continuous: robust loss scale on point-to-plane distances, m", INSALIGN_AT(calibrate.refine.huber_m)));
  t.push_back(field("refine.max_iterations", "continuous: Gauss-Newton iterations", INSALIGN_AT(calibrate.refine.max_iterations)));
  t.push_back(field("refine.converged_rot_deg", "continuous: stop when the rotation update is below this, deg", INSALIGN_AT(calibrate.refine.converged_rot_deg)));
  t.push_back(field("refine.converged_trans_m", "continuous: ...and the translation update below this, m", INSALIGN_AT(calibrate.refine.converged_trans_m)));
  t.push_back(field("refine.time_offset_scan_step_s", "coarse time-offset scan step before Gauss-Newton, s", INSALIGN_AT(calibrate.refine.time_offset_scan_step_s)));

  // Stage 3.
  t.push_back(enumeration("z.match", "how a fiducial meets the map: local_plane (robust plane) or nearest_neighbour (the paper)",
                          INSALIGN_AT(calibrate.z.match),
                          std::vector<std::pair<std::string, FiducialMatch>>{{"local_plane", FiducialMatch::kLocalPlane},
                                                                             {"nearest_neighbour", FiducialMatch::kNearestNeighbour}}));
  t.push_back(field("z.search_radius_m", "map points within this horizontal distance form a fiducial's local map, m", INSALIGN_AT(calibrate.z.search_radius_m)));
  t.push_back(field("z.min_points", "a fiducial needs at least this many map points", INSALIGN_AT(calibrate.z.min_points)));
  t.push_back(field("z.outlier_threshold_m", "fiducials farther than max(this, mad_factor * MAD) from the median dz are outliers, m",
                    INSALIGN_AT(calibrate.z.outlier_threshold_m)));
  t.push_back(field("z.outlier_mad_factor", "see outlier_threshold_m", INSALIGN_AT(calibrate.z.outlier_mad_factor)));
  t.push_back(field("z.min_fiducials", "fewer usable fiducials and tz is not determined", INSALIGN_AT(calibrate.z.min_fiducials)));
  t.push_back(field("z.fiducial_sigma_m", "survey noise of a fiducial (1 sigma), m", INSALIGN_AT(calibrate.z.fiducial_sigma_m)));
  t.push_back(field("z.ins_vertical_sigma_m", "absolute height error of the INS over the drive (1 sigma), m",
                    INSALIGN_AT(calibrate.z.ins_vertical_sigma_m)));
  t.push_back(field("z.min_range_m", "nearer points are the car body, m", INSALIGN_AT(calibrate.z.min_range_m)));
  t.push_back(field("z.min_view_distance_m", "frames used for a fiducial pass at least this far from it, m", INSALIGN_AT(calibrate.z.min_view_distance_m)));
  t.push_back(field("z.max_view_distance_m", "...and at most this far, m", INSALIGN_AT(calibrate.z.max_view_distance_m)));
  t.push_back(field("z.frames_per_fiducial", "at most this many frames per fiducial", INSALIGN_AT(calibrate.z.frames_per_fiducial)));
  t.push_back(field("z.max_frames_per_fiducial", "more (farther) frames for a fiducial seen in too few, up to this many",
                    INSALIGN_AT(calibrate.z.max_frames_per_fiducial)));
  t.push_back(field("z.min_frame_separation_s", "frames for one fiducial at least this far apart in time, s", INSALIGN_AT(calibrate.z.min_frame_separation_s)));
  t.push_back(field("z.height_samples", "height prior: places along the drive where the ground under the INS is measured", INSALIGN_AT(calibrate.z.height_samples)));
  t.push_back(field("z.ground_radius_m", "height prior: ground points within this of the INS origin are fitted, m", INSALIGN_AT(calibrate.z.ground_radius_m)));
  t.push_back(field("z.ground_window_s", "height prior: neighbouring frames within this time are stitched in, s", INSALIGN_AT(calibrate.z.ground_window_s)));
  t.push_back(field("z.ground_frames_per_sample", "height prior: frames stitched per sample", INSALIGN_AT(calibrate.z.ground_frames_per_sample)));
  t.push_back(field("z.max_ground_slope_deg", "height prior: a steeper plane is not ground, deg", INSALIGN_AT(calibrate.z.max_ground_slope_deg)));

  // Simulator.
  t.push_back(field("sim.seed", "random seed of the scene, noise and mount", INSALIGN_AT(sim.seed)));
  t.push_back(enumeration("sim.scene", "scene: intersection (buildings, poles, cars) or feature_poor", INSALIGN_AT(sim.scene),
                          std::vector<std::pair<std::string, sim::SceneKind>>{{"intersection", sim::SceneKind::kIntersection},
                                                                              {"feature_poor", sim::SceneKind::kFeaturePoor}}));
  t.push_back(enumeration("sim.trajectory", "drive: figure8, straight or standstill", INSALIGN_AT(sim.trajectory),
                          std::vector<std::pair<std::string, sim::TrajectoryKind>>{{"figure8", sim::TrajectoryKind::kFigure8},
                                                                                   {"straight", sim::TrajectoryKind::kStraight},
                                                                                   {"standstill", sim::TrajectoryKind::kStandstill}}));
  t.push_back(field("sim.figure8_loops", "loops of the figure-8", INSALIGN_AT(sim.figure8_loops)));
  t.push_back(field("sim.speed_kmh", "cruise speed, km/h", INSALIGN_AT(sim.speed_kmh)));
  t.push_back(field("sim.duration_s", "0: the trajectory's natural length; > 0 truncates, s", INSALIGN_AT(sim.duration_s)));
  t.push_back(field("sim.lidar_model", "pandar64, hdl32, os1-64 or vlp16", INSALIGN_AT(sim.lidar_model)));
  t.push_back(field("sim.azimuth_step_deg", "horizontal resolution, deg", INSALIGN_AT(sim.azimuth_step_deg)));
  t.push_back(field("sim.frame_rate_hz", "spin rate, one frame per revolution, Hz", INSALIGN_AT(sim.frame_rate_hz)));
  t.push_back(field("sim.range_noise_m", "range noise sigma along the ray, m", INSALIGN_AT(sim.range_noise_m)));
  t.push_back(field("sim.dropout_prob", "probability that a return is lost", INSALIGN_AT(sim.dropout_prob)));
  t.push_back(field("sim.max_range_m", "no return beyond this, m", INSALIGN_AT(sim.max_range_m)));
  t.push_back(enumeration("sim.ins_axes", "INS body axes: x_forward (ROS REP-103) or y_forward (NovAtel)", INSALIGN_AT(sim.ins_axes),
                          std::vector<std::pair<std::string, sim::InsAxes>>{{"x_forward", sim::InsAxes::kXForward},
                                                                            {"y_forward", sim::InsAxes::kYForward}}));
  t.push_back(field("sim.ins_noise_scale", "INS noise: 1 = NovAtel class, 0 = perfect poses", INSALIGN_AT(sim.ins_noise_scale)));
  t.push_back(enumeration("sim.ins_error.model", "INS slow error: rtk_fixed (bounded) or drift (random walk from the start)",
                          INSALIGN_AT(sim.ins_error.model),
                          std::vector<std::pair<std::string, sim::InsErrorModel>>{{"rtk_fixed", sim::InsErrorModel::kRtkFixed},
                                                                                  {"drift", sim::InsErrorModel::kDrift}}));
  t.push_back(field("sim.ins_error.drift_horizontal_m_per_sqrt_s", "drift: position random walk per horizontal axis, m/sqrt(s)",
                    INSALIGN_AT(sim.ins_error.drift_horizontal_m_per_sqrt_s)));
  t.push_back(field("sim.ins_error.drift_vertical_m_per_sqrt_s", "drift: vertical position random walk, m/sqrt(s)",
                    INSALIGN_AT(sim.ins_error.drift_vertical_m_per_sqrt_s)));
  t.push_back(field("sim.ins_error.drift_heading_deg_per_sqrt_s", "drift: heading random walk, deg/sqrt(s)",
                    INSALIGN_AT(sim.ins_error.drift_heading_deg_per_sqrt_s)));
  t.push_back(field("sim.ins_error.float_episodes", "RTK float episodes (error ramping up and back)", INSALIGN_AT(sim.ins_error.float_episodes)));
  t.push_back(field("sim.ins_error.float_peak_m", "float episode: peak position error, m", INSALIGN_AT(sim.ins_error.float_peak_m)));
  t.push_back(field("sim.ins_error.float_duration_s", "float episode: length, s", INSALIGN_AT(sim.ins_error.float_duration_s)));
  t.push_back(field("sim.ins_error.wrong_fixes", "wrong RTK fixes (a jump, reported as a normal fix)", INSALIGN_AT(sim.ins_error.wrong_fixes)));
  t.push_back(field("sim.ins_error.wrong_fix_jump_m", "wrong fix: position jump, m", INSALIGN_AT(sim.ins_error.wrong_fix_jump_m)));
  t.push_back(field("sim.ins_error.wrong_fix_duration_s", "wrong fix: length, s", INSALIGN_AT(sim.ins_error.wrong_fix_duration_s)));
  t.push_back(field("sim.ins_error.outages", "GNSS outages (the INS coasts)", INSALIGN_AT(sim.ins_error.outages)));
  t.push_back(field("sim.ins_error.outage_duration_s", "outage: length, s", INSALIGN_AT(sim.ins_error.outage_duration_s)));
  t.push_back(field("sim.ins_error.outage_error_m", "outage: position error at its end (grows quadratically), m", INSALIGN_AT(sim.ins_error.outage_error_m)));
  t.push_back(field("sim.ins_error.outage_tilt_deg", "outage: roll and pitch error at its end, deg", INSALIGN_AT(sim.ins_error.outage_tilt_deg)));
  t.push_back(field("sim.ins_error.outage_heading_deg", "outage: heading error at its end, deg", INSALIGN_AT(sim.ins_error.outage_heading_deg)));
  t.push_back(field("sim.time_offset_s", "true LiDAR-to-INS time offset (t_ins = t_lidar + offset), s", INSALIGN_AT(sim.time_offset_s)));
  t.push_back(field("sim.init_rot_err_deg", "rotation error of the written initial guess, deg", INSALIGN_AT(sim.init_rot_err_deg)));
  t.push_back(field("sim.init_trans_err_m", "translation error of the written initial guess, m", INSALIGN_AT(sim.init_trans_err_m)));
  t.push_back(field("sim.n_fiducials", "surveyed ground points", INSALIGN_AT(sim.n_fiducials)));
  t.push_back(field("sim.fiducial_noise_m", "survey noise sigma per axis, m", INSALIGN_AT(sim.fiducial_noise_m)));
  t.push_back(field("sim.traffic", "moving cars and vans in the lanes beside the path", INSALIGN_AT(sim.traffic)));
  t.push_back(field("sim.pedestrians", "moving people (cyclists, walkers, joggers) on bike lanes and sidewalks", INSALIGN_AT(sim.pedestrians)));
  t.push_back(field("sim.rig", "several LiDARs: name:model[@mount][/rate_hz],... (empty: the single lidar_model)", INSALIGN_AT(sim.rig)));
  t.push_back(field("sim.rig_clock_spread_s", "rig: each LiDAR's clock offset is time_offset_s plus a uniform draw within +-this, s",
                    INSALIGN_AT(sim.rig_clock_spread_s)));
  return t;
}

#undef INSALIGN_AT

}  // namespace

const std::vector<ConfigParam<ToolConfig>>& tool_config_params() {
  static const std::vector<P> table = build_table();  // immutable after first use
  return table;
}

ToolConfig load_tool_config(const std::filesystem::path& path, ToolConfig defaults) {
  load_config_file(tool_config_params(), path, defaults);
  return defaults;
}

ToolConfig tool_config_with(const std::vector<std::string>& assignments, const std::string& source,
                            ToolConfig defaults) {
  for (const std::string& a : assignments) apply_config_assignment(tool_config_params(), a, source, defaults);
  return defaults;
}

std::string dump_tool_config(const ToolConfig& config) {
  return dump_config(tool_config_params(), config,
                     "insalign parameters with their defaults. Pass a file with any subset of them to\n"
                     "`insalign calibrate --config FILE` (or `simulate`); unknown names are errors.\n"
                     "Not settable here: the stage-1 round schedule (rough.rounds) and the simulator's\n"
                     "fixed mount (use --init / the simulate options).");
}

}  // namespace insalign::io
