// The repeatability study: the drive cut into disjoint time segments, each calibrated alone
// (stage 2 on the segment's frames only, from the full run's result; RepeatabilityConfig), so
// that the spread of the results shows, without ground truth, how well the drive pins the
// extrinsic down. Segments use the full run's own frames
// (the part of its selections inside their time span) from the same store, so they decode
// nothing again, and they run in parallel.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "core/frame_store.hpp"
#include "core/refine.hpp"
#include "core/rough.hpp"

namespace insalign {

struct RepeatabilityConfig {
  int segments = 3;            ///< disjoint time segments; 0 or 1: off
  /// Stage-1 rounds a segment runs before its stage 2: the schedule's last ones, from the full
  /// run's result. 0: none, stage 2 alone from the full run's result (as a rig's segments run; a
  /// segment without stage-2 frames still runs the last round): the spread was the same as with
  /// one round to three digits, and coverage unchanged, for half the study's time
  /// (bench/RESULTS.md). -1: the whole schedule from the run's start (3x the stage-1 work).
  int rough_rounds = 0;
  double warn_rot_deg = 0.1;   ///< a spread (max - min) above this is a warning
  double warn_trans_m = 0.02;
};

template <class V>
void visit_config(V& v, RepeatabilityConfig& c) {
  v("segments", c.segments, "disjoint drive segments calibrated on their own to show the spread (0 or 1: off)");
  v("rough_rounds", c.rough_rounds,
    "stage-1 rounds per segment before its stage 2, the schedule's last, from the full result (0: none; -1: all, from the start)");
  v("warn_rot_deg", c.warn_rot_deg, "segment spread (max - min) above this is a warning, deg");
  v("warn_trans_m", c.warn_trans_m, "segment spread (max - min) above this is a warning, m");
}

/// One segment.
struct SegmentResult {
  double t_begin_s = 0.0, t_end_s = 0.0;  ///< LiDAR clock
  std::size_t frames = 0;
  bool ok = false;                        ///< false: the segment alone could not be calibrated
  std::string message;                    ///< why not
  Iso3 T_ins_lidar = Iso3::Identity();
  double time_offset_s = 0.0;
};

struct RepeatabilityResult {
  std::vector<SegmentResult> segments;
  int segments_ok = 0;
  /// max - min over the segments that succeeded [tx ty tz roll pitch yaw], m and rad (rotations
  /// relative to the full result, in the INS frame); tz 0 (not estimated per segment).
  Vec6 spread = Vec6::Zero();
  /// What the spread says of the whole drive's one-sigma error: range / (d_n sqrt(n)) for n
  /// segments (the expected range of n normal samples is d_n sigma, and a segment has 1/n of the
  /// data). +inf where fewer than two segments succeeded.
  Vec6 stddev_whole_drive = Vec6::Constant(std::numeric_limits<double>::infinity());
  /// The same for the time offset, s (the segments' stage 2 estimates it when the run's did; 0
  /// when it did not, and +inf with fewer than two segments).
  double time_offset_stddev_whole_drive_s = std::numeric_limits<double>::infinity();
  std::string warning;                    ///< a spread above the config's limits, or too few segments
  double wall_time_s = 0.0;
};

struct RepeatabilityInputs {
  FrameGroups rough_groups;               ///< the full run's stage-1 groups
  std::vector<std::size_t> refine_frames; ///< the full run's stage-2 frames (empty: no stage 2)
  Iso3 T_ins_lidar_start = Iso3::Identity();
  Iso3 T_ins_lidar_full = Iso3::Identity();  ///< the full run's result (rotations are relative to it)
  double max_speed_mps = 0.0;
  double time_offset_full_s = 0.0;           ///< the full run's time offset
};

/// The whole drive's stddev per unit of the spread (largest - smallest) of `segments` segment
/// results: 1 / (d_n sqrt(n)), d_n the mean range of n normal draws (n above 5: 5's).
double whole_drive_stddev_per_spread(int segments);

/// The stddev to report from the formal one (m, rad; the stages' least-squares value) and the
/// segments': per DOF the largest of the formal stddev, the segments' stddev_whole_drive, and the
/// formal stddev times the segments' typical inflation. A spread from 3 segments has 2 degrees
/// of freedom and comes out near 0 by chance (seen: y 0.19 mm for an error of 0.9 mm); how far
/// the formal stddev underestimates (residuals are correlated, not independent) is a property of
/// the drive, pooled over DOFs: the geometric mean of stddev_whole_drive / formal, over all five
/// DOFs and over those of the DOF's kind (x, y, yaw: the turns; roll, pitch: the ground), the
/// larger of the two, divided by the geometric mean's known shortfall for that many segments.
/// DOFs without a finite segment value keep their formal stddev.
Vec6 stddev_with_repeatability(const Vec6& formal, const RepeatabilityResult& repeatability);

/// The same where the result came from another estimator than the one the segments repeat (the
/// INS trajectory correction after stage 2): the inflation is measured against and applied to
/// `segments_formal` (stage 2's formal stddev), the result's own `formal` stays a floor. Pooling
/// one estimator's stddev with the other's (x from stage 2, yaw from the correction) came out
/// 20x too wide.
Vec6 stddev_with_repeatability(const Vec6& formal, const Vec6& segments_formal, const RepeatabilityResult& repeatability);

/// The time offset's stddev to report from its formal one (s) by the same rule as x, y and yaw
/// (the turns determine it too): the largest of the formal stddev, the segments' whole-drive
/// stddev, and the formal one times the turns' inflation (`formal`: the six DOFs' formal stddev).
/// The formal value alone came out 10-100x below the errors (bench/results/check.md). A formal
/// stddev that is not finite (the offset not estimated) is returned as is.
double time_offset_stddev_with_repeatability(double formal_s, const Vec6& formal, const RepeatabilityResult& repeatability);

/// The factor stddev_with_repeatability widens roll and pitch by (at least 1): for a DOF the
/// segments do not estimate but the same ground excitation determines (stage 1's tz).
double ground_inflation(const Vec6& formal, const RepeatabilityResult& repeatability);

RepeatabilityResult run_repeatability(const FrameStore& store, const RepeatabilityInputs& inputs,
                                      const RoughConfig& rough, const RefineConfig& refine,
                                      const RepeatabilityConfig& config);

}  // namespace insalign
