// Slow INS error must not become an extrinsic error: the extrinsic estimated together with a
// smooth correction of the INS trajectory. The position error of an INS that is not RTK fixed
// walks by centimetres over a drive; where the car passes the same walls twice those walls no
// longer meet, and the extrinsic that makes the map crispest is then biased (0.046 deg of yaw on
// a drive whose poses drift by 5 mm/sqrt(s)). Here the INS position error (and optionally its
// heading error) is a piecewise-linear function of time with knots every few seconds, kept
// smooth by a random-walk prior (knot differences ~ q sqrt(dt)), and estimated jointly with the
// extrinsic and the time offset by Gauss-Newton on stage 2's plane-thickness measure.
//
// What the data cannot tell apart, and how it is pinned:
// - a constant world shift of the whole trajectory: harmless; the corrections' mean is kept at
//   zero by a weak absolute prior;
// - a constant heading error is an extrinsic yaw error (T_world_ins Rz(d) T_ins_lidar): the
//   heading corrections' mean is kept at zero, so the INS's drive-mean heading error stays in
//   yaw (a floor no method removes);
// - a lever-arm error d moves each sweep by R(t) d, which a free position correction can mimic:
//   x and y are determined only through the prior (the turns make R(t) d change faster than the
//   INS can drift), so their standard deviation grows; rotations move points by range-dependent
//   amounts that no trajectory shift mimics.
#pragma once

#include <array>
#include <cstddef>
#include <span>
#include <string>
#include <vector>

#include "core/frame_store.hpp"
#include "core/geometry.hpp"
#include "core/ins_screen.hpp"
#include "core/pose_stream.hpp"
#include "core/refine.hpp"
#include "core/stage.hpp"

