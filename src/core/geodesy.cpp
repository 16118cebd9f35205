#include "core/geodesy.hpp"

#include <GeographicLib/Geocentric.hpp>
#include <GeographicLib/LocalCartesian.hpp>

#include <cmath>
#include <stdexcept>
#include <vector>

namespace insalign {

void check_geodetic(const GeodeticPoint& p) {
  if (!std::isfinite(p.lat_deg) || !std::isfinite(p.lon_deg) || !std::isfinite(p.height_m)) {
    throw std::invalid_argument("latitude, longitude or height is not a finite number");
  }
  if (p.lat_deg < -90.0 || p.lat_deg > 90.0) throw std::invalid_argument("latitude outside [-90, 90] deg");
  if (p.lon_deg < -180.0 || p.lon_deg > 360.0) throw std::invalid_argument("longitude outside [-180, 360] deg");
  if (std::abs(p.height_m) > 1e5) throw std::invalid_argument("height more than 100 km from the ellipsoid");
}

LocalEnu::LocalEnu(const GeodeticPoint& origin) : origin_(origin) { check_geodetic(origin); }

Vec3 LocalEnu::position(const GeodeticPoint& p) const {
  const GeographicLib::LocalCartesian frame(origin_.lat_deg, origin_.lon_deg, origin_.height_m);
  Vec3 out;
  frame.Forward(p.lat_deg, p.lon_deg, p.height_m, out.x(), out.y(), out.z());
  return out;
}

Mat3 LocalEnu::rotation_at(const GeodeticPoint& p) const {
  // GeographicLib's M maps local ENU vectors at p into this frame's ENU, row-major.
  const GeographicLib::LocalCartesian frame(origin_.lat_deg, origin_.lon_deg, origin_.height_m);
  std::vector<double> M(9);
  double x, y, z;
  frame.Forward(p.lat_deg, p.lon_deg, p.height_m, x, y, z, M);
  Mat3 R;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R(r, c) = M[3 * r + c];
  return R;
}

GeodeticPoint LocalEnu::geodetic(const Vec3& p_enu_m) const {
  const GeographicLib::LocalCartesian frame(origin_.lat_deg, origin_.lon_deg, origin_.height_m);
  GeodeticPoint out;
  frame.Reverse(p_enu_m.x(), p_enu_m.y(), p_enu_m.z(), out.lat_deg, out.lon_deg, out.height_m);
  return out;
}

}  // namespace insalign
