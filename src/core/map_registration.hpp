// A LiDAR's sweeps registered to a map another LiDAR of the rig made: the one extrinsic that puts
// all of them, each through its INS pose, on that map's surfaces. Independent of the LiDAR's own
// stage 1, so a rig member whose start ended in a wrong basin is found (and restarted, rig.cpp).
#pragma once

#include <cstddef>
#include <memory>
#include <vector>

#include "core/frame_store.hpp"
#include "core/frames.hpp"
#include "core/geometry.hpp"
#include "core/scan_registration.hpp"

namespace insalign {

struct MapRegistrationConfig {
  std::size_t frames = 30;  ///< sweeps of the LiDAR, spread over the drive's motion
  /// Per sweep: 0.5 m voxels and at most 1500 points are plenty for six parameters.
  SweepFilter filter{.min_range_m = 0.0, .max_range_m = 60.0, .voxel_m = 0.5, .max_points = 1500};
  int iterations = 30;
  /// Association gate, shrinking geometrically over the first half of the iterations: wide enough
  /// for a start a few degrees off (5 deg at 20 m is 1.7 m), narrow enough at the end to ignore
  /// what the map does not share.
  double gate_start_m = 2.0;
  double gate_end_m = 0.3;
  /// The iterations before the gate reaches gate_end_m take every this-th point: they only find
  /// the basin, and with the wide gate their nearest-point searches cost the most.
  std::size_t coarse_stride = 4;
  double huber_m = 0.1;            ///< robust kernel on point-to-plane residuals
  int normal_neighbours = 8;       ///< target normals from this many neighbours...
  double max_plane_thickness_m = 0.08;  ///< ...where the patch is at most this thick
  double converged_step = 1e-5;    ///< stop when the update is below this (m and rad)
  /// ...or when an iteration at the final gate improved the fit's RMS by less than this fraction:
  /// a slide along a direction the map barely constrains (a millimetre an iteration, seen on a
  /// side VLP-16) goes on for every iteration allowed and changes no comparison of fits.
  double converged_rms_fraction = 2e-3;
  std::size_t min_inliers = 300;   ///< fewer associations at the end: not converged
};

template <class V>
void visit_config(V& v, MapRegistrationConfig& c) {
  v("frames", c.frames, "sweeps of the LiDAR registered to the other's map");
  v.section("filter", c.filter);
  v("iterations", c.iterations, "Gauss-Newton iterations");
  v("gate_start_m", c.gate_start_m, "association gate of the first iteration, m");
  v("gate_end_m", c.gate_end_m, "association gate at the end (and of the fit measure), m");
  v("coarse_stride", c.coarse_stride, "the iterations before the gate reaches gate_end_m take every this-th point");
  v("huber_m", c.huber_m, "robust kernel on point-to-plane residuals, m");
  v("converged_rms_fraction", c.converged_rms_fraction, "stop when an iteration at the final gate improves the RMS by less than this fraction");
}

/// Rigs: every LiDAR's stage 1 checked against the map of the member whose stage 1 found the most
/// planes. A LiDAR whose sweeps fit that map clearly better elsewhere is restarted from there
/// (its own start can end in a wrong basin: a tilted 16-ring LiDAR that sees mostly ground).
struct MapCheckConfig {
  bool enabled = true;
  std::size_t map_frames = 40;  ///< frames of the reference LiDAR stitched into the map
  double map_voxel_m = 0.2;     ///< one map point per cube of this edge, m
  /// Restart when the registration moved the LiDAR farther than stage 1's own bound from its
  /// stage 1 (INS noise and the map's own error move a calibrated one by a tenth of that)...
  double restart_rot_deg = 0.2;
  double restart_trans_m = 0.03;  ///< ...(x, y; tz is stage 3's)
  /// ...and its sweeps' point-to-plane RMS on the map (inliers at gate_end_m, every fit at the
  /// map's tz) is this factor smaller there: a right stage 1 and the map agree to the map's
  /// thickness, and that floor (sensor noise, ~6 mm) is in both RMS, so a third of a degree off
  /// shows as about 2x, not more.
  double min_fit_gain = 1.5;
  MapRegistrationConfig registration;
};

template <class V>
void visit_config(V& v, MapCheckConfig& c) {
  v("enabled", c.enabled, "rig: check every LiDAR's stage 1 against the best LiDAR's map, restart a misfit");
  v("map_frames", c.map_frames, "rig: frames of the reference LiDAR in that map");
  v("map_voxel_m", c.map_voxel_m, "rig: voxel of that map, m");
  v("restart_rot_deg", c.restart_rot_deg, "rig: restart stage 1 when the map puts the LiDAR this far in rotation, deg");
  v("restart_trans_m", c.restart_trans_m, "rig: ...or this far in x, y, m");
  v("min_fit_gain", c.min_fit_gain, "rig: ...and its point-to-plane RMS on the map is this factor smaller there");
  v.section("registration", c.registration);
}

struct MapFit {
  std::size_t points = 0;   ///< source points placed
  std::size_t inliers = 0;  ///< of them within gate_end_m of a planar map point
  double rms_m = 0.0;       ///< point-to-plane RMS of the inliers
  double inlier_ratio() const { return points ? double(inliers) / double(points) : 0.0; }
};

struct MapRegistrationResult {
  Iso3 T_ins_lidar = Iso3::Identity();
  bool converged = false;
  int iterations = 0;
  MapFit start;  ///< how the start extrinsic fits the map (final gate)
  MapFit end;    ///< how the result fits it
};

/// The map as a registration target (kd-tree; a point's normal fitted when a registration first
/// lands on it), to share between registrations that run one after another.
std::shared_ptr<const PlaneTarget> map_target(const std::vector<Vec3f>& map_world, const MapRegistrationConfig& config);

/// A LiDAR's sweeps (frames of `store`, each point placed at its own time + time_offset_s) against
/// a world map, ready to measure how an extrinsic fits the map and to solve for the one that fits
/// best. tz is estimated too (a map's own tz error moves it: callers use the rotation
/// and x, y).
class MapRegistration {
 public:
  MapRegistration(const FrameStore& store, const std::vector<Vec3f>& map_world, double time_offset_s,
                  const MapRegistrationConfig& config = {});
  /// The same against a map target built once (map_target) and shared by several LiDARs.
  MapRegistration(const FrameStore& store, std::shared_ptr<const PlaneTarget> map, double time_offset_s,
                  const MapRegistrationConfig& config = {});
  ~MapRegistration();

  MapFit fit(const Iso3& T_ins_lidar) const;
  MapRegistrationResult solve(const Iso3& T_ins_lidar_start) const;

 private:
  struct Sweeps;
  MapRegistrationConfig config_;
  std::shared_ptr<const PlaneTarget> map_;
  std::unique_ptr<const Sweeps> sweeps_;
};

}  // namespace insalign
