// Which degrees of freedom of the extrinsic the data determines, from the information matrix of
// the point-to-plane residuals (Gauss-Newton J^T J, residuals in metres).
//
// Perturbation (the same in every stage that reports it): in the INS frame, R' = exp(w) R,
// t' = t + rho, ordered [rho_x rho_y rho_z w_x w_y w_z] = tx ty tz (m), roll pitch yaw (rad);
// so tz is the INS vertical and yaw is the rotation about it.
#pragma once

#include <array>
#include <limits>
#include <optional>
#include <string>

#include "core/geometry.hpp"
#include "core/stage.hpp"

namespace insalign {

struct ObservabilityConfig {
  /// Test 1 (noise): a DOF's standard deviation (sigma * sqrt of the diagonal of the inverse
  /// information over the determined block) must be below these.
  double max_stddev_trans_m = 0.01;
  double max_stddev_rot_deg = 0.05;
  /// Test 2 (leverage; needs the residual count): changing the DOF by the accuracy target (the
  /// others re-fitted) must move the points by at least min_shift_m RMS, or per-frame INS pose
  /// errors, common to all points of a frame, can mimic it however many points there are.
  double target_trans_m = 0.02;
  double target_rot_deg = 0.1;
  double min_shift_m = 0.0005;
  /// See observability.cpp for why these values.
};

template <class V>
void visit_config(V& v, ObservabilityConfig& c) {
  v("max_stddev_trans_m", c.max_stddev_trans_m, "a translation DOF is determined below this standard deviation, m");
  v("max_stddev_rot_deg", c.max_stddev_rot_deg, "a rotation DOF is determined below this standard deviation, deg");
  v("target_trans_m", c.target_trans_m, "leverage test: translation change the points must feel, m");
  v("target_rot_deg", c.target_rot_deg, "leverage test: rotation change the points must feel, deg");
  v("min_shift_m", c.min_shift_m, "leverage test: RMS point shift needed at the target change, m");
}

struct DofVerdict {
  std::array<bool, 6> determined{};  ///< tx ty tz roll pitch yaw
  Vec6 stddev = Vec6::Constant(std::numeric_limits<double>::infinity());  ///< m, rad; inf if undetermined
  /// Eigenvalues (ascending) of the information scaled by the noise test's limits and sigma:
  /// >= 1 means that direction passes the noise test.
  Vec6 information_eigen = Vec6::Zero();
  /// Per DOF: RMS point shift, metres, when the DOF moves by its accuracy target (others
  /// re-fitted); 0 if the residual count was not given.
  Vec6 shift_at_target_m = Vec6::Zero();
  /// Per undetermined DOF: its standard deviation (m, rad) when it was removed; 0 otherwise.
  Vec6 stddev_at_removal = Vec6::Zero();
  std::string explanation;           ///< human readable: which DOFs and why

  bool all_determined() const;
};

/// Per-DOF verdict from the 6x6 information (J^T J) and the residual standard deviation.
/// Undetermined DOFs are removed greedily (largest standard deviation first) until the rest
/// all meet the thresholds.
DofVerdict assess_observability(const Mat6& information, double residual_sigma_m,
                                const ObservabilityConfig& config = {});
/// Both tests; residual_count = the (weighted) number of point-to-plane residuals in information.
DofVerdict assess_observability(const Mat6& information, double residual_sigma_m, double residual_count,
                                const ObservabilityConfig& config = {});

/// Throw-free: the reason the extrinsic cannot be calibrated (any DOF other than tz undetermined),
/// or nothing. tz alone undetermined is expected for planar driving (fiducials or a height
/// prior fix it later) and is not a reason.
std::optional<std::string> unobservable_reason(const DofVerdict& verdict);

}  // namespace insalign
