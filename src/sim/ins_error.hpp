// What is wrong with the simulated INS: a slow error model (bounded RTK-fixed error or a random
// walk) plus events on top (RTK float episodes, wrong fixes, GNSS outages), and what the INS
// states about itself (solution type and standard deviations). Numbers and their sources: the
// README section "Simulated INS errors" and the comments below.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/dataset.hpp"
#include "core/geometry.hpp"

namespace insalign::sim {

enum class InsErrorModel {
  /// NovAtel-class RTK fixed (the default, as before these models existed): white noise plus a
  /// bounded Gauss-Markov position error (1 cm horizontal, 1.5 cm vertical, 30 s correlation).
  kRtkFixed,
  /// Random walk in position and heading, exactly zero at the start of the drive: an INS whose
  /// GNSS solution is not RTK fixed drifts by centimetres over minutes.
  kDrift,
};

/// Settings of the INS error (SimConfig::ins_error). White noise (SimConfig::ins_noise_scale) is
/// added in every model. Events need a drive long enough to hold them away from its ends.
struct InsErrorConfig {
  InsErrorModel model = InsErrorModel::kRtkFixed;
  // kDrift. Position: 5 mm/sqrt(s) per axis (a few centimetres over a drive, issue 17). Heading:
  // the angle random walk of a tactical-grade gyro, Honeywell HG1700: 0.125 deg/sqrt(h) =
  // 0.0021 deg/sqrt(s) (about 0.03 deg after 4 minutes).
  double drift_horizontal_m_per_sqrt_s = 0.005;  ///< per horizontal axis
  double drift_vertical_m_per_sqrt_s = 0.005;
  double drift_heading_deg_per_sqrt_s = 0.002;
  // RTK float episodes: the position error ramps up to float_peak_m and back (a raised-cosine
  // bump) in a random direction; decimetres is what a float solution holds (NovAtel: RT-20
  // floating-ambiguity 20 cm CEP; RT-2 before fixing 25-40 cm).
  int float_episodes = 0;
  double float_peak_m = 0.3;
  double float_duration_s = 8.0;
  // Wrong fixes: ambiguities fixed to wrong integers, a jump of wrong_fix_jump_m held for the
  // duration and reported as a normal RTK fix (a wrong fix is, by definition, not flagged).
  int wrong_fixes = 0;
  double wrong_fix_jump_m = 0.5;
  double wrong_fix_duration_s = 5.0;
  // GNSS outages: the INS coasts; the position error grows quadratically to outage_error_m at the
  // end (a residual accelerometer bias of ~0.6 mg: 0.5 * 0.006 m/s^2 * (10 s)^2 = 0.3 m; the
  // HG1700 bias is 1 mg before in-run calibration), attitude drifts linearly to the given
  // magnitudes, and the error vanishes when the fix returns.
  int outages = 0;
  double outage_duration_s = 10.0;
  double outage_error_m = 0.3;
  double outage_tilt_deg = 0.02;     ///< roll and pitch error at the end of the outage
  double outage_heading_deg = 0.05;  ///< heading error at the end of the outage
};

/// "rtk-fixed" / "drift"; parse_ins_error_model returns false for an unknown name.
const char* ins_error_model_name(InsErrorModel model);
bool parse_ins_error_model(const std::string& name, InsErrorModel& out);

enum class InsEventKind { kFloatEpisode, kWrongFix, kOutage };
const char* ins_event_name(InsEventKind kind);  ///< "float_episode", "wrong_fix", "outage"

/// Ground truth of one event (INS clock).
struct InsEvent {
  InsEventKind kind = InsEventKind::kFloatEpisode;
  double t_begin_s = 0.0, t_end_s = 0.0;
  Vec3 error_m = Vec3::Zero();  ///< float: at mid-episode; wrong fix: the jump; outage: at the end
  Vec3 rpy_error_rad = Vec3::Zero();  ///< outage: world-frame roll, pitch, yaw error at the end
};

/// Slow position error sampled at knots, interpolated linearly, constant outside the knots.
struct InsDrift {
  double t0_s = 0.0, knot_spacing_s = 1.0;
  std::vector<Vec3> knots_m;
  Vec3 at(double t_s) const;
};

/// Random walk of position and heading, zero at t0_s and before.
struct InsWalk {
  InsDrift position;               ///< knots_m[0] = 0
  std::vector<double> heading_rad; ///< same knots, heading_rad[0] = 0
  double heading_at(double t_s) const;
};

/// The bounded RTK-fixed error (Gauss-Markov, stationary from the first knot) over [t0, t1].
InsDrift make_rtk_fixed_drift(double noise_scale, double t0_s, double t1_s, std::uint64_t seed);
InsWalk make_walk(const InsErrorConfig& config, double t0_s, double t1_s, std::uint64_t seed);
/// Events at random times in [t_begin, t_end], at least a margin from both ends and apart from
/// each other. Throws std::invalid_argument when they do not fit.
std::vector<InsEvent> place_ins_events(const InsErrorConfig& config, double t_begin_s, double t_end_s,
                                       std::uint64_t seed);

/// An event's contribution at t (zero outside [t_begin, t_end)).
Vec3 event_position_error(const InsEvent& event, double t_s);
Vec3 event_rpy_error_rad(const InsEvent& event, double t_s);

/// What the INS reports: RTK fixed normally with stddevs of its error model (`normal_*`), RTK
/// float during float episodes (0.1-0.3 m horizontal at the default peak), RTK fixed with the
/// normal stddev during a wrong fix, INS-only with growing stddev during an outage.
InsQuality event_quality(const std::vector<InsEvent>& events, double t_s, double normal_horizontal_m,
                         double normal_vertical_m);

/// Throws std::invalid_argument for values out of range.
void validate_ins_error(const InsErrorConfig& config);

}  // namespace insalign::sim
