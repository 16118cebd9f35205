// Stage 3: the vertical lever arm tz. Planar driving cannot reveal it (a change of tz lifts the
// whole map), so an absolute reference fixes it: surveyed fiducials on surfaces the LiDAR sees,
// or the known height of the INS origin above the ground.
#pragma once

#include <array>
#include <cstddef>
#include <span>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "core/frame_store.hpp"
#include "core/geometry.hpp"
#include "core/stage.hpp"

namespace insalign {

/// How a fiducial is compared with the map around it.
enum class FiducialMatch {
  kNearestNeighbour,  ///< height of the map point horizontally nearest the fiducial (the paper)
  kLocalPlane,        ///< robust plane through the map points near it, evaluated at the fiducial
};
inline constexpr std::array<std::pair<FiducialMatch, std::string_view>, 2> kFiducialMatchNames{
    {{FiducialMatch::kLocalPlane, "local-plane"}, {FiducialMatch::kNearestNeighbour, "nearest-neighbour"}}};
constexpr auto enum_names(FiducialMatch) { return std::span(kFiducialMatchNames); }

/// What fixed tz.
enum class ZMethod { kNone, kFiducials, kInsHeight };
inline constexpr std::array<std::pair<ZMethod, std::string_view>, 3> kZMethodNames{
    {{ZMethod::kNone, "none"}, {ZMethod::kFiducials, "fiducials"}, {ZMethod::kInsHeight, "ins-height"}}};
constexpr auto enum_names(ZMethod) { return std::span(kZMethodNames); }

struct ZConfig {
  /// kLocalPlane averages the LiDAR range noise of many points instead of taking one point's;
  /// measured better (see bench/z_accuracy.cpp and the README numbers).
  FiducialMatch match = FiducialMatch::kLocalPlane;
  /// Map points within this horizontal distance of a fiducial form its local map. Small, so
  /// ground slope and nearby objects matter little; large enough for several scan rings.
  double search_radius_m = 0.5;
  /// A fiducial (or a height-prior frame) needs at least this many map points to be used.
  std::size_t min_points = 10;
  /// A fiducial whose implied dz differs from the median of all by more than
  /// max(outlier_threshold_m, outlier_mad_factor * 1.4826 * MAD) is rejected as an outlier
  /// (occluded, moved or mistyped). The floor keeps a handful of agreeing fiducials (MAD of a
  /// few mm) from rejecting a good one at 5 mm survey noise; 5 cm is 10 sigma of that noise.
  double outlier_threshold_m = 0.05;
  double outlier_mad_factor = 4.0;
  /// Fewer usable fiducials than this and tz is not determined (3 allows an outlier to show).
  std::size_t min_fiducials = 3;
  /// Survey noise assumed for each fiducial (1 sigma); enters the weights and tz_stddev_m.
  double fiducial_sigma_m = 0.005;
  /// The INS's own absolute height error, averaged over the frames used (1 sigma). Fiducials are
  /// absolute, so it adds to tz_stddev_m in quadrature; no LiDAR data can remove it (it lifts map
  /// and trajectory together). 1 cm: an RTK-fixed INS (~1.5 cm vertical RMS, partly averaging
  /// over a few minutes of driving). The height prior is relative to the INS poses: not affected.
  double ins_vertical_sigma_m = 0.01;
  /// Frames used for a fiducial: those whose LiDAR passes within [min_view_distance_m,
  /// max_view_distance_m] horizontally of it, nearest first, at most frames_per_fiducial of
  /// them (ground sampling is densest at short range; more frames cost load time).
  double min_view_distance_m = 3.0;
  double max_view_distance_m = 20.0;
  std::size_t frames_per_fiducial = 8;
  /// A fiducial whose local map holds points from fewer than frames_per_fiducial / 2 frames gets
  /// more rounds of farther candidate frames, up to this many frames in all: a 16-ring LiDAR
  /// meets the ground near a fiducial only from the distances where one of its rings does.
  std::size_t max_frames_per_fiducial = 40;
  /// Frames closer in time than this to an already chosen one for the same fiducial are
  /// skipped, so the chosen frames see it from different places and, on a figure-8, from
  /// different passes (INS drift differs between passes and partly averages out).
  double min_frame_separation_s = 3.0;

