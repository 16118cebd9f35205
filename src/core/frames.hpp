// The one frame policy every stage follows: which sweeps the poses cover (from the LiDAR's
// measured sweep period), how a sweep is thinned (one SweepFilter), and how frames are spread
// over a drive (one motion measure, in metres). A 20 Hz LiDAR or a bigger vehicle is one setting
// here, not an edit in every stage.
#pragma once

#include <cstddef>
#include <vector>

#include "core/dataset.hpp"
#include "core/geometry.hpp"
#include "core/pose_stream.hpp"
#include "core/sweep.hpp"

namespace insalign {

/// The vehicle the sensors ride on, as every stage needs it.
struct VehicleConfig {
  /// Points within this distance of a LiDAR are the car body or its shadow: dropped everywhere.
  /// 2.5 m clears a car or SUV from a roof mount; raise it for a van or a truck.
  double body_radius_m = 2.5;
};

/// How frames are told apart and spread over a drive.
struct FramesConfig {
  /// Motion measure = path length + this x turned angle, so that turning on the spot counts as
  /// motion (it determines rotation) and standing still does not. 10 m/rad: a 90 deg turn
  /// weighs like 16 m of driving.
  double turn_weight_m_per_rad = 10.0;
  /// Two frames closer than both of these are the same view (standstill): the later one adds
  /// nothing to a group of consecutive frames.
  double min_step_m = 0.1;
  double min_step_deg = 1.0;
  /// Duration of one sweep; 0: measured from the frame times (median spacing: one revolution
  /// per frame). Poses must cover the sweep (x 1.1 for jitter) to deskew it.
  double sweep_period_s = 0.0;
};

/// Range limits, downsampling and a point budget: the whole of how a stage thins a sweep.
struct SweepFilter {
  double min_range_m = 2.5;    ///< nearer points dropped (set from VehicleConfig::body_radius_m)
  double max_range_m = 80.0;   ///< farther points dropped (sparse and noisy)
  double voxel_m = 0.0;        ///< one raw point (with its own time) kept per cube of this edge; 0: all
  std::size_t max_points = 0;  ///< then thinned evenly to at most this many; 0: no budget
};

template <class V>
void visit_config(V& v, VehicleConfig& c) {
  v("body_radius_m", c.body_radius_m, "points within this distance of a LiDAR are the car body, dropped by every stage, m");
}
template <class V>
void visit_config(V& v, FramesConfig& c) {
  v("turn_weight_m_per_rad", c.turn_weight_m_per_rad, "motion measure = path length + this x turned angle, m/rad");
  v("min_step_m", c.min_step_m, "frames closer than this (and min_step_deg) are the same view, m");
  v("min_step_deg", c.min_step_deg, "see min_step_m, deg");
  v("sweep_period_s", c.sweep_period_s, "duration of one sweep (0: measured from the frame times), s");
}
template <class V>
void visit_config(V& v, SweepFilter& c) {
  v("min_range_m", c.min_range_m, "nearer points dropped (0: the vehicle body radius), m");
  v("max_range_m", c.max_range_m, "farther points dropped, m");
  v("voxel_m", c.voxel_m, "one point kept per cube of this edge (0: all), m");
  v("max_points", c.max_points, "then thinned evenly to at most this many (0: no budget)");
}

/// The filter applied: non-finite points and those outside the range limits dropped, one point
/// per voxel (the first met, keeping its time and intensity), then an even stride to the budget.
Sweep thin_sweep(const Sweep& sweep, const SweepFilter& filter);

/// The sweep period: config.sweep_period_s if set, else the median frame spacing (clamped to
/// 0.02-0.25 s; 0.1 s when there are fewer than two frames).
double sweep_period_s(const std::vector<FrameInfo>& frames, const FramesConfig& config = {});

/// Whether the poses cover the sweep ending at t_end_s (LiDAR clock) through the time offset,
/// with margin_s more on both sides (a time-offset search looks that far).
bool sweep_covered(const PoseStream& poses, double t_end_s, double period_s, double time_offset_s, double margin_s = 0.0);
/// The same from a loaded sweep's own point times (a sweep without times needs only its end).
bool sweep_covered(const PoseStream& poses, const Sweep& sweep, double time_offset_s, double margin_s = 0.0);

/// The frames of a drive whose sweeps the poses cover, each with its INS pose at the frame time
/// and the cumulative motion measure. Pose-only: no sweep is loaded.
struct DriveFrames {
  std::vector<std::size_t> index;    ///< into Dataset::frames.frames, time order
  std::vector<double> t_end_s;       ///< frame times, LiDAR clock
  std::vector<Iso3> T_world_ins;     ///< at each frame time (INS clock = LiDAR + offset)
  std::vector<double> motion_m;      ///< cumulative motion measure, 0 at the first frame
  double distance_m = 0.0;           ///< path length over these frames
  double turned_rad = 0.0;           ///< total rotation angle over these frames
  std::size_t moving = 0;            ///< frames that moved since the previous one
  std::vector<char> decoded;         ///< the frame's sweep is already in the store (empty: unknown)
  std::size_t size() const { return index.size(); }
};
class FrameStore;
/// Over the store's poses (possibly corrected), leaving out frames whose sweep touches one of
/// its excluded INS spans.
DriveFrames drive_frames(const FrameStore& store, double time_offset_s = 0.0, double margin_s = 0.0);

/// Positions (into `frames`) of up to n frames at the centres of n equal slices of the motion
/// measure between positions first and last (inclusive; default: all), without repeats. A slice
/// whose centre frame is not decoded yet takes its decoded frame nearest the centre if it has one:
/// the report and the rig checks then share sweeps instead of decoding new ones. A caller that
/// needs the exact centres clears `frames.decoded` first (stage 2: refine_frames).
std::vector<std::size_t> spread_over_motion(const DriveFrames& frames, std::size_t n, std::size_t first = 0,
                                            std::size_t last = static_cast<std::size_t>(-1));

/// `frames` (dataset indices, time order, each a frame of `drive`) and, between each consecutive
/// pair, `per_gap` more at equal steps of the motion measure (the frame nearest each step), in
/// time order without repeats. A step that samples the drive more densely on the frames an earlier
/// one decoded: the trajectory correction's 240 around stage 2's 120.
std::vector<std::size_t> fill_between(const DriveFrames& drive, const std::vector<std::size_t>& frames,
                                      std::size_t per_gap);

/// Up to n frames (dataset indices, time order) for a check that samples the drive after stage 1
/// (INS screening, moving points): the decoded ones when at least n / 2 are (n of them, evenly in
/// time order, if more); else n spread over every frame's motion. The decoded frames are the ones
/// the stages use (stage 1's, and stage 2's, loaded before the checks), and decoding a sweep costs
/// more than checking it.
std::vector<std::size_t> check_sample(const FrameStore& store, std::size_t n, double time_offset_s = 0.0);

/// Up to n_groups groups of per_group consecutive frames that each moved by at least the
/// config's min step from the previous member, anchored at the starts of equal slices of the
/// motion measure, never overlapping. Dataset frame indices, time order.
std::vector<std::vector<std::size_t>> spread_groups(const DriveFrames& frames, const FramesConfig& config,
                                                    std::size_t n_groups, std::size_t per_group);

}  // namespace insalign
