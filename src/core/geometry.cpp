#include "core/geometry.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>

namespace insalign {

Vec3 rpy_from_rotation(const Mat3& R) {
  // ZYX: pitch = -asin(R20); near the poles yaw and roll couple, keep roll = 0 there.
  const double sp = std::clamp(-R(2, 0), -1.0, 1.0);
  const double pitch = std::asin(sp);
  if (std::abs(sp) > 1.0 - 1e-12) {
    return {0.0, pitch, std::atan2(-R(0, 1), R(1, 1))};
  }
  return {std::atan2(R(2, 1), R(2, 2)), pitch, std::atan2(R(1, 0), R(0, 0))};
}

Mat3 rotation_from_rpy(const Vec3& rpy_rad) {
  return (Eigen::AngleAxisd(rpy_rad.z(), Vec3::UnitZ()) * Eigen::AngleAxisd(rpy_rad.y(), Vec3::UnitY()) *
          Eigen::AngleAxisd(rpy_rad.x(), Vec3::UnitX()))
      .toRotationMatrix();
}

Iso3 make_transform(const Vec3& t_m, const Vec3& rpy_deg) {
  Iso3 T = Iso3::Identity();
  T.linear() = rotation_from_rpy(rpy_deg * kRadPerDeg);
  T.translation() = t_m;
  return T;
}

Mat3 so3_exp(const Vec3& omega_rad) {
  const double angle = omega_rad.norm();
  if (angle < 1e-12) return Mat3::Identity();
  return Eigen::AngleAxisd(angle, omega_rad / angle).toRotationMatrix();
}

Vec3 so3_log(const Mat3& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

Iso3 perturb_in_ins_frame(const Iso3& T_ins_lidar, const Vec6& delta) {
  Iso3 out = T_ins_lidar;
  out.linear() = nearest_rotation(so3_exp(delta.tail<3>()) * T_ins_lidar.linear());
  out.translation() = T_ins_lidar.translation() + delta.head<3>();
  return out;
}

double wrap_pi(double angle_rad) { return std::remainder(angle_rad, 6.283185307179586); }

Mat3 nearest_rotation(const Mat3& M) {
  Eigen::JacobiSVD<Mat3> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 R = svd.matrixU() * svd.matrixV().transpose();
  if (R.determinant() < 0) {
    Mat3 U = svd.matrixU();
    U.col(2) *= -1.0;
    R = U * svd.matrixV().transpose();
  }
  return R;
}

ExtrinsicError extrinsic_error(const Iso3& T_ins_lidar_est, const Iso3& T_ins_lidar_gt) {
  ExtrinsicError e;
  const Vec3 dt = T_ins_lidar_est.translation() - T_ins_lidar_gt.translation();
  e.dt_m = dt.cwiseAbs();
  e.dt_norm_m = dt.norm();
  const Mat3 dR = T_ins_lidar_est.linear() * T_ins_lidar_gt.linear().transpose();
  e.drpy_deg = (rpy_from_rotation(dR) * kDegPerRad).cwiseAbs();
  e.angle_deg = Eigen::AngleAxisd(dR).angle() * kDegPerRad;
  return e;
}

}  // namespace insalign
