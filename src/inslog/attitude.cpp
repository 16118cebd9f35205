#include "inslog/attitude.hpp"

#include <algorithm>
#include <cmath>

namespace insalign::io {
namespace {

Mat3 rot(const Vec3& axis, double angle_deg) {
  return Eigen::AngleAxisd(angle_deg * kRadPerDeg, axis).toRotationMatrix();
}

double deg(double rad) { return rad * kDegPerRad; }

double wrap_360(double angle_deg) {
  double a = std::fmod(angle_deg, 360.0);
  if (a < 0.0) a += 360.0;
  return a >= 360.0 ? 0.0 : a;  // -1e-17 + 360 rounds to 360
}

double clamped_asin(double s) { return std::asin(std::clamp(s, -1.0, 1.0)); }

}  // namespace

Mat3 R_enu_ins_novatel(double roll_deg, double pitch_deg, double azimuth_deg) {
  return rot(Vec3::UnitZ(), -azimuth_deg) * rot(Vec3::UnitX(), pitch_deg) * rot(Vec3::UnitY(), roll_deg);
}

Mat3 R_enu_ned() {
  Mat3 R;
  R << 0, 1, 0, 1, 0, 0, 0, 0, -1;
  return R;
}

Mat3 R_enu_ins_ned(double roll_deg, double pitch_deg, double heading_deg) {
  const Mat3 R_ned_body =
      rot(Vec3::UnitZ(), heading_deg) * rot(Vec3::UnitY(), pitch_deg) * rot(Vec3::UnitX(), roll_deg);
  return R_enu_ned() * R_ned_body;
}

Mat3 R_enu_ins_enu(double roll_deg, double pitch_deg, double yaw_deg) {
  return rot(Vec3::UnitZ(), yaw_deg) * rot(Vec3::UnitY(), pitch_deg) * rot(Vec3::UnitX(), roll_deg);
}

Mat3 R_enu_ins_sbet(double roll_deg, double pitch_deg, double platform_heading_deg, double wander_deg) {
  return R_enu_ins_ned(roll_deg, pitch_deg, platform_heading_deg - wander_deg);
}

AttitudeDeg novatel_angles(const Mat3& R) {
  // Columns of Rz(-a) Rx(p) Ry(r): forward (y) = (cos p sin a, cos p cos a, sin p); the z row is
  // (-cos p sin r, sin p, cos p cos r).
  AttitudeDeg out;
  out.pitch_deg = deg(clamped_asin(R(2, 1)));
  out.heading_deg = wrap_360(deg(std::atan2(R(0, 1), R(1, 1))));
  out.roll_deg = deg(std::atan2(-R(2, 0), R(2, 2)));
  return out;
}

AttitudeDeg ned_angles(const Mat3& R_enu_ins) {
  const Mat3 R = R_enu_ned().transpose() * R_enu_ins;  // R_ned_body = Rz(h) Ry(p) Rx(r)
  AttitudeDeg out;
  out.pitch_deg = deg(clamped_asin(-R(2, 0)));
  out.heading_deg = wrap_360(deg(std::atan2(R(1, 0), R(0, 0))));
  out.roll_deg = deg(std::atan2(R(2, 1), R(2, 2)));
  return out;
}

AttitudeDeg enu_angles(const Mat3& R) {
  AttitudeDeg out;  // Rz(y) Ry(p) Rx(r), the same extraction as for NED
  out.pitch_deg = deg(clamped_asin(-R(2, 0)));
  out.heading_deg = deg(std::atan2(R(1, 0), R(0, 0)));
  out.roll_deg = deg(std::atan2(R(2, 1), R(2, 2)));
  return out;
}

}  // namespace insalign::io
