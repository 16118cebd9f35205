// The local ENU frame every geodetic source (INS fixes, geodetic fiducials) is placed in:
// x east, y north, z up, tangent to the WGS-84 ellipsoid at an origin (the first INS fix).
#pragma once

#include "core/geometry.hpp"

namespace insalign {

struct GeodeticPoint {
  double lat_deg = 0.0, lon_deg = 0.0;
  double height_m = 0.0;  ///< above the WGS-84 ellipsoid
};

/// Throws std::invalid_argument for a latitude outside [-90, 90], a longitude outside
/// [-180, 360] or a non-finite value (the readers turn that into an InputError with the line).
void check_geodetic(const GeodeticPoint& p);

class LocalEnu {
 public:
  explicit LocalEnu(const GeodeticPoint& origin);
  const GeodeticPoint& origin() const { return origin_; }
  /// Position of p in the frame (m).
  Vec3 position(const GeodeticPoint& p) const;
  /// R_enu0_enuP: rotates vectors of the local ENU frame at p into this frame's (the meridian
  /// convergence and the tilt of the vertical, 1.6e-4 rad per km).
  Mat3 rotation_at(const GeodeticPoint& p) const;
  /// The inverse of position().
  GeodeticPoint geodetic(const Vec3& p_enu_m) const;

 private:
  GeodeticPoint origin_;
};

}  // namespace insalign
