#include "core/tz_coupling.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>

namespace insalign {

double ins_height_sigma_m(const FrameStore& store, double assumed_m) {
  double best = std::numeric_limits<double>::infinity(), sum_sq = 0.0;
  std::size_t n = 0;
  for (const InsQuality& q : store.data().ins_quality) {
    if (!std::isfinite(q.vertical_stddev_m) || store.excluded(q.t_s, q.t_s)) continue;
    best = std::min(best, q.vertical_stddev_m);
    sum_sq += q.vertical_stddev_m * q.vertical_stddev_m;
    ++n;
  }
  if (n == 0) return assumed_m;
  const double growth_sq = std::max(0.0, sum_sq / static_cast<double>(n) - best * best);
  return std::sqrt(assumed_m * assumed_m + growth_sq);
}

TzCoupling tz_coupling(const FrameStore& store, const std::vector<std::size_t>& frames, const Iso3& T_ins_lidar,
                       double time_offset_s, bool time_offset_free, const RefineConfig& config, double tz_sigma_m) {
  TzCoupling out;
  out.tz_sigma_m = tz_sigma_m;
  const std::vector<RefineSystem> systems = refine_systems(store, frames, {{T_ins_lidar, time_offset_s}}, config);
  if (systems.empty() || systems.front().points < 100) return out;
  const Eigen::Matrix<double, 7, 7>& H = systems.front().hessian;
  // The DOFs stage 2 estimates with tz held: [tx ty roll pitch yaw (offset)]. A tz change dz
  // moves their optimum by -H_ff^-1 H_f,tz dz.
  std::vector<int> free = {0, 1, 3, 4, 5};
  if (time_offset_free) free.push_back(6);
  const int n = static_cast<int>(free.size());
  Eigen::MatrixXd H_ff(n, n);
  Eigen::VectorXd H_fz(n);
  for (int a = 0; a < n; ++a) {
    H_fz[a] = H(free[a], 2);
    for (int b = 0; b < n; ++b) H_ff(a, b) = H(free[a], free[b]);
  }
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(H_ff);
  if (ldlt.info() != Eigen::Success) return out;
  const Eigen::VectorXd d = -ldlt.solve(H_fz);
  if (!d.allFinite()) return out;
  out.dxy_dtz = d.head<2>();
  out.stddev_added_m = out.dxy_dtz.cwiseAbs() * tz_sigma_m;
  out.drpy_dtz = d.segment<3>(2);
  out.rpy_stddev_added_rad = out.drpy_dtz.cwiseAbs() * tz_sigma_m;
  out.ok = true;
  return out;
}

}  // namespace insalign