namespace insalign {

enum class TrajectoryCorrectionMode {
  kOff,     ///< the INS poses are taken as exact
  /// Estimated only when the drive shows that the INS drifts (drift_evidence: the INS's stated
  /// horizontal stddev growing along the drive or, where it states none, the frames sitting off
  /// the map of the drive's other times), then decided as kAuto. An RTK-fixed drive costs nothing
  /// and keeps off's answer; float episodes, outages and wrong fixes are left out by the screen and
  /// do not count as drift.
  kIfDrifting,
  kAuto,    ///< estimated always, applied only when the drive's evidence asks for it (see decide)
  kAlways,  ///< estimated and applied
};
inline constexpr std::array<std::pair<TrajectoryCorrectionMode, std::string_view>, 4> kTrajectoryCorrectionModeNames{
    {{TrajectoryCorrectionMode::kOff, "off"},
     {TrajectoryCorrectionMode::kIfDrifting, "if-drifting"},
     {TrajectoryCorrectionMode::kAuto, "auto"},
     {TrajectoryCorrectionMode::kAlways, "always"}}};
constexpr auto enum_names(TrajectoryCorrectionMode) { return std::span(kTrajectoryCorrectionModeNames); }

struct TrajectoryCorrectionConfig {
  TrajectoryCorrectionMode mode = TrajectoryCorrectionMode::kIfDrifting;
  /// if-drifting: the INS counts as drifting when its stated horizontal stddev rises above its
  /// best on the drive by at least this (RMS over the samples not left out, m). A walk of
  /// 5 mm/sqrt(s) over 108 s states ~37 mm; an RTK-fixed INS states a constant ~1 cm (0).
  double drifting_min_stated_growth_m = 0.01;
  /// if-drifting where the INS states no accuracy (TUM, OpenCalib pose files): the INS counts as
  /// drifting when the median frame offset from the map of the drive's other times (the INS
  /// screen's map-residual check, frames left out excluded) is at least this, m. Measured
  /// (bench/results/honest.md): RTK fixed (1 cm / 1.5 cm Gauss-Markov, 30 s) 28-32 mm, perfect
  /// poses 2-5 mm, a 5 mm/sqrt(s) walk over 108 s 28-66 mm (7 of 8 above): the two overlap. An
  /// RTK drive above it costs the correction's time (auto's decision still applies); a drifting
  /// one below it gets off's answer.
  double drifting_min_map_offset_m = 0.033;
  double knot_spacing_s = 1.0;            ///< knots of the correction, INS seconds
  /// Assumed random walk of the INS position per axis where the INS states nothing better; the
  /// stated standard deviations (Dataset::ins_quality) add their change between knots.
  double drift_m_per_sqrt_s = 0.005;
  bool estimate_heading = false;          ///< also a heading correction (about the world vertical)
  /// Keep stage 2's horizontal lever arm (the correction then moves the rotation only). Estimated,
  /// the lever arm is decided by the random-walk prior alone along the direction the knots mimic
  /// it (see remove_data_modes); before that, the data's errors decided it and put tx 20-120 mm
  /// off at a stated 4-7 mm on one-way city loops. The time offset always stays stage 2's.
  bool hold_lever_arm = false;
  double heading_drift_deg_per_sqrt_s = 0.002;  ///< its random-walk prior
  /// Points of one plane seen from one sweep share their errors (range bias, the sweep's pose):
  /// the data term counts as this many times fewer independent points against the prior.
  double point_correlation = 20.0;
  std::size_t max_frames = 240;           ///< frames spread over the drive's motion (stage 2's and between them)
  SweepFilter filter{.min_range_m = 0.0, .max_range_m = 60.0, .voxel_m = 0.2, .max_points = 5000};
  int max_iterations = 10;
  int refit_iterations = 3;               ///< iterations that re-find the local planes
  /// kAuto applies the correction when the trajectory it found moves the map by more than this
  /// (RMS over the frames of the correction's time-varying part, m) ...
  /// Measured: an RTK-fixed drive (gate seed 21) 15 mm and 5-7% thinner, where applying it cost
  /// x 1.1 -> 4.4 mm; drifting drives (5 mm/sqrt(s), recorded trajectory) 31-37 mm and ~27%.
  double apply_min_rms_m = 0.025;
  /// ... and it lowers the plane-thickness cost by at least this fraction ...
  double apply_min_gain = 0.15;
  /// ... and on no axis is it more than this many times what its own random-walk prior expects
  /// (prior_rms_axes_m). A correction far beyond the INS's drift is the LiDAR fitting something
  /// else: a vertical ramp of 1.7 m over a 3-minute city drive (prior: 27 mm RMS) left a
  /// left-mounted HDL-32's pitch 0.157 deg off where the uncorrected run was 0.001 off.
  double max_prior_ratio = 4.0;
};

template <class V>
void visit_config(V& v, TrajectoryCorrectionConfig& c) {
  v("mode", c.mode,
    "off, if-drifting (estimated when the drive shows the INS drifts: its stated stddev grows or, where it states none, "
    "its frames sit off the map of other times; then as auto), auto (estimated, applied when the drive's own evidence "
    "asks for it) or always");
  v("drifting_min_stated_growth_m", c.drifting_min_stated_growth_m,
    "if-drifting: the INS drifts when its stated horizontal stddev grows at least this above its best, m");
  v("drifting_min_map_offset_m", c.drifting_min_map_offset_m,
    "if-drifting where the INS states no stddev: the INS drifts when frames sit this far off the map of other times "
    "(median), m");
  v("knot_spacing_s", c.knot_spacing_s, "knots of the INS trajectory correction, s");
  v("drift_m_per_sqrt_s", c.drift_m_per_sqrt_s, "assumed INS position random walk per axis (prior), m/sqrt(s)");
  v("estimate_heading", c.estimate_heading, "also correct the INS heading (its drive mean stays in yaw)");
  v("hold_lever_arm", c.hold_lever_arm,
    "keep stage 2's horizontal lever arm; the correction moves the rotation only");
  v("heading_drift_deg_per_sqrt_s", c.heading_drift_deg_per_sqrt_s, "assumed INS heading random walk (prior), deg/sqrt(s)");
  v("point_correlation", c.point_correlation, "points per independent observation, weighing the data against the prior");
  v("max_frames", c.max_frames, "frames spread over the drive's motion: stage 2's and as many between them as fit");
  v.section("filter", c.filter);
  v("max_iterations", c.max_iterations, "Gauss-Newton iterations at most");
  v("refit_iterations", c.refit_iterations, "iterations that re-find the local planes before freezing them");
  v("apply_min_rms_m", c.apply_min_rms_m, "auto: apply when the correction's time-varying part has at least this RMS, m (not asked when the INS states its drift)");
  v("apply_min_gain", c.apply_min_gain, "auto: ...and lowers the plane-thickness cost by at least this fraction");
  v("max_prior_ratio", c.max_prior_ratio,
    "auto: ...and is on no axis more than this many times the RMS its random-walk prior expects");
}

struct TrajectoryCorrection {
  /// kSkipped: off or too few frames; kOk: estimated (applied says whether it was used).
  /// stddev: of the joint extrinsic (m, rad; tz +inf), the corrections marginalised.
  StageOutcome outcome;
  bool applied = false;
  std::string decision;                 ///< why it was (not) applied, in plain words
  std::vector<double> t_s;              ///< knot times, INS clock
  std::vector<Vec3> position_m;         ///< world frame: corrected position = reported + this
  std::vector<double> heading_rad;      ///< corrected R_world_ins = Rz(this) * reported (empty: none)
  Iso3 T_ins_lidar = Iso3::Identity();  ///< the joint estimate
  double time_offset_s = 0.0;
  double time_offset_stddev_s = 0.0;
  double cost_ins_rms_m = 0.0;          ///< plane thickness RMS with the INS poses, at the joint extrinsic
  double cost_corrected_rms_m = 0.0;    ///< ... and with the corrected poses
  double correction_rms_m = 0.0;        ///< RMS over the frames of the corrections minus their mean
  Vec3 correction_rms_axes_m = Vec3::Zero();  ///< the same per world axis
  /// What the random-walk prior expects of that RMS per axis: sqrt(V / 6), V the prior's
  /// variance summed over the drive (a walk's variance about its own mean averages V/6).
  Vec3 prior_rms_axes_m = Vec3::Zero();
  std::size_t frames_used = 0, points_used = 0;
  int iterations = 0;

