#include "core/pipeline.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fmt/format.h>
#include <tbb/parallel_invoke.h>

#include "core/errors.hpp"
#include "core/z_surface.hpp"

namespace insalign {
namespace {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// The stage's verdict is the run's when it is certain to stop the calibration.
void stop_if_undetermined(const StageOutcome& outcome) {
  if (outcome.status == StageStatus::kUndetermined) throw UnobservableError(outcome.message);
}

// Stage 2 from stage 1, with tz already fixed by stage 3 (which is cheap). tz is not free in
// stages 1 and 2, and a wrong tz shows as a horizontal shift wherever the car rolls or pitches:
// 0.3 m at a 1.5 deg roll in a turn is 8 mm sideways, which the lateral lever arm absorbs
// (measured on the recorded trajectory: tx 3.3 -> 0.2 mm with perfect poses).
void run_refine(const FrameStore& store, const std::vector<std::size_t>& frames, const PipelineConfig& config,
                const PipelineProgress& progress, NearPoints& near, CalibrationResult& r) {
  const ZResult early_z = correct_z(store, r.T_ins_lidar, r.time_offset_s, config.ins_height_m, config.z, &near);
  if (early_z.determined()) r.T_ins_lidar = early_z.T_ins_lidar;
  std::string warning;
  r.refine = refine_checked(store, frames, r.T_ins_lidar, r.time_offset_s, r.motion.max_speed_mps, config.refine,
                            [&](double f) { progress("refine", f); }, warning);
  stop_if_undetermined(r.refine->outcome);
  if (!warning.empty()) r.warnings.push_back(warning);
  r.T_ins_lidar = r.refine->T_ins_lidar;
  r.time_offset_s = r.refine->time_offset_s;
  r.time_offset_stddev_s = r.refine->time_offset_stddev_s;
  for (int i : {0, 1, 3, 4, 5})
    if (std::isfinite(r.refine->outcome.stddev[i])) r.stddev[i] = r.refine->outcome.stddev[i];
}

// The formal stddev treats every point as independent and comes out 10-50x below the
// benchmark's errors; the segments' disagreement is an honest floor (core/repeatability), for
// the time offset too.
// tz from stage 1 (not re-estimated per segment) is widened like roll and pitch, whose ground
// excitation it shares; stage 3's tz is absolute and keeps its own stddev.
// The widening is measured against stage 2's formal stddev, the estimator the segments repeat:
// against the trajectory correction's (wider, from another estimator) tz got no widening (3.1-3.4
// sigma off on real scans, bench/results/honest.md) and, mixed with stage 2's, yaw 20x too much.
void apply_repeatability(const RepeatabilityResult& rep, CalibrationResult& r) {
  const double tz_sd = r.stddev[2];
  Vec6 formal = r.stddev;
  if (r.trajectory.applied && r.refine)
    for (int i : {0, 1, 3, 4, 5})
      if (std::isfinite(r.refine->outcome.stddev[i])) formal[i] = r.refine->outcome.stddev[i];
  const double tz_inflation = ground_inflation(formal, rep);
  r.time_offset_stddev_s = time_offset_stddev_with_repeatability(r.time_offset_stddev_s, formal, rep);
  r.stddev = stddev_with_repeatability(r.stddev, formal, rep);
  r.stddev[2] = r.z.determined() || !r.rough.tz_estimated ? tz_sd : tz_sd * tz_inflation;
  if (!rep.warning.empty()) r.warnings.push_back(rep.warning);
}

// tz estimated by stage 1 alone: at least the INS's height error over the drive can hide in it.
double data_tz_stddev_m(const CalibrationResult& r, const ZConfig& z) {
  return std::max(r.stddev[2], z.ins_vertical_sigma_m);
}

// tz not fixed by stage 3: stage 2 held it where stage 1 left it, and absorbed its error in x and
// y (and a little in the rotation); their stddev carries tz's uncertainty (stage 1's, when it
// estimated tz, else the assumed one).
void carry_tz_uncertainty(const FrameStore& store, const std::vector<std::size_t>& frames, const PipelineConfig& config,
                          CalibrationResult& r) {
  const bool from_data = r.rough.tz_estimated && std::isfinite(r.stddev[2]);
  const double sd = from_data ? data_tz_stddev_m(r, config.z) : config.z.undetermined_tz_sigma_m;
  if (from_data) r.stddev[2] = sd;
  r.tz_coupling = tz_coupling(store, frames, r.T_ins_lidar, r.time_offset_s, r.refine->time_offset_estimated,
                              config.refine, sd);
  if (!r.tz_coupling.ok) return;
  for (int i : {0, 1}) r.stddev[i] = std::hypot(r.stddev[i], r.tz_coupling.stddev_added_m[i]);
  for (int i : {0, 1, 2}) r.stddev[3 + i] = std::hypot(r.stddev[3 + i], r.tz_coupling.rpy_stddev_added_rad[i]);
}

// The INS looks wrong: stretches left out, segments that disagree, a correction the drive needed.
// What the INS states about itself is a fact; what the LiDAR finds may also be a place it saw too
// little of (a frame sliding along a street it alone saw), so that advice says both.
void add_ins_advice(const CalibrationResult& r, std::vector<std::string>& advice) {
  std::vector<TimeSpan> stated, found;
  for (const TimeSpan& span : r.excluded) (span.source == SpanSource::kInsStatus ? stated : found).push_back(span);
  if (!stated.empty())
    advice.push_back(fmt::format("The INS states a degraded solution for {:.1f} s of the drive ({} stretches, left out): "
                                 "check its RTK status (fixed, not float) and its antenna.",
                                 spans_duration_s(stated), stated.size()));
  if (!found.empty())
    advice.push_back(fmt::format("The LiDAR finds the INS poses off for {:.1f} s of the drive ({} stretches, left out): "
                                 "the INS may have jumped there (check its RTK status); with RTK fixed throughout, the "
                                 "LiDAR saw too little there to place the frames.",
                                 spans_duration_s(found), found.size()));
  if (!r.repeatability.warning.empty() && r.repeatability.segments_ok >= 2)
    advice.push_back("Parts of the drive disagree on the extrinsic more than expected: check the INS's RTK status, "
                     "moving objects and the mount; the stddev includes the disagreement.");
  if (r.trajectory.applied)
    advice.push_back("The INS trajectory drifted and was corrected with the LiDAR: check the INS's RTK status; a drive "
                     "with RTK fixed throughout gives a tighter result.");
}

// The start's value of each held DOF (translations as they are, rotations as the roll, pitch and
// yaw of the change from the start), the rest from T.
Iso3 with_held_from(const Iso3& T, const Iso3& T_start, const std::array<bool, 6>& held) {
  Iso3 out = T;
  for (int i = 0; i < 3; ++i)
    if (held[static_cast<std::size_t>(i)]) out.translation()[i] = T_start.translation()[i];
  Vec3 rpy = rpy_from_rotation(T.linear() * T_start.linear().transpose());
  for (int i = 0; i < 3; ++i)
    if (held[static_cast<std::size_t>(3 + i)]) rpy[i] = 0.0;
  out.linear() = rotation_from_rpy(rpy) * T_start.linear();
  return out;
}

// Stage 1 left some DOFs undetermined: stop, or (config.hold_undetermined, and something is
// determined) hold them at the start's values for the later stages. The time offset is held with
// the lever arm: along the travel they move the map alike, and a lever arm held wrong would
// otherwise show as a wrong offset.
PipelineConfig hold_undetermined_dofs(const PipelineConfig& config, CalibrationResult& r) {
  if (r.rough.outcome.status != StageStatus::kUndetermined) return config;
  std::vector<std::string_view> names;
  for (int i : {0, 1, 3, 4, 5})
    if (!r.determined[i]) names.push_back(kDofNames[static_cast<std::size_t>(i)]);
  if (!config.hold_undetermined || names.size() == 5) stop_if_undetermined(r.rough.outcome);
  PipelineConfig held = config;
  for (int i : {0, 1, 3, 4, 5}) held.refine.held[static_cast<std::size_t>(i)] = !r.determined[i];
  const bool lever_arm = held.refine.held[0] || held.refine.held[1];
  if (lever_arm) held.refine.estimate_time_offset = false;
  r.T_ins_lidar = with_held_from(r.T_ins_lidar, r.init.T_ins_lidar, held.refine.held);
  r.warnings.push_back(fmt::format("this drive does not determine {}: held at the starting values{}, the rest measured",
                                   fmt::join(names, ", "), lever_arm ? " (the time offset with them)" : ""));
  return held;
}

}  // namespace

// The INS trajectory corrected jointly with the extrinsic: stage 2 takes the INS poses as exact,
// and a drifting INS biases it. Only the extrinsic is taken from it: stage 3 and the repeatability
// study keep the reported poses: fiducials are absolute and the correction's mean is a gauge
// choice (held by a 1 cm prior it walked 0.73 m and took stage 3's tz with it; it is pinned now:
// TrajectoryCorrection.CorrectedPosesKeepTheFiducialTz).
void run_trajectory_correction(const FrameStore& store, const std::vector<std::size_t>& refine_frames,
                               const PipelineConfig& config, const PipelineProgress& progress, CalibrationResult& r) {
  RefineConfig refine = config.refine;
  // The time offset stays stage 2's: along the travel it moves the map as the knots do, and
  // estimated with them its stddev came out 2.5x its error (median) on 150 simulated drifting
  // drives, for errors no smaller (bench/results/honest.md).
  refine.estimate_time_offset = false;
  if (config.trajectory.hold_lever_arm) refine.held[0] = refine.held[1] = true;
  progress("trajectory", 0.0);
  r.trajectory = correct_trajectory(store, r.T_ins_lidar, r.time_offset_s, config.trajectory, refine, &r.ins_screen,
                                    refine_frames);
  progress("trajectory", 1.0);
  const auto measured_drift = [&] {
    return random_walk_stddev(*r.refine, r.trajectory.correction_rms_axes_m,
                              r.trajectory.t_s.back() - r.trajectory.t_s.front());
  };
  const bool measured = r.refine && r.trajectory.t_s.size() >= 2;  // the correction was estimated
  if (!r.trajectory.applied) {
    // The answer stays stage 2's on the INS poses taken as exact, and every DOF of it carries the
    // slow INS error the correction measured: on real scans (BALM, an INS from LiDAR odometry)
    // a 53 mm RMS correction too weak to apply left yaw 0.13 deg off at a stated 0.04, and
    // `check` called the true extrinsic `drifted` (bench/results/check.md).
    if (measured) {
      const auto drift = measured_drift();
      for (int i : {0, 1, 3, 4, 5}) r.ins_drift_stddev[i] = drift[i];
      if (r.refine->time_offset_estimated) r.ins_drift_stddev[6] = drift[6];
    }
    return;
  }
  r.T_ins_lidar = r.trajectory.T_ins_lidar;
  r.time_offset_s = r.trajectory.time_offset_s;
  if (refine.estimate_time_offset) r.time_offset_stddev_s = r.trajectory.time_offset_stddev_s;
  for (int i : {0, 1, 3, 4, 5})
    if (!refine.held[static_cast<std::size_t>(i)]) r.stddev[i] = r.trajectory.outcome.stddev[i];
  // What the correction kept from stage 2 still carries the drift it measured: a 20 mm lever-arm
  // change read as 5-10 mm at a stated 4-7 mm on drifting drives (bench/results/check.md).
  // Added to the stddev, not a floor: the drift common to the whole drive is the part the
  // repeatability segments' spread cannot hold.
  if (measured) {
    const auto drift = measured_drift();
    for (int i = 0; i < 6; ++i)
      if (refine.held[static_cast<std::size_t>(i)]) r.ins_drift_stddev[i] = drift[i];
    if (!refine.estimate_time_offset) r.ins_drift_stddev[6] = drift[6];
  }
  r.warnings.push_back(r.trajectory.decision);
}

FrameStore make_frame_store(const Dataset& data, const PipelineConfig& config) {
  SweepFilter base = finest_of({config.init.filter, config.rough.filter, config.refine.filter});
  base.min_range_m = config.vehicle.body_radius_m;
  return FrameStore(data, base, config.frames);
}

void load_check_frames(const FrameStore& store, const PipelineConfig& config, double time_offset_s) {
  if (config.run_refine) store.load(refine_frames(store, config.refine, time_offset_s, refine_margin_s(config.refine)));
}

FrameStore screen_after_stage1(const FrameStore& store, const InsScreenResult& lidar_checks, const PipelineConfig& config,
                               CalibrationResult& r, FrameGroups& groups, const MovingPointsResult* moving) {
  r.ins_screen = with_lidar_checks(r.ins_screen, lidar_checks);
  FrameStore out = leave_out_spans(store, lidar_checks.spans);
  if (moving) r.moving = *moving;
  if (auto mask = moving ? moving->mask : find_moving_points(out, r.T_ins_lidar, r.time_offset_s, config.moving, r.moving))
    out = out.with_mask(mask);
  r.excluded = ins_spans(out.excluded());
  if (out.excluded().size() != store.excluded().size()) groups = rough_frame_groups(out, config.rough, r.time_offset_s);
  return out;
}

FrameGroups run_start(const FrameStore& store, const PipelineConfig& config, const PipelineProgress& progress,
                      CalibrationResult& r, bool stage1_may_fail) {
  const Dataset& data = store.data();
  // 0. Can this drive determine anything? Decided from the poses alone, before loading sweeps.
  r.motion = check_motion(store.poses(), data.frames.frames, config.motion);
  if (!r.motion.ok) throw UnobservableError(r.motion.explanation);

  // 1. Start: from the data, or the given initial guess checked against the data.
  progress("init", 0.0);
  r.init = initialise_extrinsic(store, data.T_ins_lidar_init, config.init, config.ins_height_m);
  // Its frames are not the stages' (the checks sample the stages' frames): their memory back.
  store.forget();
  progress("init", 1.0);
  stop_if_undetermined(r.init.outcome);
  if (r.init.source == InitSource::kDataOverridesInit) r.warnings.push_back(r.init.explanation);

  // 2. Stage 1.
  // Stage 1 places the sweeps with the time offset the start found (0 unless it is far from 0).
  r.time_offset_s = r.init.time_offset_s;
  FrameGroups groups = rough_frame_groups(store, config.rough, r.time_offset_s);
  RoughConfig rough = config.rough;
  rough.rounds = pipeline_rounds(rough, start_is_near(r.init), config.run_refine);
  r.rough = calibrate_rough(store, groups, r.init.T_ins_lidar, r.time_offset_s, rough,
                            [&](double f) { progress("rough", f); });
  if (!stage1_may_fail) stop_if_undetermined(r.rough.outcome);
  r.T_ins_lidar = r.rough.T_ins_lidar;
  r.determined = r.rough.outcome.determined;
  r.stddev = r.rough.outcome.stddev;
  return groups;
}

void run_finish(const FrameStore& placed, const FrameGroups& groups, const std::vector<std::size_t>& refine_frames,
                const PipelineConfig& config, const PipelineProgress& progress, CalibrationResult& r,
                const BesideRepeatability& beside, NearPoints* near) {
  // 4. Stage 3: tz from fiducials or the height prior; otherwise it stays undetermined.
  progress("z", 0.0);
  ZConfig z_config = config.z;  // a drifting INS's height error enters tz's stddev (core/tz_coupling)
  z_config.ins_vertical_sigma_m = ins_height_sigma_m(placed, config.z.ins_vertical_sigma_m);
  r.z = correct_z(placed, r.T_ins_lidar, r.time_offset_s, config.ins_height_m, z_config, near);
  progress("z", 1.0);
  r.T_ins_lidar = r.z.T_ins_lidar;
  r.determined[2] = r.z.determined() || r.rough.tz_estimated;  // evidence: finish_dof_status decides
  if (r.z.determined()) r.stddev[2] = r.z.tz_stddev_m();
  if (!r.determined[2]) r.stddev[2] = std::numeric_limits<double>::infinity();
  // Fiducials or a height given but unusable: why (finish_dof_status says where tz came from).
  if (r.z.outcome.status == StageStatus::kUndetermined) r.warnings.push_back(r.z.outcome.message);

  // 5. Repeatability: the segments start from the same start, with stage 3's tz (a wrong tz
  // biases the horizontal lever arm, see step 3). `beside` reads r meanwhile: the study's result
  // joins r only after both are done.
  const bool study = config.repeatability.segments > 1;
  RepeatabilityResult repeatability;
  auto run_study = [&] {
    if (!study) return;
    progress("repeatability", 0.0);
    RepeatabilityInputs in{groups, refine_frames, r.init.T_ins_lidar, r.T_ins_lidar, r.motion.max_speed_mps,
                           r.time_offset_s};
    if (r.z.determined()) in.T_ins_lidar_start.translation().z() = r.T_ins_lidar.translation().z();
    repeatability = run_repeatability(placed, in, config.rough, config.refine, config.repeatability);
    progress("repeatability", 1.0);
  };
  tbb::parallel_invoke(run_study, [&] {
    if (beside) beside(r);
  });
  if (study) {
    r.repeatability = std::move(repeatability);
    apply_repeatability(r.repeatability, r);
  }
  if (!r.z.determined() && r.refine) carry_tz_uncertainty(placed, refine_frames, config, r);
}

void add_ins_heading_error(const PipelineConfig& config, CalibrationResult& r) {
  r.ins_heading_sigma_rad = std::max(0.0, config.ins_heading_sigma_deg) * kRadPerDeg;
  if (std::isfinite(r.stddev[5])) r.stddev[5] = std::hypot(r.stddev[5], r.ins_heading_sigma_rad);
}

// The assumed slow error a floor, not a sum: part of it (its faster wander) the segments' spread
// already holds. The measured drift is added (run_trajectory_correction says why).
void add_ins_position_error(CalibrationResult& r) {
  if (!r.refine) return;
  for (int i : {0, 1, 3, 4, 5})
    if (std::isfinite(r.stddev[i]))
      r.stddev[i] = std::hypot(std::max(r.stddev[i], r.refine->ins_position_stddev[i]), r.ins_drift_stddev[i]);
  if (std::isfinite(r.time_offset_stddev_s))
    r.time_offset_stddev_s = std::hypot(r.time_offset_stddev_s, r.ins_drift_stddev[6]);
}

TzSource final_tz_source(const CalibrationResult& r) {
  if (r.z.determined()) return r.z.method == ZMethod::kFiducials ? TzSource::kFiducials : TzSource::kInsHeight;
  if (r.rough.tz_estimated) return TzSource::kData;
  return r.init.tz_source;
}

void finish_dof_status(const PipelineConfig& config, CalibrationResult& r, std::optional<TzSource> tz_source) {
  DofEvidence e;
  e.observed = r.determined;  // the stages' verdicts (stage 1, stage 3 or stage 1's tz; a rig's joint ones)
  e.stddev = r.stddev;
  e.tz_source = tz_source.value_or(final_tz_source(r));
  e.tz_m = r.T_ins_lidar.translation().z();
  if (r.tz_coupling.ok) {
    e.tz_assumed_sigma_m = r.tz_coupling.tz_sigma_m;
    e.dx_per_tz = r.tz_coupling.dxy_dtz.x();
    e.dy_per_tz = r.tz_coupling.dxy_dtz.y();
  }
  e.ins_drift_stddev = r.ins_drift_stddev.head<6>();
  const DofStatusResult status = decide_dof_status(e, config.status);
  r.determined = status.determined();
  r.stddev = status.stddev();
  r.tz_source = status.tz_source;
  r.advice = status.advice;
  add_ins_advice(r, r.advice);
  r.warnings.insert(r.warnings.begin(), r.advice.begin(), r.advice.end());
}

CalibrationResult run_calibration(const FrameStore& store, const PipelineConfig& config_in,
                                  const PipelineProgress& progress_in, const BesideRepeatability& beside) {
  const auto start = std::chrono::steady_clock::now();
  const PipelineProgress progress = [&](std::string_view step, double fraction) {
    if (progress_in) progress_in(step, fraction);
  };
  CalibrationResult r;
  const FrameStore status_screened = leave_out_status_spans(store, config_in.ins_screen, r.ins_screen);
  FrameGroups groups = run_start(status_screened, config_in, progress, r, config_in.hold_undetermined);  // steps 0-2
  const PipelineConfig config = hold_undetermined_dofs(config_in, r);
  // Bad INS stretches the LiDAR shows and points on moving things, found with stage 1's extrinsic
  // and left out of every later step (stage 2 picks its frames again after the checks, the same
  // ones but for those in a span left out).
  progress("screen", 0.0);  // decoding stage 2's frames is part of the checks' cost
  load_check_frames(status_screened, config, r.time_offset_s);
  const InsScreenResult checks = lidar_checks(status_screened, r.T_ins_lidar, r.time_offset_s, config.ins_screen);
  const FrameStore screened = screen_after_stage1(status_screened, checks, config, r, groups);
  progress("screen", 1.0);

  // 3. Stage 2 (with an early stage 3 first).
  const std::vector<std::size_t> refine_frames =
      config.run_refine ? insalign::refine_frames(screened, config.refine, r.time_offset_s, refine_margin_s(config.refine))
                        : std::vector<std::size_t>{};
  NearPoints near;  // stage 3 runs twice (before and after stage 2) on the same raw sweeps
  if (config.run_refine) run_refine(screened, refine_frames, config, progress, near, r);
  if (config.run_refine) run_trajectory_correction(screened, refine_frames, config, progress, r);
  const FrameStore& placed = screened;  // the poses the later steps use (the reported ones)

  run_finish(placed, groups, refine_frames, config, progress, r, beside, &near);  // steps 4-5
  add_ins_position_error(r);
  add_ins_heading_error(config, r);
  finish_dof_status(config, r);
  r.frames_decoded = store.frames_decoded();
  r.wall_time_s = seconds_since(start);
  return r;
}

}  // namespace insalign
