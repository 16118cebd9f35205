// Whole-second clock differences between a LiDAR and its INS, found from the data.
//
// A LiDAR stamping UTC and an INS stamping GPS time differ by 18 s (TAI-UTC 37 s, TAI-GPS 19 s, a
// time zone: whole quarter hours). When the ranges still overlap (18 s on a 5 minute drive) the
// ranges alone cannot tell, but the motion can: the rotation angle between two LiDAR sweeps
// (scan-to-scan registration) equals the INS's rotation angle between the same instants whatever
// the extrinsic is (R_lidar = X^T R_ins X keeps the angle). For a handful of frame pairs where the
// candidate offsets disagree most (turns), the LiDAR angles are compared with the INS angles at
// each candidate offset: 0 and the known offsets that keep most frames inside the INS range. The
// clear winner is taken and the evidence reported; an offset is never applied without it.
//
// Rules (align_clocks), the same words as the recordings' clock check (input/bag_dataset.hpp):
//   - no candidate keeps min_inside_fraction of the frames inside the INS range: ClockGapError
//     with both ranges, the gap between their middles and whether it is a known whole-second one;
//   - only 0 fits, or 0 fits and both ends of the ranges agree within 2 s: the clocks agree
//     (no sweep is decoded);
//   - otherwise the data decides among the fitting candidates; if it cannot (no turns), 0 is kept
//     with a warning when it fits, else ClockGapError.
#pragma once

#include <cstddef>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "core/dataset.hpp"
#include "core/pose_stream.hpp"

namespace insalign::io {

struct ClockCheckConfig {
  bool enabled = true;                ///< false: never decode sweeps; the clocks agree if 0 fits
  double min_inside_fraction = 0.5;   ///< a candidate must keep this fraction of the frames inside the INS range
  double pair_gap_s = 0.5;            ///< time between the two sweeps of a pair, s
  std::size_t pairs = 12;             ///< frame pairs registered
  double target_voxel_m = 0.4;        ///< registration target (first sweep) voxel centroids, m
  double source_voxel_m = 0.8;        ///< registration source (second sweep) voxel centroids, m
  double body_radius_m = 2.5;         ///< nearer points (the car) dropped, m
  double max_match_deg = 0.5;         ///< the winner's median |LiDAR - INS angle| must be below this, deg
  double min_ratio = 3.0;             ///< every other candidate's median at least this x the winner's (and > max_match_deg)
};

template <class V>
void visit_config(V& v, ClockCheckConfig& c) {
  v("enabled", c.enabled, "compare LiDAR and INS rotations to detect whole-second clock offsets (false: assume none)");
  v("min_inside_fraction", c.min_inside_fraction, "a candidate offset must keep this fraction of the frames inside the INS range");
  v("pair_gap_s", c.pair_gap_s, "time between the two sweeps of a compared pair, s");
  v("pairs", c.pairs, "frame pairs registered to compare rotation angles");
  v("target_voxel_m", c.target_voxel_m, "registration target (first sweep of a pair) voxel, m");
  v("source_voxel_m", c.source_voxel_m, "registration source (second sweep) voxel, m");
  v("body_radius_m", c.body_radius_m, "points nearer the LiDAR than this are dropped before registration, m");
  v("max_match_deg", c.max_match_deg, "the chosen offset's median angle difference must be below this, deg");
  v("min_ratio", c.min_ratio, "every other candidate's median difference must be at least this times the chosen one's");
}

/// One candidate offset and how well the INS rotation at it matches the LiDAR's.
struct ClockCandidate {
  double offset_s = 0.0;      ///< t_ins = t_lidar + offset_s
  std::string meaning;        ///< "the clocks agree", "GPS - UTC (18 leap seconds): ..."
  double inside_fraction = 0.0;  ///< frames inside the INS range at this offset
  std::size_t pairs = 0;      ///< pairs compared at this offset
  double median_diff_deg = std::numeric_limits<double>::quiet_NaN();  ///< median |LiDAR - INS angle|
};

/// A registered frame pair: the LiDAR's rotation angle and the INS's at each candidate (NaN where
/// the candidate puts the pair outside the INS range).
struct ClockPair {
  std::string frame_a, frame_b;
  double t_a_s = 0.0, t_b_s = 0.0;  ///< LiDAR clock
  double lidar_deg = 0.0;
  std::vector<double> ins_deg;      ///< per candidate
};

struct ClockAlignment {
  double offset_s = 0.0;  ///< decided: t_ins = t_lidar + offset_s; the INS poses are shifted by -offset_s
  std::string meaning;    ///< of offset_s
  bool checked_by_data = false;
  double lidar_begin_s = 0.0, lidar_end_s = 0.0;  ///< LiDAR clock
  double ins_begin_s = 0.0, ins_end_s = 0.0;      ///< INS clock, before the shift
  double inside_fraction = 0.0;                   ///< frames inside the INS range before the shift
  std::vector<ClockCandidate> candidates;         ///< those that fit the ranges
  std::vector<ClockPair> pairs;
  std::string decision;  ///< the decision in words ("the clocks agree (...)", "the INS clock is 18 s ahead ...")
  std::string summary;   ///< ranges and the decision, one line
  std::string evidence;  ///< the data's verdict, one line ("" when no sweep was compared)
  std::vector<std::string> warnings;
};

/// Decides the whole-second offset between the frames' clock and the poses' (see the top).
/// `file` names the pose source in errors. Throws ClockGapError (an InputError).
ClockAlignment align_clocks(const FrameSource& frames, const PoseStream& poses, const ClockCheckConfig& config,
                            const std::string& file);

/// Checks a correction made already (a recording whose stamps differ by `applied_s`, with the
/// poses shifted by -applied_s): the corrected poses (offset 0, `meaning`) against the uncorrected
/// ones (offset -applied_s), by the data. Throws ClockGapError when the data contradicts it.
ClockAlignment confirm_clock_correction(const FrameSource& frames, const PoseStream& corrected_poses, double applied_s,
                                        const std::string& meaning, const ClockCheckConfig& config,
                                        const std::string& file);

/// A known offset (input.clock_offset_s), taken without a check. Throws ClockGapError when it
/// leaves no frame inside the INS range.
ClockAlignment given_clock_offset(const FrameSource& frames, const PoseStream& poses, double offset_s,
                                  const std::string& file);

/// The poses with every time shifted by shift_s (quality too).
PoseStream shifted_poses(const PoseStream& poses, double shift_s);

/// "+18 s (GPS - UTC ...)": the offset as the user reads it.
std::string describe_offset(double offset_s, const std::string& meaning);

}  // namespace insalign::io