  Vec3 position_at(double t_s) const;   ///< interpolated (constant beyond the knots)
  double heading_at(double t_s) const;
};

/// What the random-walk prior expects of the correction's RMS about its mean, per world axis (m):
/// sqrt(V / 6), V the prior's variance (add_priors: the larger of drift_m_per_sqrt_s^2 per second
/// and the growth of the INS's stated variance) summed over the knots of s.
Vec3 prior_rms_axes_m(const TrajectoryCorrection& s, const TrajectoryCorrectionConfig& config,
                      const std::vector<InsQuality>& quality);

/// Sets s.applied and s.decision from the mode, the drive's evidence (apply_min_rms_m,
/// apply_min_gain) and the correction's plausibility against its prior (max_prior_ratio).
/// ins_states_drift: the INS's own stated accuracy says it drifts (if-drifting's evidence); the
/// correction's size then need not show it again, only the map getting thinner.
void decide_application(const TrajectoryCorrectionConfig& config, TrajectoryCorrection& s,
                        bool ins_states_drift = false);

/// How far the INS's stated horizontal stddev grows above its best value on the drive: RMS over
/// the samples outside the store's left-out spans of sqrt(stated^2 - best^2), m; 0 when the INS
/// states nothing.
double stated_drift_rms_m(const FrameStore& store);

/// if-drifting's verdict: does the INS drift on this drive? From what the INS states where it states
/// a horizontal stddev (stated_drift_rms_m), else from the LiDAR (map_offset_median_m).
struct DriftEvidence {
  bool stated = false;    ///< the INS states its accuracy: value_m is stated_drift_rms_m
  bool measured = false;  ///< else the map-residual check measured frames: value_m is their median offset
  double value_m = 0.0;
  bool drifting = false;
  std::string message;    ///< the verdict and its numbers, in plain words
};
DriftEvidence drift_evidence(const FrameStore& store, const InsScreenResult& screen,
                             const TrajectoryCorrectionConfig& config);

/// Median offset of the frames from the map of the drive's other times (the screen's map-residual
/// check, beyond its drive-wide part), over the frames it measured that are neither flagged nor
/// in a span the screen found, m; NaN when it measured fewer than 10. A drifting INS misplaces each
/// frame by its error's change since the other passes (a 5 mm/sqrt(s) walk: centimetres); an
/// RTK-fixed one by its noise.
double map_offset_median_m(const InsScreenResult& screen);

/// The INS trajectory with the correction applied at every pose.
PoseStream corrected_poses(const PoseStream& poses, const TrajectoryCorrection& correction);

/// Estimates the correction and the extrinsic jointly from a start near the optimum (stage 2's
/// result). Local planes follow `refine` (plane_voxel_m etc.); tz and, unless
/// refine.estimate_time_offset, the offset stay fixed. `ins_quality`: the INS's stated stddevs.
/// `screen`: the INS screen's findings, if-drifting's evidence where the INS states nothing
/// (none: such a drive counts as not drifting). `around`: stage 2's frames, if any: the correction
/// then takes them and as many again between them as config.max_frames allows (they are decoded
/// already: half its decoding saved), else its own config.max_frames spread over the drive.
TrajectoryCorrection correct_trajectory(const FrameStore& store, const Iso3& T_ins_lidar_start,
                                        double time_offset_start_s, const TrajectoryCorrectionConfig& config,
                                        const RefineConfig& refine, const InsScreenResult* screen = nullptr,
                                        const std::vector<std::size_t>& around = {});

}  // namespace insalign
