// Scan-to-scan registration: point-to-plane ICP between two point clouds (used by the global
// initialisation to measure LiDAR relative motion for hand-eye calibration), and the planar
// target it associates with (also used to register a LiDAR's sweeps to another's map).
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <vector>

#include "core/geometry.hpp"

namespace insalign {

struct ScanRegistrationConfig {
  int max_iterations = 30;                ///< Gauss-Newton iterations over all stages
  double max_corr_dist_start_m = 1.5;     ///< correspondence gate of the first iteration
  double max_corr_dist_end_m = 0.3;       ///< gate shrinks geometrically to this
  int normal_neighbours = 8;              ///< k nearest target points for a target normal
  double max_plane_thickness_m = 0.08;    ///< target points whose neighbourhood is thicker get no normal
  double huber_delta_m = 0.1;             ///< robust kernel on point-to-plane residuals
  double converged_step_m = 1e-4;         ///< stop when the update is below this (m and rad)
  int min_inliers = 100;                  ///< fewer correspondences: not converged
};

struct ScanRegistrationResult {
  Iso3 T_target_source = Iso3::Identity();
  bool converged = false;
  int iterations = 0;
  int num_inliers = 0;
  double rms_m = 0.0;          ///< RMS point-to-plane residual of the inliers at the end
  double inlier_ratio = 0.0;   ///< inliers / source points at the final gate
  /// Smallest eigenvalue of the 6x6 Gauss-Newton information, normalised by inliers: a small value
  /// flags a degenerate (corridor-like) geometry whose motion along some direction is unknown.
  double min_information = 0.0;
};

/// A point's last nearest-neighbour search, kept between iterations: while the point has moved
/// less than the gap its search left (to the second nearest target point, or to the gate), the
/// next search is certain to give the same answer and is skipped.
struct NearestMemo {
  Vec3 p_searched = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());  ///< NaN: none yet
  double clear_m = 0.0;  ///< no target point but `index` lay closer than this to p_searched
  std::uint32_t index = kNoIndex;  ///< the nearest within the gate then, or kNoIndex
  static constexpr std::uint32_t kNoIndex = std::numeric_limits<std::uint32_t>::max();
};

/// When a PlaneTarget fits its normals.
enum class NormalFit {
  kUpFront,   ///< all in the constructor: the target may be shared between threads
  kOnDemand,  ///< each on first use (a scan-to-scan ICP meets a fraction of the target's points);
              ///< the same normals, but the target must then stay in one thread, or its users
              ///< fit the normals they will read first (fit_normals) and then only read
};

/// A target cloud ready for point-to-plane association: a kd-tree and, per point, the normal of
/// its k nearest neighbours (none where that patch is thicker than max_plane_thickness_m or a line).
class PlaneTarget {
 public:
  PlaneTarget(std::vector<Vec3> points, int normal_neighbours, double max_plane_thickness_m,
              NormalFit fit = NormalFit::kUpFront);
  ~PlaneTarget();
  PlaneTarget(PlaneTarget&&) noexcept;
  PlaneTarget& operator=(PlaneTarget&&) noexcept;

  /// The target point nearest to p within gate_m (nearer than it). `memo`: the same source point's
  /// last search, updated; the answer is the same as without it.
  std::optional<std::size_t> nearest(const Vec3& p, double gate_m, NearestMemo& memo) const;
  /// The target point nearest to p within gate_m, if it has a normal.
  std::optional<std::size_t> nearest_planar(const Vec3& p, double gate_m) const {
    NearestMemo memo;
    const std::optional<std::size_t> j = nearest(p, gate_m, memo);
    return j && !normal(*j).isZero() ? j : std::nullopt;
  }
  const Vec3& point(std::size_t i) const { return points_[i]; }
  /// Zero where point i has no normal.
  const Vec3& normal(std::size_t i) const {
    if (!fitted_[i]) fit_normal(i, knn_index_, knn_d2_);
    return normals_[i];
  }
  std::size_t size() const { return points_.size(); }
  /// Fits the normals of `indices` (repeats and kNoIndex allowed) not fitted yet, in parallel: the
  /// same normals as normal() fits one at a time. Not concurrently with any other call; after it,
  /// normal() of those points only reads, so threads may share the target.
  void fit_normals(const std::vector<std::uint32_t>& indices) const;

 private:
  struct Tree;
  void fit_normal(std::size_t i, std::vector<std::uint32_t>& idx, std::vector<double>& d2) const;
  std::vector<Vec3> points_;
  std::size_t neighbours_;
  double max_thickness_m_;
  mutable std::vector<Vec3> normals_;
  mutable std::vector<char> fitted_;
  mutable std::vector<std::uint32_t> knn_index_;  // fit_normal's scratch
  mutable std::vector<double> knn_d2_;
  std::unique_ptr<Tree> tree_;
};

/// The Gauss-Newton system of point-to-plane residuals r_i = n_i . (T p_i - q_i) for fixed
/// associations (source p_i to target point q_i with normal n_i), Huber-weighted, in the left
/// perturbation T <- exp([rho; omega]) T. Exposed so a test can check its Jacobian numerically.
struct PointToPlaneSystem {
  double cost = 0.0;        ///< sum of 0.5 w r^2
  double sum_sq_m2 = 0.0;   ///< sum of r^2 (unweighted)
  Vec6 gradient = Vec6::Zero();
  Mat6 hessian = Mat6::Zero();
};
PointToPlaneSystem point_to_plane_system(const std::vector<Vec3>& p_source, const std::vector<Vec3>& q_target,
                                         const std::vector<Vec3>& n_target, const Iso3& T_target_source,
                                         double huber_delta_m);

/// Point-to-plane ICP: finds T_target_source so that T_target_source * source lies on target surfaces.
ScanRegistrationResult register_scans(const std::vector<Vec3>& target, const std::vector<Vec3>& source,
                                      const Iso3& T_target_source_init,
                                      const ScanRegistrationConfig& config = {});

}  // namespace insalign
