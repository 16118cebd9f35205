// Global initialisation, the LiDAR-to-INS time offset from afar: a LiDAR stamping its sweeps with
// the host's receive time, or a clock that is not synchronised, is tenths of a second off the INS,
// beyond stage 2's own search (+-time_offset_range_s around the start). The rotation angle between
// two registered sweeps equals the INS's rotation angle between the same instants whatever the
// extrinsic is (R_lidar = X^T R_ins X keeps the angle), and where the car's turning rate changes
// between the two sweeps the INS angle changes with the offset: the offset that makes the INS
// angles of the hand-eye pairs match the LiDAR's is the clock difference. (io/clock_alignment
// uses the same angles to choose among whole-second offsets before any stage runs.)
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "core/pose_stream.hpp"

namespace insalign {

struct CoarseTimeOffsetConfig {
  double range_s = 1.0;         ///< offsets searched within +- this, s (0: off); whole seconds beyond: io/clock_alignment
  double step_s = 0.0025;       ///< search step, s
  /// Offsets closer to 0 than this are left to stage 2's own search (it finds them more finely).
  double min_offset_s = 0.02;
  /// The offset is taken only when the pairs' median angle difference at 0 is at least this factor
  /// times the one at the offset and this much larger (deg): a drive without changing turns
  /// cannot tell offsets apart, and then 0 stays.
  double min_gain = 2.0;
  double min_gain_deg = 0.05;
  std::size_t min_pairs = 6;    ///< fewer registered pairs decide nothing
};

template <class V>
void visit_config(V& v, CoarseTimeOffsetConfig& c) {
  v("range_s", c.range_s, "LiDAR-to-INS time offsets searched within +- this from the rotation angles, s (0: off)");
  v("step_s", c.step_s, "search step, s");
  v("min_offset_s", c.min_offset_s, "smaller offsets are left to stage 2's search, s");
  v("min_gain", c.min_gain, "the angle difference at 0 must be this factor times the one at the offset");
  v("min_gain_deg", c.min_gain_deg, "...and this much larger, deg");
  v("min_pairs", c.min_pairs, "fewer registered pairs decide nothing");
}

/// One registered pair: its sweeps' times (LiDAR clock) and the LiDAR's rotation angle between them.
struct AnglePair {
  double t0_s = 0.0, t1_s = 0.0;
  double lidar_deg = 0.0;
};

struct CoarseTimeOffset {
  bool applied = false;           ///< best_offset_s is far enough from the reference and the data clearly prefers it
  double offset_s = 0.0;          ///< t_ins = t_lidar + offset_s (the reference when not applied)
  double best_offset_s = 0.0;     ///< the search's minimum, applied or not
  /// Median |LiDAR - INS angle| at the reference offset and at the best one.
  double median_at_reference_deg = 0.0, median_at_best_deg = 0.0;
  std::size_t pairs = 0;
  std::string explanation;
};

/// The offset within reference_s +- config.range_s whose INS angles match the pairs' LiDAR angles
/// best (median absolute difference), and whether the data is clear enough to take it instead of
/// reference_s (the offset already known: 0, or the installed one a check is given).
CoarseTimeOffset fit_time_offset(const std::vector<AnglePair>& pairs, const PoseStream& poses,
                                 const CoarseTimeOffsetConfig& config, double reference_s = 0.0);

}  // namespace insalign
