#include "report/result_outputs.hpp"

#include <fmt/format.h>
#include <tbb/parallel_invoke.h>

#include <cmath>

#include "core/stitch.hpp"
#include "files/extrinsic_json.hpp"
#include "input/input_report.hpp"

namespace insalign::io {
namespace {

using nlohmann::json;

// JSON has no NaN or infinity: unknown or undetermined numbers are null.
json number(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

json vec(const Vec3& v) { return json::array({number(v.x()), number(v.y()), number(v.z())}); }

/// Per DOF, m and rad in, m and deg out.
json dof_map(const Vec6& v) {
  return {{"tx_m", number(v[0])},
          {"ty_m", number(v[1])},
          {"tz_m", number(v[2])},
          {"roll_deg", number(v[3] * kDegPerRad)},
          {"pitch_deg", number(v[4] * kDegPerRad)},
          {"yaw_deg", number(v[5] * kDegPerRad)}};
}

json determined_map(const std::array<bool, 6>& d) {
  json out = json::object();
  for (int i = 0; i < 6; ++i) out[kDofNames[i]] = d[i];
  return out;
}

json outcome_json(const StageOutcome& o) {
  return {{"status", std::string(enum_name(o.status))},
          {"message", o.message},
          {"determined", determined_map(o.determined)},
          {"stddev", dof_map(o.stddev)},
          {"wall_time_s", o.wall_time_s}};
}

json init_json(const GlobalInitResult& init) {
  json j = {{"outcome", outcome_json(init.outcome)},
            {"source", std::string(enum_name(init.source))},
            {"start_candidate", init.start_candidate},
            {"start_is_near", start_is_near(init)},  // stage 1 then skips its one-group rounds
            {"explanation", init.explanation},
            {"extrinsic", extrinsic_fields(init.T_ins_lidar)},
            {"frames_loaded", init.frames_loaded},
            {"time_offset", {{"applied", init.time_offset.applied},
                             {"offset_s", init.time_offset.offset_s},
                             {"best_offset_s", init.time_offset.best_offset_s},
                             {"median_angle_difference_at_best_deg", init.time_offset.median_at_best_deg},
                             {"median_angle_difference_at_zero_deg", init.time_offset.median_at_reference_deg},
                             {"pairs", init.time_offset.pairs}}},
            {"seconds", {{"load", init.load_s}, {"coarse_yaw", init.coarse_s}, {"hand_eye", init.hand_eye_s},
                         {"scores", init.score_s}}},
            {"candidates", json::array()}};
  for (const InitCandidate& c : init.candidates)
    j["candidates"].push_back({{"label", c.label}, {"score", c.score}, {"extrinsic", extrinsic_fields(c.T_ins_lidar)}});
  return j;
}

json rough_json(const RoughResult& r) {
  json rounds = json::array();
  for (const RoundLog& log : r.convergence) {
    rounds.push_back({{"round", log.round}, {"cost", log.cost}, {"planes", log.planes}, {"residuals", log.residuals},
                      {"windows", log.windows}, {"build_s", log.build_s}, {"solve_s", log.solve_s},
                      {"extrinsic", extrinsic_fields(log.T_ins_lidar)}});
  }
  return {{"outcome", outcome_json(r.outcome)},
          {"extrinsic", extrinsic_fields(r.T_ins_lidar)},
          {"cost_before_m2", r.cost_before},
          {"cost_after_m2", r.cost_after},
          {"residual_sigma_m", r.residual_sigma_m},
          {"frames_used", r.frames_used},
          {"load_s", r.load_time_s},
          {"planes", r.planes},
          {"residuals", r.residuals},
          {"tz_estimated", r.tz_estimated},
          {"observability", r.observability.explanation},
          {"rounds", rounds}};
}

json refine_json(const RefineResult& f) {
  json rounds = json::array();
  for (const RefineRound& log : f.rounds) {
    rounds.push_back({{"round", log.round}, {"cost", log.cost}, {"time_offset_s", log.time_offset_s},
                      {"extrinsic", extrinsic_fields(log.T_ins_lidar)}});
  }
  return {{"outcome", outcome_json(f.outcome)},
          {"extrinsic", extrinsic_fields(f.T_ins_lidar)},
          {"time_offset_s", f.time_offset_s},
          {"time_offset_stddev_s", number(f.time_offset_stddev_s)},
          {"time_offset_estimated", f.time_offset_estimated},
          {"stddev_from_ins_position", dof_map(f.ins_position_stddev)},
          {"measure", f.measure},
          {"crispness_before", f.crispness_before},
          {"crispness_after", f.crispness_after},
          {"occupied_voxels_before", f.occupied_voxels_before},
          {"occupied_voxels_after", f.occupied_voxels_after},
          {"frames_used", f.frames_used},
          {"points_used", f.points_used},
          {"evaluations", f.evaluations},
          {"converged", f.converged},
          {"rounds", rounds}};
}

json z_json(const ZResult& z) {
  json fiducials = json::array();
  for (const FiducialResidual& f : z.fiducials) {
    fiducials.push_back({{"id", f.id},
                         {"residual_before_m", number(f.residual_before_m)},
                         {"residual_after_m", number(f.residual_after_m)},
                         {"used", f.used},
                         {"reason_rejected", f.reason_rejected},
                         {"map_points", f.map_points}});
  }
  return {{"outcome", outcome_json(z.outcome)},
          {"method", std::string(enum_name(z.method))},
          {"dz_m", z.dz_m},
          {"height_samples_used", z.height_samples_used},
          {"fiducials", fiducials}};
}

json repeatability_json(const RepeatabilityResult& rep) {
  json segments = json::array();
  for (const SegmentResult& s : rep.segments) {
    json seg = {{"t_begin_s", s.t_begin_s}, {"t_end_s", s.t_end_s}, {"frames", s.frames}, {"ok", s.ok}};
    if (s.ok) {
      seg["extrinsic"] = extrinsic_fields(s.T_ins_lidar);
      seg["time_offset_s"] = s.time_offset_s;
    } else {
      seg["message"] = s.message;
    }
    segments.push_back(seg);
  }
  return {{"segments", segments},
          {"spread", dof_map(rep.spread)},
          {"stddev_whole_drive", dof_map(rep.stddev_whole_drive)},
          {"wall_time_s", rep.wall_time_s}};
}

// Every INS span left out, with who found it and why; the LiDAR checks' thresholds; the mask.
json screen_json(const CalibrationResult& r) {
  json spans = json::array();
  for (const TimeSpan& span : r.excluded)
    spans.push_back({{"begin_s", span.begin_s},
                     {"end_s", span.end_s},
                     {"duration_s", span.end_s - span.begin_s},
                     {"kind", std::string(enum_name(span.kind))},
                     {"source", std::string(enum_name(span.source))},
                     {"reason", span.reason}});
  const InsScreenResult& s = r.ins_screen;
  std::size_t pairs_used = 0, frames_used = 0;
  for (const PairCheck& p : s.pairs) pairs_used += p.used;
  for (const FrameOffset& f : s.offsets) frames_used += f.used;
  const MovingPointsResult& m = r.moving;
  return {{"ins_spans_left_out", spans},
          {"ins_time_left_out_s", spans_duration_s(r.excluded)},
          {"ins_checks",
           {{"typical_stated_horizontal_stddev_m", number(s.typical_stddev_m)},
            {"scan_pairs_used", pairs_used},
            {"scan_pair_threshold_m", s.jump_threshold_m},
            {"map_frames_used", frames_used},
            {"map_offset_threshold_m", s.offset_threshold_m},
            {"wall_time_s", s.wall_time_s}}},
          {"moving_points",
           {{"applied", m.applied},
            {"sample_frames", m.frames_used},
            {"voxels_judged", m.voxels_judged},
            {"voxels_moving", m.voxels_moving},
            {"sample_points", m.points_checked},
            {"sample_points_left_out", m.points_moving},
            {"wall_time_s", m.wall_time_s}}}};
}

// The INS position correction found with the extrinsic: knots (INS clock) and values (world, m).
json trajectory_correction_json(const TrajectoryCorrection& c) {
  json knots = json::array();
  for (std::size_t k = 0; k < c.t_s.size(); ++k)
    knots.push_back({{"t_s", c.t_s[k]}, {"position_m", {c.position_m[k].x(), c.position_m[k].y(), c.position_m[k].z()}}});
  return {{"outcome", outcome_json(c.outcome)},
          {"applied", c.applied},
          {"decision", c.decision},
          {"correction_rms_m", c.correction_rms_m},
          {"correction_rms_xyz_m", {c.correction_rms_axes_m.x(), c.correction_rms_axes_m.y(), c.correction_rms_axes_m.z()}},
          {"prior_rms_xyz_m", {c.prior_rms_axes_m.x(), c.prior_rms_axes_m.y(), c.prior_rms_axes_m.z()}},
          {"plane_thickness_rms_m", {{"ins_poses", c.cost_ins_rms_m}, {"corrected_poses", c.cost_corrected_rms_m}}},
          {"frames_used", c.frames_used},
          {"points_used", c.points_used},
          {"iterations", c.iterations},
          {"knots", knots}};
}

std::string dof_value(int i, const Iso3& T) {
  const Vec3 t = T.translation();
  const Vec3 rpy = rpy_from_rotation(T.linear()) * kDegPerRad;
  return fmt::format("{:.4f}", i < 3 ? t[i] : rpy[i - 3]);
}

// Stddev as a person reads it: m or deg, "-" when not determined.
std::string dof_stddev(int i, const Vec6& stddev) {
  if (!std::isfinite(stddev[i])) return "-";
  return fmt::format("{:.4f}", i < 3 ? stddev[i] : stddev[i] * kDegPerRad);
}

double data_start_s(const FrameStore& store) {
  const auto& frames = store.data().frames.frames;
  return frames.empty() ? 0.0 : frames.front().t_end_s;
}

// A map snapshot; with a mask, the points it leaves out apart (drawn in another colour).
MapSnapshot map_snapshot(const std::string& label, const FrameStore& store, const std::vector<std::size_t>& frames,
                         const Iso3& T_ins_lidar, double time_offset_s, const PointMask* mask) {
  if (!mask) return {label, stitch_map(store, frames, T_ins_lidar, time_offset_s, 0.05), {}};
  SplitMap split = stitch_map_split(store, frames, T_ins_lidar, time_offset_s, 0.05, *mask);
  return {label, std::move(split.kept_world), std::move(split.dropped_world)};
}

// What the stages did not use: the INS spans (and why) and the points on moving things.
std::string left_out_text(const CalibrationResult& r) {
  std::string s;
  if (!r.excluded.empty())
    s += fmt::format("\nINS left out: {} spans, {:.1f} s\n", r.excluded.size(), spans_duration_s(r.excluded));
  for (const TimeSpan& span : r.excluded)
    s += fmt::format("  {:.3f} - {:.3f} s ({:.1f} s, {}): {}\n", span.begin_s, span.end_s, span.end_s - span.begin_s,
                     enum_name(span.source), span.reason);
  if (r.moving.applied && r.moving.points_checked > 0)
    s += fmt::format("moving things: {:.2f}% of the sampled points left out ({} voxels of moving space)\n",
                     100.0 * r.moving.points_moving / r.moving.points_checked, r.moving.voxels_moving);
  return s;
}

}  // namespace

json extrinsic_fields(const Iso3& T_ins_lidar) {
  const Eigen::Quaterniond q(T_ins_lidar.linear());
  return {{"T_ins_lidar", transform_to_json(T_ins_lidar)},
          {"translation_m", vec(T_ins_lidar.translation())},
          {"rpy_deg", vec(rpy_from_rotation(T_ins_lidar.linear()) * kDegPerRad)},
          {"quaternion_wxyz", json::array({q.w(), q.x(), q.y(), q.z()})}};
}

json dof_json(const Vec6& m_rad) { return dof_map(m_rad); }
json determined_json(const std::array<bool, 6>& determined) { return determined_map(determined); }

json result_to_json(const CalibrationResult& r, const RunInfo& run) {
  json out = extrinsic_fields(r.T_ins_lidar);
  out["time_offset_s"] = r.time_offset_s;
  out["stddev"] = dof_map(r.stddev);
  out["stddev"]["time_offset_s"] = number(r.time_offset_stddev_s);
  out["stddev_yaw_includes_ins_heading_deg"] = r.ins_heading_sigma_rad * kDegPerRad;  // ins_heading_sigma_deg
  out["stddev_includes_ins_drift"] = dof_map(r.ins_drift_stddev.head<6>());  // the drift the correction measured
  out["stddev_includes_ins_drift"]["time_offset_s"] = r.ins_drift_stddev[6];
  out["determined"] = determined_map(r.determined);
  out["tz_source"] = std::string(enum_name(r.tz_source));  // stage 3's method is stages.z.method
  out["advice"] = r.advice;
  out["warnings"] = r.warnings;
  out["wall_time_s"] = r.wall_time_s;
  out["frames_decoded"] = r.frames_decoded;
  out["stages"] = {{"init", init_json(r.init)}, {"rough", rough_json(r.rough)}, {"z", z_json(r.z)}};
  if (r.refine) out["stages"]["refine"] = refine_json(*r.refine);
  out["repeatability"] = repeatability_json(r.repeatability);
  out["left_out"] = screen_json(r);
  out["trajectory_correction"] = trajectory_correction_json(r.trajectory);
  out["motion"] = {{"distance_m", r.motion.distance_m},
                   {"heading_change_deg", r.motion.heading_change_deg},
                   {"lever_arm_sensitivity", r.motion.lever_arm_sensitivity},
                   {"max_speed_mps", r.motion.max_speed_mps},
                   {"duration_s", r.motion.duration_s}};
  out["input"] = input_json(run.load);  // what was read: input/input_report.hpp
  return out;
}

std::vector<std::size_t> report_frames(const FrameStore& store, const CalibrationResult& result) {
  return spread_frames(store, 40, result.time_offset_s);
}

// The same frames stitched at each stage's extrinsic, so the thinning is visible.
MapSnapshot report_map(const CalibrationResult& r, const FrameStore& store, const std::vector<std::size_t>& frames,
                       std::size_t i) {
  switch (i) {
    case 0: return map_snapshot("start", store, frames, r.init.T_ins_lidar, 0.0, nullptr);
    case 1: return map_snapshot("stage 1: rough", store, frames, r.rough.T_ins_lidar, 0.0, nullptr);
    default:  // the moving things the stages left out, in magenta
      return map_snapshot("final", store, frames, r.T_ins_lidar, r.time_offset_s, r.moving.mask.get());
  }
}

ViewerScene report_viewer_scene(const CalibrationResult& r, const FrameStore& store, const std::vector<std::size_t>& frames,
                                const ViewerConfig& viewer) {
  return viewer_scene(store, frames, {{"start", r.init.T_ins_lidar, 0.0}, {"final", r.T_ins_lidar, r.time_offset_s}},
                      r.excluded, r.moving.mask.get(), viewer);
}

ReportImages report_images(const CalibrationResult& r, const FrameStore& store, const ViewerConfig& viewer) {
  const std::vector<std::size_t> frames = report_frames(store, r);
  ReportImages images;
  ViewerScene scene;
  // The viewer's points are placed while the pictures are drawn: the report takes no longer.
  tbb::parallel_invoke(
      [&] { images = draw_report_images(kReportMaps, [&](std::size_t i) { return report_map(r, store, frames, i); }); },
      [&] {
        if (viewer.max_points > 0) scene = report_viewer_scene(r, store, frames, viewer);
      });
  if (scene.size() == 0) return images;
  scene.sections = report_sections(images);
  images.viewer = encode_viewer(scene);
  return images;
}

std::vector<MapSnapshot> report_maps(const CalibrationResult& r, const FrameStore& store) {
  const std::vector<std::size_t> frames = report_frames(store, r);
  std::vector<MapSnapshot> maps;
  for (std::size_t i = 0; i < kReportMaps; ++i) maps.push_back(report_map(r, store, frames, i));
  return maps;
}

ReportData report_data(const CalibrationResult& r, const FrameStore& store, const RunInfo& run,
                       const PipelineConfig& config) {
  ReportData report;
  report.T_ins_lidar = r.T_ins_lidar;
  const LoadReport& load = run.load;
  report.input_summary = {
      {"frames", fmt::format("{} used of {} found", load.frames_used, load.frames_total)},
      {"poses", fmt::format("{} ({})", store.poses().size(), load.pose_format)},
      {"duration", fmt::format("{:.1f} s", r.motion.duration_s)},
      {"distance driven", fmt::format("{:.1f} m", r.motion.distance_m)},
      {"total heading change", fmt::format("{:.0f} deg", r.motion.heading_change_deg)},
      {"top speed", fmt::format("{:.1f} km/h", 3.6 * r.motion.max_speed_mps)},
      {"point time field", describe_time_field(load.time_field)},
      {"frame times", load.frame_time_source},
      {"sweeps decoded", fmt::format("{} (each at most once)", r.frames_decoded)}};
  for (auto& row : input_rows(load)) report.input_summary.push_back(std::move(row));
  report.stages.push_back({"start (" + std::string(enum_name(r.init.source)) + ")", r.init.T_ins_lidar, 0.0, "", NAN,
                           NAN, r.init.outcome.wall_time_s, r.init.explanation});
  report.stages.push_back({"stage 1: rough", r.rough.T_ins_lidar, 0.0, "robust point-to-plane cost (m^2)",
                           r.rough.cost_before, r.rough.cost_after, r.rough.outcome.wall_time_s,
                           fmt::format("{} frames, {} planes", r.rough.frames_used, r.rough.planes)});
  if (r.refine) {
    report.stages.push_back({"stage 2: refine", r.refine->T_ins_lidar, r.refine->time_offset_s, r.refine->measure,
                             r.refine->crispness_before, r.refine->crispness_after, r.refine->outcome.wall_time_s,
                             fmt::format("occupied voxels {} -> {}", r.refine->occupied_voxels_before,
                                         r.refine->occupied_voxels_after)});
  }
  report.stages.push_back({"stage 3: z", r.z.T_ins_lidar, r.time_offset_s, "", NAN, NAN, r.z.outcome.wall_time_s,
                           r.z.outcome.message});
  for (const RoundLog& log : r.rough.convergence) report.convergence.push_back({"rough", log.round, log.T_ins_lidar, log.cost});
  if (r.refine) {
    for (const RefineRound& log : r.refine->rounds) report.convergence.push_back({"refine", log.round, log.T_ins_lidar, log.cost});
  }
  for (const FiducialResidual& f : r.z.fiducials)
    report.fiducials.push_back({f.id, f.residual_before_m, f.residual_after_m, f.used, f.reason_rejected});
  report.fiducial_summary = r.z.outcome.message;
  report.time_offset_s = r.time_offset_s;
  if (r.refine) {
    report.time_offset_stddev_s = r.time_offset_stddev_s;
    report.time_offset_note = r.refine->time_offset_estimated ? "estimated in stage 2" : "not estimated";
  }
  ObservabilityReport obs;
  obs.determined = r.determined;
  obs.stddev = r.stddev;
  obs.explanation = r.rough.observability.explanation;
  report.observability = obs;
  if (!r.repeatability.segments.empty()) {
    RepeatabilityReport rep;
    const double t0 = r.repeatability.segments.front().t_begin_s;
    for (const SegmentResult& seg : r.repeatability.segments) {
      rep.segments.push_back({fmt::format("{:.0f}-{:.0f} s", seg.t_begin_s - t0, seg.t_end_s - t0), seg.ok, seg.message,
                              seg.T_ins_lidar, seg.time_offset_s});
    }
    rep.spread = r.repeatability.spread;
    const auto& rc = config.repeatability;
    rep.warn_above << rc.warn_trans_m, rc.warn_trans_m, rc.warn_trans_m, rc.warn_rot_deg * kRadPerDeg,
        rc.warn_rot_deg * kRadPerDeg, rc.warn_rot_deg * kRadPerDeg;
    report.repeatability = rep;
  }
  report.advice = r.advice;
  report.warnings.assign(r.warnings.begin() + static_cast<std::ptrdiff_t>(std::min(r.advice.size(), r.warnings.size())),
                         r.warnings.end());
  const double t0 = data_start_s(store);
  if (r.trajectory.outcome.ok()) {
    TrajectoryCorrectionReport tc{r.trajectory.applied, r.trajectory.decision, {}, r.trajectory.position_m};
    for (double t : r.trajectory.t_s) tc.t_s.push_back(t - r.trajectory.time_offset_s - t0);
    report.trajectory_correction = tc;
  }
  for (const TimeSpan& span : r.excluded)
    report.left_out.push_back(fmt::format("INS {:.1f}-{:.1f} s after the first frame ({:.1f} s), found by {}: {}",
                                          span.begin_s - t0, span.end_s - t0, span.end_s - span.begin_s,
                                          enum_name(span.source), span.reason));
  if (r.moving.applied && r.moving.points_checked > 0)
    report.left_out.push_back(fmt::format("points on moving things (space seen empty at other times): {:.2f}% of the "
                                          "sampled points, magenta on the final map",
                                          100.0 * r.moving.points_moving / r.moving.points_checked));
  for (const auto& f : run.format_files) report.output_files.push_back({f.filename().string(), "extrinsic for other tools"});
  report.output_files.push_back({"extrinsic.json", "the result with uncertainties and per-stage metrics"});
  report.output_files.push_back({"gnss-to-lidar-extrinsic.json", "OpenCalib JSON (T_lidar_ins)"});

  return report;
}

std::string summary_text(const CalibrationResult& r, const RunInfo& run) {
  // What to do first: a DOF not determined or weak, an INS that looks wrong (one line each).
  std::string s;
  if (!r.advice.empty()) s += "\n";
  for (const std::string& a : r.advice) s += "attention: " + a + "\n";
  s += "\nT_ins_lidar (LiDAR to INS)\n";
  s += fmt::format("  {:<6} {:>12} {:>12} {:>12}\n", "dof", "value", "stddev", "determined");
  const char* names[6] = {"x m", "y m", "z m", "roll", "pitch", "yaw"};
  for (int i = 0; i < 6; ++i) {
    s += fmt::format("  {:<6} {:>12} {:>12} {:>12}\n", names[i], dof_value(i, r.T_ins_lidar), dof_stddev(i, r.stddev),
                     r.determined[i] ? "yes" : "NO");
  }
  s += fmt::format("  tz from {}\n", tz_source_phrase(r.tz_source));
  s += fmt::format("  time offset {:.4f} s\n\nstages\n", r.time_offset_s);
  const auto stage = [&](const char* name, double seconds, const std::string& note) {
    s += fmt::format("  {:<14} {:>7.2f} s  {}\n", name, seconds, note);
  };
  stage("init", r.init.outcome.wall_time_s, std::string(enum_name(r.init.source)));
  stage("rough", r.rough.outcome.wall_time_s,
        fmt::format("cost {:.4g} -> {:.4g} m^2, {} frames", r.rough.cost_before, r.rough.cost_after, r.rough.frames_used));
  if (r.refine) {
    stage("refine", r.refine->outcome.wall_time_s,
          fmt::format("{}: {:.4g} -> {:.4g}", r.refine->measure, r.refine->crispness_before, r.refine->crispness_after));
  }
  stage("z", r.z.outcome.wall_time_s, r.z.determined() ? std::string(enum_name(r.z.method)) : "tz not determined");
  if (!r.repeatability.segments.empty()) {
    stage("repeatability", r.repeatability.wall_time_s,
          fmt::format("{} of {} segments calibrated alone", r.repeatability.segments_ok, r.repeatability.segments.size()));
  }
  s += fmt::format("  total          {:>7.2f} s  (loading included; {} sweeps decoded), peak memory {:.0f} MB\n",
                   r.wall_time_s, r.frames_decoded, run.peak_memory_mb);
  s += left_out_text(r);
  for (std::size_t k = r.advice.size(); k < r.warnings.size(); ++k) s += "warning: " + r.warnings[k] + "\n";
  return s;
}

}  // namespace insalign::io
