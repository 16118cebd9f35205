#include "core/observability.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <limits>
#include <sstream>
#include <vector>

namespace insalign {

// Why these thresholds.
// Noise test (1 cm, 0.05 deg): the calibration must reach about 2 cm and 0.1 deg. The formal
// standard deviation assumes independent residuals of standard deviation sigma, which is
// optimistic (neighbouring points share plane-fitting and downsampling errors), so it must be
// well inside the target: half of it. A DOF the motion does not excite (standstill: all; no
// turns: x, y and the rotation about the travel direction) has a formal deviation of metres or
// degrees, far from the line.
// Leverage test (0.5 mm at 2 cm / 0.1 deg): per-frame INS pose errors (~1 cm position noise, a few
// cm of drift, ~0.01-0.03 deg attitude) move all points of a frame together, so they do not
// average out over points and the noise test cannot see them. A DOF is only trusted if moving it
// by the accuracy target moves the points by a clearly measurable amount. Measured leverages
// (simulated figure-8, Pandar64): rotation and x, y move points by 1-3 cm at the target in the
// intersection scene, x and y by only ~2 mm in a feature-poor one (the RMS is over all points and
// most are ground, which x and y do not move; those drives still calibrate to ~1 mm); tz by
// 0.02-0.2 mm (only the vehicle's ~0.7 deg of roll/pitch levers it), standstill and straight
// drives by ~0 for the unexcited DOFs. 0.5 mm sits a factor ~3 from both the weakest determined DOF
// and tz. Without this test the noise test declared tz determined (formal 3 mm) on a
// drive where the estimate was 10 cm off.

bool DofVerdict::all_determined() const {
  for (bool d : determined)
    if (!d) return false;
  return true;
}

namespace {

/// "tx: +-3.1 cm (limit 1 cm), a 2 cm change moves the points 1.2 mm RMS (2 mm needed)".
std::string dof_numbers(const DofVerdict& v, int i, const ObservabilityConfig& c) {
  const bool trans = i < 3;
  const double unit = trans ? 100.0 : kDegPerRad;  // cm or deg
  const char* u = trans ? "cm" : "deg";
  std::ostringstream os;
  os.precision(2);
  os << kDofNames[i] << ": +-" << v.stddev_at_removal(i) * unit << ' ' << u << " (limit "
     << (trans ? c.max_stddev_trans_m * 100.0 : c.max_stddev_rot_deg) << ' ' << u << ")";
  if (v.shift_at_target_m(i) > 0.0) {
    os << ", a " << (trans ? c.target_trans_m * 100.0 : c.target_rot_deg) << ' ' << u << " change moves the points "
       << v.shift_at_target_m(i) * 1e3 << " mm RMS (" << c.min_shift_m * 1e3 << " mm needed)";
  }
  return os.str();
}

std::string describe(const DofVerdict& v, const ObservabilityConfig& config) {
  std::vector<int> undetermined;
  for (int i = 0; i < 6; ++i)
    if (!v.determined[i]) undetermined.push_back(i);
  if (undetermined.empty()) return "all six degrees of freedom are determined";
  std::ostringstream os;
  os << "undetermined:";
  for (int i : undetermined) os << ' ' << kDofNames[i];
  os << ". ";
  const bool txy = !v.determined[0] || !v.determined[1];
  const bool any_rot = !v.determined[3] || !v.determined[4] || !v.determined[5];
  if (undetermined.size() == 6) {
    os << "The frames hardly move relative to each other (standing still) or share no planes: the "
          "point clouds line up the same whatever the extrinsic.";
    return os.str();
  }
  if (txy && !v.determined[5] && v.determined[3] && v.determined[4]) {
    os << "The scene shows planes of too few orientations (e.g. only the ground): nothing constrains "
          "horizontal shifts or the rotation about the vertical. ";
  } else if (txy) {
    os << "The horizontal lever arm shows only when vertical surfaces (walls, poles) are seen from "
          "different headings: too little turning, or too little but ground in view. ";
  }
  if (any_rot && !( txy && !v.determined[5] && v.determined[3] && v.determined[4])) {
    os << "Rotation about an axis the motion never changes (driving straight leaves the rotation "
          "about the travel direction free). ";
  }
  if (!v.determined[2]) {
    os << "tz: the vertical offset shows only through roll and pitch of the vehicle, which planar "
          "driving lacks; fiducials or a height prior determine it. ";
  }
  os << "Measured:";
  for (std::size_t k = 0; k < undetermined.size(); ++k) os << (k ? "; " : " ") << dof_numbers(v, undetermined[k], config);
  os << '.';
  return os.str();
}

}  // namespace

DofVerdict assess_observability(const Mat6& information, double residual_sigma_m, const ObservabilityConfig& config) {
  return assess_observability(information, residual_sigma_m, 0.0, config);
}

DofVerdict assess_observability(const Mat6& information, double residual_sigma_m, double residual_count,
                                const ObservabilityConfig& config) {
  DofVerdict v;
  Vec6 target;
  target << Vec3::Constant(config.target_trans_m), Vec3::Constant(config.target_rot_deg * kRadPerDeg);
  const double sigma = residual_sigma_m > 0.0 ? residual_sigma_m : 1.0;
  Vec6 limit;
  limit << Vec3::Constant(config.max_stddev_trans_m), Vec3::Constant(config.max_stddev_rot_deg * kRadPerDeg);
  // Dimensionless information: eigenvalue >= 1 means that direction is known to within the limits.
  const Mat6 scaled = limit.asDiagonal() * information * limit.asDiagonal() / (sigma * sigma);
  const Mat6 sym = 0.5 * (scaled + scaled.transpose());
  v.information_eigen = Eigen::SelfAdjointEigenSolver<Mat6>(sym, Eigen::EigenvaluesOnly).eigenvalues();

  std::vector<int> free{0, 1, 2, 3, 4, 5};
  const bool finite = information.allFinite() && std::isfinite(sigma);
  while (finite && !free.empty()) {
    const int n = static_cast<int>(free.size());
    Eigen::MatrixXd H(n, n);
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) H(a, b) = sym(free[a], free[b]);
    // Scaled so that a ratio (stddev / limit) = sqrt(diag(H^-1)); a tiny ridge keeps exactly
    // singular blocks invertible (their directions then show huge ratios and are removed).
    const double ridge = 1e-12 * std::max(1.0, H.trace());
    H += ridge * Eigen::MatrixXd::Identity(n, n);
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(H);
    const Eigen::MatrixXd cov = ldlt.solve(Eigen::MatrixXd::Identity(n, n));
    int worst = -1;
    double worst_ratio = 1.0;
    std::vector<double> shifts(n, 0.0);
    for (int a = 0; a < n; ++a) {
      const double c = cov(a, a);
      const bool ok = ldlt.info() == Eigen::Success && c > 0.0 && std::isfinite(c);
      double ratio = ok ? std::sqrt(c) : 1e300;
      if (ok && residual_count > 0.0) {
        // Unscaled (H^-1)_aa = c * limit^2 / sigma^2; RMS shift per unit = 1 / sqrt(N (H^-1)_aa).
        const int i = free[a];
        const double shift = target(i) * sigma / (limit(i) * std::sqrt(c * residual_count));
        ratio = std::max(ratio, config.min_shift_m / shift);
        shifts[a] = shift;
      }
      if (ratio > worst_ratio) {
        worst_ratio = ratio;
        worst = a;
      }
    }
    if (worst < 0) {
      for (int a = 0; a < n; ++a) {
        const int i = free[a];
        v.determined[i] = true;
        v.stddev(i) = std::sqrt(cov(a, a)) * limit(i);
        if (residual_count > 0.0)
          v.shift_at_target_m(i) = target(i) * sigma / (limit(i) * std::sqrt(cov(a, a) * residual_count));
      }
      break;
    }
    v.shift_at_target_m(free[worst]) = shifts[worst];  // at removal: how far from the line it was
    if (const double c = cov(worst, worst); c > 0.0 && std::isfinite(c)) {
      v.stddev_at_removal(free[worst]) = std::sqrt(c) * limit(free[worst]);
    } else {
      v.stddev_at_removal(free[worst]) = std::numeric_limits<double>::infinity();
    }
    free.erase(free.begin() + worst);
  }
  v.explanation = describe(v, config);
  return v;
}

std::optional<std::string> unobservable_reason(const DofVerdict& verdict) {
  for (int i : {0, 1, 3, 4, 5}) {
    if (!verdict.determined[i]) return "the data cannot determine the extrinsic: " + verdict.explanation;
  }
  return std::nullopt;
}

}  // namespace insalign
