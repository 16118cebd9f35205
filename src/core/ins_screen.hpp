// Bad INS stretches, found so that the stages can leave them out (issue 17). Every stage takes the
// INS poses as exact; an RTK float episode, a wrong fix or an outage breaks that for seconds. Three
// witnesses, each with its own blind spot:
//  - the INS's own status: solution type and stated standard deviations (Dataset::ins_quality).
//    Sees float episodes and outages; never a wrong fix, which is reported as a good fix.
//  - LiDAR motion: scan-to-scan registration of frames a few seconds apart along the drive against
//    the INS motion between them. A position jump shows at both of its ends, whatever the INS says.
//  - map residual: each frame's offset from the map the frames of other times agree on (voxel
//    planes of the rest of the drive). Says which side of a jump is wrong, and sees slow ramps.
// The LiDAR checks need an extrinsic near the truth (stage 1's): a lever-arm or rotation error
// misplaces frames by centimetres, far below the decimetres these events cost.
#pragma once

#include <cstddef>
#include <limits>
#include <vector>

#include "core/dataset.hpp"
#include "core/frame_store.hpp"
#include "core/geometry.hpp"
#include "core/scan_registration.hpp"

namespace insalign {

struct InsStatusConfig {
  /// A stated horizontal standard deviation above this factor x the drive's median (and above
  /// min_stddev_m) marks the sample bad: an INS that states 0.01 m typically and 0.2 m now.
  double stddev_factor = 4.0;
  double min_stddev_m = 0.05;
  double margin_s = 0.2;  ///< spans widened by this on each side, s
};

/// Scan-to-scan: a chain of frame pairs along the drive (each frame of a pair is the next's first).
struct LidarMotionConfig {
  std::size_t max_pairs = 40;      ///< registrations at most (the chain's gap grows on long drives)
  /// Frames of a pair at least this far apart (more on drives longer than max_pairs x this); a
  /// stretch shorter than the gap can hide inside one pair, s.
  double min_gap_s = 2.0;
  double target_voxel_m = 0.3;     ///< first frame of a pair, voxel centroids
  double source_voxel_m = 0.6;     ///< second frame
  double min_inlier_ratio = 0.3;   ///< a registration with fewer inliers says nothing
  /// Discrepancy between LiDAR and INS motion above max(min_jump_m, jump_factor x the drive's
  /// median discrepancy) flags a pair (RTK noise and ICP agree to 1-2 cm; a wrong fix is 0.5 m).
  double min_jump_m = 0.15;
  double jump_factor = 6.0;
  double min_turn_deg = 0.3;       ///< a pair whose rotation angles disagree by more is not used (clock offset, bad ICP)
  double max_span_s = 60.0;        ///< a jump and its return farther apart are not paired
  ScanRegistrationConfig icp = {.max_iterations = 20};
};

/// Map residual: each checked frame aligned (translation only) to voxel planes of the frames of
/// other times.
struct MapResidualConfig {
  double voxel_m = 2.0;            ///< plane voxels of the map, m
  double min_time_apart_s = 8.0;   ///< map frames closer in time to the frame are left out, s
  std::size_t min_plane_points = 12;
  double max_plane_thickness_m = 0.08;  ///< RMS distance from a voxel's plane
  int iterations = 6;
  double gate_start_m = 1.0, gate_end_m = 0.3;  ///< point-to-plane distance gate, shrinking
  double huber_m = 0.1;
  double min_information = 40.0;   ///< a direction with less (weighted normals) is not measured
  /// An offset (after the drive-wide part: a constant and speed x a time offset) above
  /// max(min_offset_m, offset_factor x the median offset) flags a frame.
  double min_offset_m = 0.12;
  double offset_factor = 5.0;
};

struct InsScreenConfig {
  bool from_status = true;         ///< use what the INS says of itself
  bool from_lidar = true;          ///< use the LiDAR checks (after stage 1)
  std::size_t max_frames = 300;    ///< frames of the LiDAR checks, spread over the drive's motion
  /// Frames of the LiDAR checks (base-thinned copies thinned again: cheap, few points suffice).
  SweepFilter filter{.min_range_m = 0.0, .max_range_m = 50.0, .voxel_m = 0.3, .max_points = 6000};
  InsStatusConfig status;
  LidarMotionConfig motion;
  MapResidualConfig map;
};

template <class V>
void visit_config(V& v, InsStatusConfig& c) {
  v("stddev_factor", c.stddev_factor, "stated horizontal stddev above this x the drive's median is bad");
  v("min_stddev_m", c.min_stddev_m, "...and above this, m");
  v("margin_s", c.margin_s, "spans widened by this on each side, s");
}
template <class V>
void visit_config(V& v, LidarMotionConfig& c) {
  v("max_pairs", c.max_pairs, "scan-to-scan registrations at most");
  v("min_gap_s", c.min_gap_s, "frames of a pair at least this far apart (more on long drives), s");
  v("target_voxel_m", c.target_voxel_m, "registration target voxel, m");
  v("source_voxel_m", c.source_voxel_m, "registration source voxel, m");
  v("min_inlier_ratio", c.min_inlier_ratio, "registrations with fewer inliers are not used");
  v("min_jump_m", c.min_jump_m, "LiDAR-INS motion discrepancy that flags a pair, m");
  v("jump_factor", c.jump_factor, "...and above this x the drive's median discrepancy");
  v("min_turn_deg", c.min_turn_deg, "a pair whose LiDAR and INS rotation angles disagree by more is not used, deg");
  v("max_span_s", c.max_span_s, "a jump and its return farther apart are not paired, s");
  v.section("icp", c.icp);
}
template <class V>
void visit_config(V& v, MapResidualConfig& c) {
  v("voxel_m", c.voxel_m, "plane voxels of the map, m");
  v("min_time_apart_s", c.min_time_apart_s, "map frames closer in time to the checked frame are left out, s");
  v("min_plane_points", c.min_plane_points, "a voxel plane needs this many points");
  v("max_plane_thickness_m", c.max_plane_thickness_m, "thicker voxels are no plane, m");
  v("iterations", c.iterations, "alignment iterations per frame");
  v("gate_start_m", c.gate_start_m, "point-to-plane gate of the first iteration, m");
  v("gate_end_m", c.gate_end_m, "...shrinking to this, m");
  v("huber_m", c.huber_m, "robust loss scale, m");
  v("min_information", c.min_information, "directions with less information are not measured");
  v("min_offset_m", c.min_offset_m, "a frame offset from the map by more than this is flagged, m");
  v("offset_factor", c.offset_factor, "...and by more than this x the median offset");
}
template <class V>
void visit_config(V& v, InsScreenConfig& c) {
  v("from_status", c.from_status, "leave out stretches the INS itself marks bad (solution type, stated stddev)");
  v("from_lidar", c.from_lidar, "leave out stretches the LiDAR data shows bad (scan-to-scan motion, map residual)");
  v("max_frames", c.max_frames, "frames of the LiDAR checks, spread over the drive's motion");
  v.section("filter", c.filter);
  v.section("status", c.status);
  v.section("motion", c.motion);
  v.section("map", c.map);
}

/// One scan-to-scan check.
struct PairCheck {
  double t0_s = 0.0, t1_s = 0.0;       ///< INS clock
  bool used = false;                   ///< the registration converged with enough inliers
  Vec3 jump_m = Vec3::Zero();          ///< world frame: INS motion minus LiDAR motion (error at t1 - at t0)
  double turn_deg = 0.0;               ///< rotation-angle discrepancy
  bool flagged = false;
};

/// One map-residual check.
struct FrameOffset {
  double t_s = 0.0;                    ///< INS clock (frame time)
  bool used = false;                   ///< enough planes met it
  Vec3 offset_m = Vec3::Zero();        ///< world: where the INS put the frame minus where the map says
  double residual_m = 0.0;             ///< |offset| beyond the drive-wide part, measured directions only
  bool flagged = false;
};

struct InsScreenResult {
  std::vector<TimeSpan> spans;         ///< every finding (spans of different sources may overlap)
  std::vector<PairCheck> pairs;
  std::vector<FrameOffset> offsets;
  double typical_stddev_m = std::numeric_limits<double>::quiet_NaN();  ///< stated, median
  double jump_threshold_m = 0.0, offset_threshold_m = 0.0;
  double time_offset_s = 0.0;          ///< the drive-wide part of the offsets: speed x this
  double wall_time_s = 0.0;
};

/// Spans the INS marks bad itself: a solution worse than the drive's usual one (RTK float,
/// differential, single, INS-only, invalid) or a stated stddev far above its typical one.
/// typical_stddev_m (optional) receives the median stated horizontal stddev.
std::vector<TimeSpan> status_spans(const std::vector<InsQuality>& quality, const InsStatusConfig& config,
                                   double* typical_stddev_m = nullptr);

/// The LiDAR checks on the given frames (dataset indices of frames the store offers, e.g. the
/// ones the stages use) with an extrinsic near the truth. Frames are read from the store.
InsScreenResult screen_with_lidar(const FrameStore& store, const std::vector<std::size_t>& frames,
                                  const Iso3& T_ins_lidar, double time_offset_s, const InsScreenConfig& config);

/// What the INS says of itself (config.from_status; nothing when off or the source states no
/// quality): its spans and the typical stated stddev.
InsScreenResult screen_with_status(const std::vector<InsQuality>& quality, const InsScreenConfig& config);
/// The LiDAR checks (config.from_lidar; nothing when off) on up to config.max_frames of the store's
/// frames (check_sample: the decoded ones first) with an extrinsic near the truth.
InsScreenResult lidar_checks(const FrameStore& store, const Iso3& T_ins_lidar, double time_offset_s,
                             const InsScreenConfig& config);
/// `status` (screen_with_status) with the LiDAR checks added: their spans after the status spans.
InsScreenResult with_lidar_checks(const InsScreenResult& status, InsScreenResult lidar);

/// The store with `spans` left out as well. Spans are in INS time: those found on one INS apply to
/// every LiDAR placed with it.
FrameStore leave_out_spans(const FrameStore& store, const std::vector<TimeSpan>& spans);
/// The store with the spans the INS marks bad itself left out as well (screen_with_status on the
/// store's dataset); the spans and the typical stated stddev go to `out`.
FrameStore leave_out_status_spans(const FrameStore& store, const InsScreenConfig& config, InsScreenResult& out);

/// Sum of the lengths of `spans` (merged where they overlap), s.
double spans_duration_s(std::vector<TimeSpan> spans);

}  // namespace insalign
