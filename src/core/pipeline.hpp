// The whole calibration: motion check, start (global initialisation or a checked --init),
// stage 1 (rough), stage 2 (refine + time offset), stage 3 (z), and the repeatability study.
// Pure computation: the command line loads and writes.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/dataset.hpp"
#include "core/dof_status.hpp"
#include "core/frame_store.hpp"
#include "core/frames.hpp"
#include "core/global_init.hpp"
#include "core/ins_screen.hpp"
#include "core/motion_check.hpp"
#include "core/moving_points.hpp"
#include "core/observability.hpp"
#include "core/refine.hpp"
#include "core/repeatability.hpp"
#include "core/rough.hpp"
#include "core/trajectory_correction.hpp"
#include "core/tz_coupling.hpp"
#include "core/zcorrect.hpp"

namespace insalign {

struct PipelineConfig {
  VehicleConfig vehicle;
  FramesConfig frames;
  MotionCheckConfig motion;
  GlobalInitConfig init;
  RoughConfig rough;
  RefineConfig refine;
  TrajectoryCorrectionConfig trajectory;  ///< the INS trajectory corrected with the extrinsic
  InsScreenConfig ins_screen;             ///< bad INS stretches left out of every stage
  MovingPointsConfig moving;              ///< points on moving things left out of every stage
  ZConfig z;
  RepeatabilityConfig repeatability;
  DofStatusConfig status;                 ///< the final per-DOF verdict (core/dof_status)
  bool run_refine = true;                  ///< stage 2 (false: stop after stage 1)
  std::optional<double> ins_height_m;      ///< INS origin height above the ground, for stage 3
  /// The INS's heading error over the drive (1 sigma), deg: a heading error is an extrinsic yaw
  /// error no LiDAR data shows (it turns the map and the trajectory alike), so yaw's reported
  /// stddev includes it, as tz's includes the INS's height error. 0.01 deg: a high-grade
  /// RTK-aided INS in motion; set your INS's figure (its datasheet or its stated heading stddev).
  double ins_heading_sigma_deg = 0.01;
  /// A drive whose stage 1 determines some of tx, ty, roll, pitch and yaw but not all (a highway:
  /// the lever arm and roll): true holds the undetermined ones at the start's values through the
  /// later stages (reported not determined, with no stddev) and measures the rest; false stops
  /// with the reason. A check sets it (core/check_run); a calibration must determine every DOF.
  bool hold_undetermined = false;
};

template <class V>
void visit_config(V& v, PipelineConfig& c) {
  v("run_refine", c.run_refine, "run stage 2 (false: stop after stage 1)");
  v("ins_height_m", c.ins_height_m, "INS origin height above the ground for stage 3 when there are no fiducials, m (null: unknown)");
  v("ins_heading_sigma_deg", c.ins_heading_sigma_deg, "the INS's heading error over the drive (1 sigma), in yaw's reported stddev, deg");
  v("hold_undetermined", c.hold_undetermined,
    "hold the DOFs stage 1 cannot determine at the start's values and measure the rest (false: stop; check sets it)");
  v.section("vehicle", c.vehicle);
  v.section("frames", c.frames);
  v.section("motion", c.motion);
  v.section("init", c.init);
  v.section("rough", c.rough);
  v.section("refine", c.refine);
  v.section("trajectory", c.trajectory);
  v.section("ins_screen", c.ins_screen);
  v.section("moving", c.moving);
  v.section("z", c.z);
  v.section("repeatability", c.repeatability);
  v.section("status", c.status);
}

struct CalibrationResult {
  MotionCheck motion;
  GlobalInitResult init;
  RoughResult rough;
  std::optional<RefineResult> refine;
  /// After stage 2: the INS trajectory correction and the joint extrinsic; when applied, the
  /// result takes the joint extrinsic (stage 3 and the repeatability study keep the reported poses).
  TrajectoryCorrection trajectory;
  /// Bad INS stretches: the INS status spans (before any stage) and the LiDAR checks (after
  /// stage 1); `excluded` = every such span stages 2, 3 and the repeatability study left out
  /// (not the stretches `check` did not choose: check.json's `used` names what it chose).
  InsScreenResult ins_screen;
  std::vector<TimeSpan> excluded;
  MovingPointsResult moving;            ///< points on moving things, masked from stage 2 on
  ZResult z;
  TzCoupling tz_coupling;               ///< tz undetermined: its uncertainty carried into x and y
  RepeatabilityResult repeatability;
  Iso3 T_ins_lidar = Iso3::Identity();  ///< final estimate
  double time_offset_s = 0.0;           ///< t_ins = t_lidar + time_offset_s
  double time_offset_stddev_s = std::numeric_limits<double>::infinity();
  /// Final verdict per DOF [tx ty tz roll pitch yaw], decided in one place (finish_dof_status,
  /// core/dof_status): determined[i] exactly when stddev[i] is finite. tz is determined by stage 3
  /// (fiducials, --ins-height-m), or by stage 1 when the drive's roll and pitch excite it tightly.
  std::array<bool, 6> determined{};
  /// m, rad (+inf: not determined): the larger of the stages' formal value and, with the
  /// repeatability study, the segments' spread scaled to the whole drive.
  Vec6 stddev = Vec6::Constant(std::numeric_limits<double>::infinity());
  TzSource tz_source = TzSource::kGuess;  ///< where the final tz came from
  /// What the user should know first, one sentence each with what to do: DOFs not determined or
  /// weak, an INS that looks wrong. Also in `warnings` (after them).
  std::vector<std::string> advice;
  double ins_heading_sigma_rad = 0.0;  ///< the part of stddev[5] that is the INS's heading error
  /// The stddev (x y z m, roll pitch yaw rad, time offset s) that the INS drift the applied
  /// trajectory correction measured leaves in the DOFs it kept from stage 2 (estimated on the
  /// reported, drifting poses; trajectory.hold_lever_arm): a random walk of the correction's RMS
  /// per axis through stage 2's sensitivity. Zero elsewhere. Added to stddev in quadrature.
  Eigen::Matrix<double, 7, 1> ins_drift_stddev = Eigen::Matrix<double, 7, 1>::Zero();
  std::vector<std::string> warnings;
  std::size_t frames_decoded = 0;       ///< sweeps decoded by the whole run (each at most once)
  double wall_time_s = 0.0;
};

/// step: a short name ("rough", "refine", ...); fraction of that step done in [0, 1].
using PipelineProgress = std::function<void(std::string_view step, double fraction)>;

/// The store every stage reads: the frames thinned once by the finest filter any stage uses.
FrameStore make_frame_store(const Dataset& data, const PipelineConfig& config);

/// Steps 0-2 of run_calibration (motion check, start, stage 1) filling `r`; returns stage 1's
/// frame groups. Throws as run_calibration does, except for an undetermined stage 1 when
/// stage1_may_fail (a rig's joint stage 2 may still determine it: r.rough.outcome says so).
FrameGroups run_start(const FrameStore& store, const PipelineConfig& config, const PipelineProgress& progress,
                      CalibrationResult& r, bool stage1_may_fail = false);
/// Decodes stage 2's frames (config.run_refine) for the checks after stage 1: they sample the
/// decoded frames, so they check the frames stage 2 will take and those stage 1 read.
void load_check_frames(const FrameStore& store, const PipelineConfig& config, double time_offset_s);
/// After stage 1, the store every later step reads: the spans `lidar_checks` found left out (INS
/// time: a rig's reference LiDAR's checks serve every LiDAR on the INS) and the points on moving
/// things masked (config.moving, found with r's stage-1 extrinsic and time offset). r.ins_screen,
/// r.moving and r.excluded record them; stage 1's `groups` are picked again without the spans
/// (the repeatability study's stage 1 leaves them out too). `moving`: the mask found already (a
/// rig's, find_moving_points over its LiDARs), taken instead of one found here.
FrameStore screen_after_stage1(const FrameStore& store, const InsScreenResult& lidar_checks, const PipelineConfig& config,
                               CalibrationResult& r, FrameGroups& groups, const MovingPointsResult* moving = nullptr);
/// After stage 2 (r.refine set): the INS trajectory corrected jointly with the extrinsic, as
/// config.trajectory decides (r.ins_screen: the drift evidence). Applied, r takes the correction's
/// extrinsic and stddevs; either way r.ins_drift_stddev holds the drift it measured where r keeps
/// the INS poses as exact. r.trajectory records it.
void run_trajectory_correction(const FrameStore& store, const std::vector<std::size_t>& refine_frames,
                               const PipelineConfig& config, const PipelineProgress& progress, CalibrationResult& r);
/// Yaw's stddev with the INS's heading error (config.ins_heading_sigma_deg) added: the last step,
/// after anything that compares LiDARs of one INS (their heading error is common).
void add_ins_heading_error(const PipelineConfig& config, CalibrationResult& r);
/// Each stddev at least stage 2's share of the INS's slow position error (RefineResult::
/// ins_position_stddev), then with the drift the trajectory correction measured added
/// (ins_drift_stddev): errors common to the drive, which the repeatability segments cannot show.
void add_ins_position_error(CalibrationResult& r);
/// The last step of every run (one LiDAR or each of a rig's): `determined`, `stddev`, `tz_source`
/// and `advice` from the stages' evidence (decide_dof_status), and the INS's own advice.
/// tz_source: where tz came from when the caller knows better (a rig LiDAR's tz from its anchor).
void finish_dof_status(const PipelineConfig& config, CalibrationResult& r, std::optional<TzSource> tz_source = {});
/// Stage 3's reference, else stage 1's estimate, else the start's (the init, --ins-height-m, a guess).
TzSource final_tz_source(const CalibrationResult& r);
/// Work that needs the final extrinsic but none of its stddevs (the report's maps), run beside the
/// repeatability study, which changes only stddevs and warnings: given the result before the study.
using BesideRepeatability = std::function<void(const CalibrationResult& r)>;

/// Steps 4-5 after stage 2: stage 3 on `placed` (the store whose poses the result uses) and the
/// repeatability study when config.repeatability asks for it, with `beside` run alongside.
/// `near`: the raw points the early stage 3 kept (correct_z).
void run_finish(const FrameStore& placed, const FrameGroups& groups, const std::vector<std::size_t>& refine_frames,
                const PipelineConfig& config, const PipelineProgress& progress, CalibrationResult& r,
                const BesideRepeatability& beside = {}, NearPoints* near = nullptr);

/// Runs everything on the store's frames. Throws UnobservableError (with which DOFs and why) when
/// the drive cannot determine the extrinsic; tz alone undetermined is not an error (it is reported).
CalibrationResult run_calibration(const FrameStore& store, const PipelineConfig& config,
                                  const PipelineProgress& progress = {}, const BesideRepeatability& beside = {});

}  // namespace insalign