  // Height prior (--ins-height-m): the ground under the INS origin from the stitched map.
  /// Number of places along the drive where the ground height under the INS is measured.
  std::size_t height_samples = 16;
  /// Ground points within this horizontal distance of the INS origin are fitted by a plane.
  double ground_radius_m = 4.0;
  /// Neighbouring frames (the nearest in time, before and after, that were at least
  /// min_view_distance_m away, within this time) are stitched in, so the ground under the car
  /// (hidden from its own sweep) is seen from where the car was or will be. 3 s covers 3 m even
  /// at 1 m/s.
  double ground_window_s = 3.0;
  std::size_t ground_frames_per_sample = 3;
  /// A ground plane steeper than this is not ground (a ramp wall, a car side).
  double max_ground_slope_deg = 15.0;
  /// A place whose ground height is less certain than this (ground seen on one side only, far
  /// from the INS) would only add noise: skipped.
  double max_ground_sigma_m = 0.01;
  /// Neither fiducials nor a height prior: tz stays at its initial value, this uncertain (1 sigma);
  /// it is carried into the stddev of x and y (see core/tz_coupling.hpp). 0.5 m: the simulator's
  /// wrong initial guess; a guess measured on the car is better, one from a drawing may be worse.
  double undetermined_tz_sigma_m = 0.5;
};

template <class V>
void visit_config(V& v, ZConfig& c) {
  v("match", c.match, "how a fiducial meets the map: local-plane (robust plane) or nearest-neighbour (the paper)");
  v("search_radius_m", c.search_radius_m, "map points within this horizontal distance form a fiducial's local map, m");
  v("min_points", c.min_points, "a fiducial needs at least this many map points");
  v("outlier_threshold_m", c.outlier_threshold_m, "fiducials farther than max(this, mad_factor * MAD) from the median dz are outliers, m");
  v("outlier_mad_factor", c.outlier_mad_factor, "see outlier_threshold_m");
  v("min_fiducials", c.min_fiducials, "fewer usable fiducials and tz is not determined");
  v("fiducial_sigma_m", c.fiducial_sigma_m, "survey noise of a fiducial (1 sigma), m");
  v("ins_vertical_sigma_m", c.ins_vertical_sigma_m, "absolute height error of the INS over the drive (1 sigma), m");
  v("min_view_distance_m", c.min_view_distance_m, "frames used for a fiducial pass at least this far from it, m");
  v("max_view_distance_m", c.max_view_distance_m, "...and at most this far, m");
  v("frames_per_fiducial", c.frames_per_fiducial, "at most this many frames per fiducial per round");
  v("max_frames_per_fiducial", c.max_frames_per_fiducial, "more (farther) frames for a fiducial seen in too few, up to this many");
  v("min_frame_separation_s", c.min_frame_separation_s, "frames for one fiducial at least this far apart in time, s");
  v("height_samples", c.height_samples, "height prior: places along the drive where the ground under the INS is measured");
  v("ground_radius_m", c.ground_radius_m, "height prior: ground points within this of the INS origin are fitted, m");
  v("ground_window_s", c.ground_window_s, "height prior: neighbouring frames within this time are stitched in, s");
  v("ground_frames_per_sample", c.ground_frames_per_sample, "height prior: frames stitched per sample");
  v("max_ground_slope_deg", c.max_ground_slope_deg, "height prior: a steeper plane is not ground, deg");
  v("max_ground_sigma_m", c.max_ground_sigma_m, "height prior: a place whose ground height is less certain is skipped, m");
  v("undetermined_tz_sigma_m", c.undetermined_tz_sigma_m, "no fiducials or height: tz's uncertainty, carried into the x and y stddev, m");
}

/// One fiducial's comparison with the map. Residual = fiducial z - map surface z at the
/// fiducial's horizontal position, before and after the correction.
struct FiducialResidual {
  std::string id;
  double residual_before_m = std::numeric_limits<double>::quiet_NaN();
  double residual_after_m = std::numeric_limits<double>::quiet_NaN();
  bool used = false;
  std::string reason_rejected;  ///< empty when used
  std::size_t map_points = 0;   ///< map points near it that the match used
};

struct ZResult {
  /// kOk: tz determined (determined[2], stddev[2]); kUndetermined: fiducials or a height were
  /// given but could not fix it; kSkipped: neither was given. The message says which and why.
  StageOutcome outcome;
  ZMethod method = ZMethod::kNone;
  Iso3 T_ins_lidar = Iso3::Identity();  ///< tz corrected (unchanged if not determined)
  double dz_m = 0.0;                    ///< added to tz
  std::vector<FiducialResidual> fiducials;
  std::size_t height_samples_used = 0;  ///< height prior: places where the ground was measured
  std::size_t frames_loaded = 0;
  bool determined() const { return outcome.ok(); }
  double tz_stddev_m() const { return outcome.stddev[2]; }
};

class NearPoints;

/// Corrects tz of T_ins_lidar (its rotation and tx, ty are kept). Uses the dataset's fiducials if
/// there are any, else ins_height_m (height of the INS origin above the ground) if given, else
/// nothing. Frames are placed with per-point deskew and time_offset_s (LiDAR -> INS clock).
/// `near` (core/z_surface.hpp): the raw points an earlier run on the same store kept, and where
/// this run keeps its own.
ZResult correct_z(const FrameStore& store, const Iso3& T_ins_lidar, double time_offset_s,
                  std::optional<double> ins_height_m, const ZConfig& config = {}, NearPoints* near = nullptr);

}  // namespace insalign
