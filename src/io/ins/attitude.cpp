#include "io/ins/attitude.hpp"

namespace insalign::io {
namespace {

Mat3 rot(const Vec3& axis, double angle_deg) {
  return Eigen::AngleAxisd(angle_deg * kRadPerDeg, axis).toRotationMatrix();
}

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

}  // namespace insalign::io
