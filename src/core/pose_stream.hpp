// The INS trajectory T_world_ins(t), interpolated at any time it covers.
#pragma once

#include <stdexcept>
#include <vector>

#include "core/geometry.hpp"

namespace insalign {

struct StampedPose {
  double t_s = 0.0;       ///< INS clock, absolute seconds
  Iso3 T_world_ins = Iso3::Identity();
};

/// Thrown when a time outside the covered range is queried.
class OutOfRangeError : public std::out_of_range {
 public:
  using std::out_of_range::out_of_range;
};

/// A time-sorted pose sequence. Rotation is interpolated by slerp, translation by a
/// Catmull-Rom cubic (C1, exact for constant velocity), which keeps deskew errors of 10 Hz
/// pose files on turns well below a millimetre where linear interpolation cuts the corner.
class PoseStream {
 public:
  PoseStream() = default;
  /// Throws std::invalid_argument unless times are strictly increasing and finite.
  explicit PoseStream(std::vector<StampedPose> poses);

  /// Pose at time t_s; throws OutOfRangeError outside [t_begin(), t_end()].
  Iso3 T_world_ins(double t_s) const;
  bool covers(double t_s) const { return !poses_.empty() && t_s >= t_begin() && t_s <= t_end(); }
  double t_begin() const { return poses_.front().t_s; }
  double t_end() const { return poses_.back().t_s; }
  bool empty() const { return poses_.empty(); }
  std::size_t size() const { return poses_.size(); }
  const std::vector<StampedPose>& poses() const { return poses_; }

 private:
  std::vector<StampedPose> poses_;
};

/// The INS's rotation angle between two instants, deg; NaN unless the stream covers both. Equal to
/// a rigidly mounted sensor's rotation angle between the same instants whatever the mount
/// (R_sensor = X^T R_ins X keeps the angle): what clock checks compare a LiDAR's motion with.
double rotation_angle_deg(const PoseStream& poses, double t0_s, double t1_s);

}  // namespace insalign
