// The informative stretches of an ordinary drive, from the INS poses alone: a check looks at
// turns (yaw, roll, the lever arm, the time offset), accelerations and braking (pitch) and slopes,
// and leaves the rest of a long drive undecoded, so a 30-minute drive costs about what a
// 3-minute one does. The stages then spread their frames over the chosen stretches only, which
// keeps neighbouring frames close enough to overlap (120 frames over 20 km of highway would not).
#pragma once

#include <string>
#include <vector>

#include "core/frame_store.hpp"
#include "core/pose_stream.hpp"

namespace insalign {

struct StretchConfig {
  /// Stretches are whole windows of this length; 30 s holds a turn with its approach and exit.
  double window_s = 30.0;
  /// At most this much drive is used; a shorter drive is used whole. 150 s of 20 s windows left
  /// ty and roll undecided on a 10-minute city drive that 300 s of 30 s windows decided
  /// (bench/results/check.md); the stages decode about as many sweeps either way.
  double budget_s = 300.0;
  /// Score of a window: its turned angle (rad) + this x its RMS longitudinal acceleration (m/s^2)
  /// + slope_weight x its pitch range (rad).
  double accel_weight = 0.5;
  double slope_weight = 10.0;
  /// Windows slower than this on average (standing at a light) score 0.
  double min_speed_mps = 1.0;
};

template <class V>
void visit_config(V& v, StretchConfig& c) {
  v("window_s", c.window_s, "check: stretches are windows of this length, s");
  v("budget_s", c.budget_s, "check: at most this much of the drive is used (a shorter drive whole), s");
  v("accel_weight", c.accel_weight, "check: window score = turned rad + this x RMS acceleration (m/s2) + ...");
  v("slope_weight", c.slope_weight, "check: ... + this x pitch range (rad)");
  v("min_speed_mps", c.min_speed_mps, "check: windows slower than this on average score 0, m/s");
}

/// A stretch of INS time and what makes it informative.
struct Stretch {
  double begin_s = 0.0, end_s = 0.0;  ///< INS clock
  double score = 0.0;
  std::string why;                    ///< "turn 91 deg right", "braking 1.9 m/s2", ...
};

/// The chosen stretches, time order, adjacent windows merged, over [t_begin_s, t_end_s] (INS
/// clock). The best left turn and the best right turn first (yaw and the lever arm need both),
/// then by score, until budget_s. The whole span when it is no longer than budget_s.
std::vector<Stretch> informative_stretches(const PoseStream& poses, double t_begin_s, double t_end_s,
                                           const StretchConfig& config = {});

/// The store with everything outside the stretches left out (the stages never offer those frames).
FrameStore keep_stretches(const FrameStore& store, const std::vector<Stretch>& stretches);

}  // namespace insalign
