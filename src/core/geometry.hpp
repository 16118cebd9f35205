// Rigid-transform helpers shared by every stage. Naming: T_a_b maps frame b into frame a.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace insalign {

using Vec3 = Eigen::Vector3d;
using Vec3f = Eigen::Vector3f;
using Mat3 = Eigen::Matrix3d;
using Mat6 = Eigen::Matrix<double, 6, 6>;
using Vec6 = Eigen::Matrix<double, 6, 1>;
using Iso3 = Eigen::Isometry3d;

constexpr double kDegPerRad = 57.29577951308232;
constexpr double kRadPerDeg = 1.0 / kDegPerRad;

/// ZYX Euler angles (R = Rz(yaw) * Ry(pitch) * Rx(roll)), radians, as [roll, pitch, yaw].
Vec3 rpy_from_rotation(const Mat3& R);
Mat3 rotation_from_rpy(const Vec3& rpy_rad);

/// Build a transform from translation (m) and ZYX roll, pitch, yaw (deg).
Iso3 make_transform(const Vec3& t_m, const Vec3& rpy_deg);

/// SO(3) exponential and logarithm (rotation vector, radians).
Mat3 so3_exp(const Vec3& omega_rad);
Vec3 so3_log(const Mat3& R);

/// The one perturbation of the extrinsic every stage optimises and reports in: R' = exp(w) R,
/// t' = t + rho, delta = [rho; w], so w is about the INS axes (yaw = about the INS vertical)
/// whatever the mount.
Iso3 perturb_in_ins_frame(const Iso3& T_ins_lidar, const Vec6& delta_rho_omega);

/// An angle wrapped to [-pi, pi].
double wrap_pi(double angle_rad);

/// Orthonormalise a nearly-rotation matrix (closest rotation in the Frobenius norm).
Mat3 nearest_rotation(const Mat3& M);

/// M += q q^T on the upper triangle only: point moments are sums of these per point, and half
/// the products do. mirror_upper(M) then gives exactly the full sums (q_i q_j == q_j q_i).
template <int N>
void add_outer_upper(Eigen::Matrix<double, N, N>& M, const Eigen::Matrix<double, N, 1>& q) {
  for (int j = 0; j < N; ++j)
    for (int i = 0; i <= j; ++i) M(i, j) += q(i) * q(j);
}
/// M += w q q^T on the upper triangle, as Eigen's selfadjointView<Upper>().rankUpdate(q, w) sums it
/// (the same bits), without its run-time sized loops: a point's normal equations are made of these.
template <int N>
void add_weighted_outer_upper(Eigen::Matrix<double, N, N>& M, const Eigen::Matrix<double, N, 1>& q, double w) {
  for (int j = 0; j < N; ++j) {
    const double wq = w * q(j);
    for (int i = 0; i <= j; ++i) M(i, j) += wq * q(i);
  }
}
template <int N>
void mirror_upper(Eigen::Matrix<double, N, N>& M) {
  for (int j = 0; j < N; ++j)
    for (int i = j + 1; i < N; ++i) M(i, j) = M(j, i);
}

/// Error of an estimate against a ground truth in the INS frame, as CONVENTIONS.md defines it.
struct ExtrinsicError {
  Vec3 dt_m;          ///< |t_est - t_gt| per axis, metres
  Vec3 drpy_deg;      ///< |roll|, |pitch|, |yaw| of R_est * R_gt^T (ZYX), degrees
  double angle_deg;   ///< rotation angle of R_est * R_gt^T
  double dt_norm_m;   ///< norm of t_est - t_gt
};
ExtrinsicError extrinsic_error(const Iso3& T_ins_lidar_est, const Iso3& T_ins_lidar_gt);

}  // namespace insalign
