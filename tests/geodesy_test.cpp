// The local ENU frame (core/geodesy.hpp, GeographicLib) against published values and against a
// direct WGS-84 ECEF computation written here.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

#include "core/geodesy.hpp"

namespace insalign::io {
namespace {

// WGS-84 geodetic -> ECEF, textbook formula (independent of GeographicLib).
Vec3 ecef(const GeodeticPoint& p) {
  const double a = 6378137.0, f = 1.0 / 298.257223563, e2 = f * (2 - f);
  const double lat = p.lat_deg * M_PI / 180, lon = p.lon_deg * M_PI / 180;
  const double N = a / std::sqrt(1 - e2 * std::sin(lat) * std::sin(lat));
  return {(N + p.height_m) * std::cos(lat) * std::cos(lon), (N + p.height_m) * std::cos(lat) * std::sin(lon),
          (N * (1 - e2) + p.height_m) * std::sin(lat)};
}

// Rows: east, north, up of the tangent frame at p, in ECEF.
Mat3 R_enu_ecef(const GeodeticPoint& p) {
  const double lat = p.lat_deg * M_PI / 180, lon = p.lon_deg * M_PI / 180;
  Mat3 R;
  R << -std::sin(lon), std::cos(lon), 0, -std::sin(lat) * std::cos(lon), -std::sin(lat) * std::sin(lon), std::cos(lat),
      std::cos(lat) * std::cos(lon), std::cos(lat) * std::sin(lon), std::sin(lat);
  return R;
}

TEST(Geodesy, MatchesGeographicLibsPublishedCartConvertExample) {
  // CartConvert's documentation: "echo 33.3 44.4 6000 | CartConvert -l 33 44 20" -> 37288.97 33374.29 5783.64
  const LocalEnu enu({33.0, 44.0, 20.0});
  const Vec3 p = enu.position({33.3, 44.4, 6000.0});
  EXPECT_NEAR(p.x(), 37288.97, 0.005);
  EXPECT_NEAR(p.y(), 33374.29, 0.005);
  EXPECT_NEAR(p.z(), 5783.64, 0.01);
}

TEST(Geodesy, PositionsMatchDirectEcefToEnuAndRoundTrip) {
  const GeodeticPoint origin{49.011, 8.424, 160.0};  // Karlsruhe
  const LocalEnu enu(origin);
  EXPECT_LT(enu.position(origin).norm(), 1e-9);
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> d(-0.05, 0.05), h(-50, 50);  // about +-5 km
  for (int i = 0; i < 200; ++i) {
    const GeodeticPoint p{origin.lat_deg + d(rng), origin.lon_deg + d(rng), origin.height_m + h(rng)};
    const Vec3 expected = R_enu_ecef(origin) * (ecef(p) - ecef(origin));
    EXPECT_LT((enu.position(p) - expected).norm(), 1e-6);
    const GeodeticPoint back = enu.geodetic(enu.position(p));
    EXPECT_NEAR(back.lat_deg, p.lat_deg, 1e-11);
    EXPECT_NEAR(back.lon_deg, p.lon_deg, 1e-11);
    EXPECT_NEAR(back.height_m, p.height_m, 1e-6);
  }
}

TEST(Geodesy, UpVectorOneKilometreEastTiltsEastByItsArc) {
  const GeodeticPoint origin{45.0, 7.0, 0.0};
  const LocalEnu enu(origin);
  // A point 1 km east along the parallel: its vertical is tilted toward east by about 1 km / radius.
  const double dlon_deg = 1000.0 / (6388838.0 * std::cos(45.0 * M_PI / 180)) * 180 / M_PI;
  const GeodeticPoint p{45.0, 7.0 + dlon_deg, 0.0};
  EXPECT_NEAR(enu.position(p).x(), 1000.0, 0.1);
  const Vec3 up_at_p = enu.rotation_at(p).col(2);
  EXPECT_NEAR(up_at_p.x(), 1.565e-4, 0.01e-4);  // ~1.57e-4 rad toward east
  EXPECT_NEAR(up_at_p.y(), 0.0, 2e-6);          // convergence tilts north a hair (1.1e-8 rad here)
  // And it is the direct computation: R_enu0_ecef * R_enuP_ecef^T.
  const Mat3 expected = R_enu_ecef(origin) * R_enu_ecef(p).transpose();
  EXPECT_LT((enu.rotation_at(p) - expected).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(Geodesy, CheckGeodeticRejectsOutOfRangeAndNonFinite) {
  EXPECT_NO_THROW(check_geodetic({90.0, 180.0, 0.0}));
  EXPECT_THROW(check_geodetic({91.0, 0.0, 0.0}), std::invalid_argument);
  EXPECT_THROW(check_geodetic({-90.5, 0.0, 0.0}), std::invalid_argument);
  EXPECT_THROW(check_geodetic({0.0, 361.0, 0.0}), std::invalid_argument);
  EXPECT_THROW(check_geodetic({std::nan(""), 0.0, 0.0}), std::invalid_argument);
  EXPECT_THROW(check_geodetic({0.0, 0.0, std::numeric_limits<double>::infinity()}), std::invalid_argument);
  EXPECT_THROW(check_geodetic({0.0, 0.0, -6356752.3}), std::invalid_argument);  // NovAtel's "not aligned" placeholder
  EXPECT_THROW(LocalEnu({95.0, 0.0, 0.0}), std::invalid_argument);
}

}  // namespace
}  // namespace insalign::io
