// Stage 3's measurement: the height of the map surface at a horizontal position (a fiducial, or
// the ground under the INS), how it moves when tz changes, and the robust combination of many
// such measurements into one dz.
#pragma once

#include <cstddef>
#include <limits>
#include <map>
#include <mutex>
#include <string>
#include <tuple>
#include <vector>

#include "core/frame_store.hpp"
#include "core/geometry.hpp"
#include "core/zcorrect.hpp"

namespace insalign {

/// A place where the map surface height is measured: map points within radius_m (horizontal) of
/// centre_xy, from the listed frames.
struct Target {
  Eigen::Vector2d centre_xy = Eigen::Vector2d::Zero();
  double radius_m = 0.0;
  std::vector<std::size_t> frames;  ///< indices into the dataset's frames, sorted
};

/// Map points gathered for one target, and the sum of R_world_ins * e_z of the frame each came
/// from: the direction a point moves when tz grows.
struct LocalMap {
  std::vector<Vec3> p_world;
  Vec3 up_sum = Vec3::Zero();
  std::size_t frames = 0;  ///< frames that contributed points
  Vec3 mean_up() const { return p_world.empty() ? Vec3::UnitZ() : Vec3(up_sum / double(p_world.size())); }
  void append(const LocalMap& other);
};

/// Raw points near stage 3's targets, kept by one stage-3 run for the next on the same store (the
/// pipeline measures tz before and after stage 2): decoding whole raw sweeps was most of the
/// stage's time. A frame's points are kept within margin_m beyond a target's radius and reused
/// while no point of them can have moved by the margin (a later extrinsic and time offset place
/// them a little differently), so the target gets exactly the points a fresh decode would give.
/// Thread-safe.
class NearPoints {
 public:
  explicit NearPoints(double margin_m = 0.5) : margin_m_(margin_m) {}

  /// The kept part of frame `index` around target t, if it still holds every point that placing
  /// the whole sweep with (T_ins_lidar, time_offset_s) would give t; else nullptr.
  const Sweep* find(std::size_t index, const Target& t, const PoseStream& poses, const Iso3& T_ins_lidar,
                    double time_offset_s) const;
  /// Keeps the points of `raw` (placed as p_world with T_ins_lidar, time_offset_s) within the
  /// margin of t, with the earliest and latest point: the part then places like the sweep.
  void keep(std::size_t index, const Target& t, const Sweep& raw, const std::vector<Vec3f>& p_world,
            const Iso3& T_ins_lidar, double time_offset_s);

 private:
  struct Part {
    Sweep sweep;
    Iso3 T_ins_lidar = Iso3::Identity();
    double time_offset_s = 0.0;
  };
  using Key = std::tuple<std::size_t, double, double, double>;  // frame, centre x, y, radius
  static Key key(std::size_t index, const Target& t) { return {index, t.centre_xy.x(), t.centre_xy.y(), t.radius_m}; }
  double margin_m_;
  mutable std::mutex mutex_;
  std::map<Key, Part> parts_;
};

/// Loads each frame any target needs once (raw, in parallel), places it with per-point deskew
/// and hands every target the points near it. Frames the poses do not cover are skipped. With
/// `near`, frames whose points near their targets it still holds are not decoded again, and those
/// decoded leave it their points near their targets.
std::vector<LocalMap> gather(const FrameStore& store, const std::vector<Target>& targets, const Iso3& T_ins_lidar,
                             double time_offset_s, std::size_t* frames_loaded, NearPoints* near = nullptr);

/// Height of the map surface at a horizontal position and how it moves with tz.
struct SurfaceHeight {
  bool ok = false;
  double z_m = std::numeric_limits<double>::quiet_NaN();      ///< surface height at the centre
  double sigma_m = std::numeric_limits<double>::quiet_NaN();  ///< standard error of z_m
  double dz_gain = 1.0;       ///< d(z_m)/d(tz): the vertical move of a tilted surface per tz change
  std::size_t points = 0;     ///< points the estimate used (inliers)
  std::string problem;        ///< why not ok
};

/// Robust plane z = a dx + b dy + c around the centre (start at the densest height: the ground
/// dominates a small disc even next to a wall or a pole; then least squares dropping points
/// beyond 3 robust sigma, a few rounds), evaluated as `match` says. Not ok for too few points or
/// a slope above max_slope_deg.
SurfaceHeight fit_surface(const LocalMap& map, const Eigen::Vector2d& centre_xy, FiducialMatch match,
                          std::size_t min_points, double max_slope_deg, double init_window_m);

/// One measurement of dz with its standard error.
struct DzSample {
  double dz_m = std::numeric_limits<double>::quiet_NaN();
  double sigma_m = std::numeric_limits<double>::quiet_NaN();
};

struct RobustMean {
  double mean_m = 0.0;
  double stddev_m = std::numeric_limits<double>::quiet_NaN();  ///< formal, or the scatter if larger
  double threshold_m = 0.0;
  std::vector<char> inlier;
};
/// Samples farther than max(floor_m, mad_factor * robust sigma) from the median are rejected;
/// weighted mean of the rest, then once more against that mean.
RobustMean robust_mean(const std::vector<DzSample>& samples, double floor_m, double mad_factor);

}  // namespace insalign
